#include "worker/bake/atlas_bake.h"

#include <chrono>
#include <fstream>
#include <future>
#include <map>
#include <optional>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/atlas/atlas_layout.h"
#include "common/request/bake_request.h"
#include "common/atlas/frame_camera.h"
#include "common/request/layout_parameters.h"
#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "worker/bake/auto_frames.h"
#include "worker/bake/bake_outputs.h"
#include "worker/bake/ktx2_maps.h"
#include "worker/bake/quality_pass.h"
#include "worker/bake/texture_array_output.h"
#include "worker/output/atlas_dilation.h"
#include "worker/output/contact_sheet.h"
#include "worker/output/cutout_hull.h"
#include "worker/output/map_writer.h"
#include "worker/scene/bounding_sphere.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Progress fractions at which each stage starts.
constexpr double kLoadStart = 0.05, kRenderStart = 0.15, kEncodeStart = 0.80, kEncodeEnd = 0.95;

// How each map's channels are encoded; written into the manifest.
const std::vector<std::string> kAlbedoChannels = {
    "R: base colour red (texture x factor, unlit), sRGB", "G: base colour green, sRGB",
    "B: base colour blue, sRGB", "A: coverage, the fraction of the texel's supersamples the mesh covers: 0 = empty, 255 = fully "
    "covered (MASK cut at alphaCutoff); colour is the covered samples' mean (straight alpha)"};
const std::vector<std::string> kNormalDepthChannels = {
    "R: scene-space normal x * 0.5 + 0.5 (normal map applied)", "G: normal y * 0.5 + 0.5",
    "B: normal z * 0.5 + 0.5",
    "A: depth along the view direction, (1 - dot(p - centre, direction) / radius) / 2: 0 = nearest point of "
    "the bounding sphere, 1 = farthest; 16-bit because 8 bits quantise depth to radius/128"};
const std::vector<std::string> kContactSheetChannels = {
    "RGB: for people, not for engines: albedo over a checkerboard, coverage, normal, depth and ORM panels "
    "side by side, labelled"};
const std::vector<std::string> kOrmChannels = {
    "R: ambient occlusion (1 + strength * (texture.r - 1)), linear", "G: roughness (factor x texture.g), linear",
    "B: metalness (factor x texture.b), linear", "A: coverage, as albedo_alpha.A"};

const std::vector<std::string> kEmissiveChannels = {
    "R: emissive red (texture x emissiveFactor x KHR_materials_emissive_strength, unlit), sRGB, clamped to 1",
    "G: emissive green, sRGB", "B: emissive blue, sRGB", "A: coverage, as albedo_alpha.A"};

// `known`: digests taken when the maps were written (MapWritten); any
// other file is hashed here.
absl::Status AddMap(const std::filesystem::path& dir, const std::string& semantic, const std::string& format,
                    const std::vector<std::string>& channels, int size, v1::Manifest* manifest,
                    const std::map<std::string, BlobDigest>& known = {}) {
  const std::string file = semantic + ".png";
  const auto it = known.find(file);
  auto digest = it != known.end() ? absl::StatusOr<BlobDigest>(it->second) : DigestFile(dir / file);
  if (!digest.ok()) return digest.status();
  v1::MapFile* map = manifest->add_maps();
  map->set_semantic(semantic);
  map->set_file(file);
  map->mutable_digest()->set_hash(digest->hash);
  map->mutable_digest()->set_size_bytes(digest->size_bytes);
  map->set_width(static_cast<uint32_t>(size));
  map->set_height(static_cast<uint32_t>(size));
  map->set_format(format);
  for (const auto& c : channels) map->add_channels(c);
  return absl::OkStatus();
}

// A map file whose bytes are final: hashed once (AddMap reuses the
// digest) and handed to request.map_written, so the worker can upload it
// while the quality pass still runs.
absl::StatusOr<BlobDigest> MapWritten(const std::filesystem::path& file, const AtlasBakeRequest& request) {
  absl::StatusOr<BlobDigest> digest = DigestFile(file);
  if (digest.ok() && request.map_written) request.map_written(file, *digest);
  return digest;
}

}  // namespace

absl::StatusOr<std::shared_ptr<const Scene>> SceneOf(const AtlasBakeRequest& request) {
  if (request.scene) return request.scene;
  absl::StatusOr<Scene> scene = LoadGltfScene(request.entry_file, request.load_limits);
  if (!scene.ok()) return scene.status();
  return std::make_shared<const Scene>(*std::move(scene));
}

absl::StatusOr<AtlasBakeOutput> BakeAtlas(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                          const BakeProgress& progress, const std::atomic<bool>& cancelled) {
  // frames_auto bakes a ladder of frame counts through this function.
  if (request.parameters.frames_auto()) return BakeAtlasAutoFrames(request, renderer, progress, cancelled);
  const auto start = Clock::now();
  const v1::BakeParameters& p = request.parameters;
  const int frames = static_cast<int>(p.frames());
  const int resolution = static_cast<int>(p.resolution());
  v1::Manifest manifest;
  v1::BakeTimings* timings = manifest.mutable_timings();

  // Load.
  progress("load", kLoadStart);
  auto t = Clock::now();
  absl::StatusOr<std::shared_ptr<const Scene>> loaded = SceneOf(request);
  if (!loaded.ok()) return loaded.status();
  const Scene* scene = loaded->get();
  timings->set_load_seconds(SecondsSince(t));
  if (cancelled) return absl::CancelledError("cancelled after loading");

  // Prepare.
  absl::StatusOr<BoundingSphere> framing = FramingSphere(*scene);
  if (!framing.ok()) return framing.status();
  const BoundingSphere sphere = *framing;
  const ViewLayout view_layout = ViewLayoutOf(p);
  const std::vector<FrameCamera> cameras = AtlasCameras(view_layout, resolution);

  // Render.
  progress("render", kRenderStart);
  if (cancelled) return absl::CancelledError("cancelled before rendering");
  RenderTimings render_timings;
  // The quality pass renders the mesh again: its views reuse this upload.
  const bool quality_pass = p.has_quality_views() ? p.quality_views() > 0 : true;
  std::optional<ScopedKeptScene> kept_upload;
  if (quality_pass) kept_upload.emplace(renderer, *scene);
  renderer.set_cancel_flag(&cancelled);
  renderer.set_emissive(p.emissive());
  // Supersampling: every tile rendered `ss` times larger, then filtered
  // down on the device (worker/gpu/supersample_resolve.h, the semantics of
  // worker/output/supersample.h), so only the final maps are read back.
  // Unset (requests not normalised by the server, e.g. in tests) renders at
  // the resolution itself.
  const int ss = p.has_supersampling() ? static_cast<int>(p.supersampling()) : 1;
  const std::vector<FrameCamera> render_cameras = SupersampledCameras(cameras, ss);
  renderer.set_supersampling(ss);
  renderer.set_resolve_on_device(true);
  auto atlas = renderer.Render(
      *scene, sphere, render_cameras, resolution * ss,
      [&](double f) { progress("render", kRenderStart + f * (kEncodeStart - kRenderStart)); }, &render_timings);
  renderer.set_cancel_flag(nullptr);
  renderer.set_emissive(false);
  renderer.set_supersampling(1);
  renderer.set_resolve_on_device(false);
  if (!atlas.ok()) return atlas.status();
  timings->set_render_seconds(render_timings.upload_seconds + render_timings.render_seconds);
  timings->set_readback_seconds(render_timings.readback_seconds);
  if (cancelled) return absl::CancelledError("cancelled after rendering");

  // Post-process and write.
  progress("encode", kEncodeStart);
  t = Clock::now();
  std::vector<TileRect> tiles;
  for (const FrameCamera& c : cameras) tiles.push_back(c.tile);
  // One convex polygon around every frame's opaque texels, for cutout quads.
  auto cutout = ComputeCutout(atlas->albedo_alpha, atlas->width, atlas->height, tiles);
  if (!cutout.ok()) return cutout.status();
  const double cutout_seconds = SecondsSince(t);
  // Dilation fills empty texels' colour from the silhouette so mipmaps and
  // bilinear filtering never pull in black; coverage stays untouched. The
  // three maps are independent (normal_depth only reads albedo's alpha,
  // which dilation never writes), so they are processed in parallel.
  const int w = atlas->width, h = atlas->height;
  const std::filesystem::path& dir = request.output_dir;
  // --texture-format ktx2 writes the maps as KTX2 below instead of PNG.
  const bool png = p.texture_format() != v1::TEXTURE_FORMAT_KTX2;
  auto albedo = std::async(std::launch::async, [&] { return DilateRgba8(atlas->albedo_alpha, w, h, tiles); });
  auto orm = std::async(std::launch::async, [&] { return DilateRgba8(atlas->orm, w, h, tiles); });
  absl::Status normal = DilateRgba16(atlas->normal_depth, atlas->albedo_alpha, w, h, tiles);
  for (absl::Status s : {albedo.get(), orm.get(), normal}) {
    if (!s.ok()) return s;
  }
  if (p.emissive()) {
    if (auto s = DilateRgba8(atlas->emissive, w, h, tiles); !s.ok()) return s;
  }
  const int tile = TileSize(resolution, GridSide(view_layout));
  const double post_seconds = SecondsSince(t);
  // The maps are final now. Encoding them (PNG or KTX2, contact sheet,
  // texture arrays) only reads them, so it runs on its own threads while
  // the quality pass below renders from a copy; the bytes written do not
  // depend on the overlap (request.serial_encode runs it first instead).
  struct Encoded {
    std::vector<v1::MapFile> ktx2_maps;
    ContactSheetInfo sheet;
    std::map<std::string, BlobDigest> png_digests;  // by file name, as MapWritten took them
    double seconds = 0;
    double maps_seconds = 0;   // the maps (PNG or KTX2), hashed
    double sheet_seconds = 0;  // the contact sheet
  };
  // --array rewrites the PNG maps as strips after the contact sheet: they
  // are final only then.
  const bool maps_final_when_written = !p.texture_array();
  auto encode = [&]() -> absl::StatusOr<Encoded> {
    const auto encode_start = Clock::now();
    Encoded out;
    // The maps side by side for a person's first look (contact_sheet.h),
    // beside the maps' encoders: it reads only the maps in memory. (After
    // them, it was a sixth of the stage on 2 cores and more on 16.)
    auto sheet = std::async(std::launch::async, [&] {
      const auto sheet_start = Clock::now();
      auto written = WriteContactSheet(dir / "contact_sheet.png",
                                       {.width = w, .height = h, .albedo_alpha = atlas->albedo_alpha,
                                        .normal_depth = atlas->normal_depth, .orm = atlas->orm,
                                        .emissive = atlas->emissive});
      out.sheet_seconds = SecondsSince(sheet_start);
      return written;
    });
    // Writes one PNG map and, once final, hashes it on the same thread.
    auto write_png = [&](const std::string& file, auto write) -> absl::StatusOr<BlobDigest> {
      if (absl::Status s = write(dir / file); !s.ok()) return s;
      if (!maps_final_when_written) return BlobDigest{};
      return MapWritten(dir / file, request);
    };
    if (png) {
      auto albedo_png = std::async(std::launch::async, [&] {
        return write_png("albedo_alpha.png",
                         [&](const std::filesystem::path& f) { return WritePngRgba8(f, atlas->albedo_alpha, w, h); });
      });
      auto orm_png = std::async(std::launch::async, [&] {
        return write_png("orm.png", [&](const std::filesystem::path& f) { return WritePngRgba8(f, atlas->orm, w, h); });
      });
      absl::StatusOr<BlobDigest> normal_png = write_png("normal_depth.png", [&](const std::filesystem::path& f) {
        return WritePngRgba16(f, atlas->normal_depth, w, h);
      });
      std::vector<std::pair<std::string, absl::StatusOr<BlobDigest>>> written;
      written.emplace_back("albedo_alpha.png", albedo_png.get());
      written.emplace_back("orm.png", orm_png.get());
      written.emplace_back("normal_depth.png", std::move(normal_png));
      if (p.emissive()) {
        written.emplace_back("emissive.png", write_png("emissive.png", [&](const std::filesystem::path& f) {
                               return WritePngRgba8(f, atlas->emissive, w, h);
                             }));
      }
      for (auto& [file, digest] : written) {
        if (!digest.ok()) return digest.status();
        if (maps_final_when_written) out.png_digests[file] = *digest;
      }
    } else {
      auto written = WriteKtx2Maps(dir, {.width = w,
                                         .height = h,
                                         .albedo_alpha = atlas->albedo_alpha,
                                         .normal_depth = atlas->normal_depth,
                                         .orm = atlas->orm,
                                         .emissive = p.emissive() ? std::span<const uint8_t>(atlas->emissive)
                                                                  : std::span<const uint8_t>(),
                                         .tiles = tiles,
                                         .levels = MipSafeLevels(resolution, GridSide(view_layout)) + 1,
                                         .albedo_codec = p.albedo_codec(),
                                         .cancelled = &cancelled});
      if (!written.ok()) return written.status();
      out.ktx2_maps = std::move(*written);
      if (request.map_written && maps_final_when_written) {
        for (const v1::MapFile& map : out.ktx2_maps) {
          request.map_written(dir / map.file(), {map.digest().hash(), map.digest().size_bytes()});
        }
      }
    }
    out.maps_seconds = SecondsSince(encode_start);
    absl::StatusOr<ContactSheetInfo> sheet_written = sheet.get();
    if (!sheet_written.ok()) return sheet_written.status();
    if (!sheet_written->labelled) spdlog::warn("event=contact_sheet_unlabelled reason=\"no TrueType font found\"");
    out.sheet = *sheet_written;
    // --array: the maps as texture arrays (layer strips) instead of atlases.
    if (p.texture_array()) {
      if (auto s = WriteTextureArrays(dir, *atlas, tiles, p.emissive()); !s.ok()) return s;
      if (png) {
        for (const char* file : {"albedo_alpha.png", "normal_depth.png", "orm.png", "emissive.png"}) {
          if (std::string_view(file) == "emissive.png" && !p.emissive()) continue;
          auto digest = MapWritten(dir / file, request);
          if (!digest.ok()) return digest.status();
          out.png_digests[file] = *digest;
        }
      }
    }
    out.seconds = SecondsSince(encode_start);
    return out;
  };
  // Declared after `atlas`, so an early return waits for the encoders
  // (a std::async future blocks in its destructor) before the maps go.
  std::future<absl::StatusOr<Encoded>> encoding =
      std::async(request.serial_encode ? std::launch::deferred : std::launch::async, encode);
  if (request.serial_encode) encoding.wait();

  // Quality: the mesh from held-out views against the impostor as a game
  // draws it from the maps as written (quality_pass.h), on a copy of the
  // maps while the encoders read them. Its time is logged. Its map entries
  // go into their own manifest, appended after the maps' below, so the
  // manifest's order is the serial one.
  v1::Manifest quality_manifest;
  if (quality_pass) {
    AtlasImages quality_maps{.width = w, .height = h, .albedo_alpha = atlas->albedo_alpha,
                             .normal_depth = atlas->normal_depth, .orm = atlas->orm, .emissive = {}};
    absl::Status quality = AddAtlasQuality(*scene, sphere, cameras, std::move(quality_maps), p, request.cache_key,
                                           dir, renderer, &quality_manifest, request.quality_overrides);
    if (!quality.ok()) return quality;
  }
  kept_upload.reset();
  absl::StatusOr<Encoded> encoded = encoding.get();
  if (!encoded.ok()) return encoded.status();
  std::vector<v1::MapFile> ktx2_maps = std::move(encoded->ktx2_maps);
  const ContactSheetInfo* sheet = &encoded->sheet;
  // Post-processing plus encoding, whether or not the encoding overlapped
  // the quality pass.
  timings->set_encode_seconds(post_seconds + encoded->seconds);
  // The encode stage's parts, for a profile (BAKE_STAGES_DEBUG=1 in bake_stages).
  spdlog::debug("event=encode_steps cache_key={} cutout={:.3f} dilate={:.3f} maps={:.3f} sheet={:.3f} encode={:.3f}",
                request.cache_key, cutout_seconds, post_seconds - cutout_seconds, encoded->maps_seconds,
                encoded->sheet_seconds, encoded->seconds);
  progress("encode", kEncodeEnd);

  // Manifest.
  manifest.set_format_version(kManifestFormatVersion);
  manifest.set_cache_key(request.cache_key);
  manifest.set_baker_version(std::string(BakerVersion()));
  manifest.set_layout(p.layout());
  manifest.set_frames(p.frames());
  manifest.set_resolution(p.resolution());
  manifest.set_tile_size(static_cast<uint32_t>(TileSize(resolution, frames)));
  for (int i = 0; i < 3; ++i) manifest.mutable_bounding_sphere()->add_center(sphere.center[i]);
  manifest.mutable_bounding_sphere()->set_radius(sphere.radius);
  const BoundingBox box = ComputeBoundingBox(*scene);
  for (int i = 0; i < 3; ++i) manifest.mutable_bounding_box()->add_min(box.min[i]);
  for (int i = 0; i < 3; ++i) manifest.mutable_bounding_box()->add_max(box.max[i]);
  for (glm::vec2 v : cutout->vertices) {
    manifest.mutable_cutout()->add_vertices(v.x);
    manifest.mutable_cutout()->add_vertices(v.y);
  }
  manifest.mutable_cutout()->set_area_ratio(cutout->area_ratio);
  for (v1::MapFile& map : ktx2_maps) {
    const std::string& m = map.semantic();
    const std::vector<std::string>& channels = m == "albedo_alpha" ? kAlbedoChannels
                                               : m == "normal_depth" ? kNormalDepthChannels
                                               : m == "orm"          ? kOrmChannels
                                                                     : kEmissiveChannels;
    // The depth map describes its own channels (ktx2_maps.h).
    if (map.channels_size() == 0) {
      for (const auto& c : channels) map.add_channels(c);
    }
    *manifest.add_maps() = std::move(map);
  }
  if (png) {
    const auto& known = encoded->png_digests;
    if (auto s = AddMap(dir, "albedo_alpha", "png_rgba8", kAlbedoChannels, resolution, &manifest, known); !s.ok()) {
      return s;
    }
    if (auto s = AddMap(dir, "normal_depth", "png_rgba16", kNormalDepthChannels, resolution, &manifest, known);
        !s.ok()) {
      return s;
    }
    if (auto s = AddMap(dir, "orm", "png_rgba8", kOrmChannels, resolution, &manifest, known); !s.ok()) return s;
    if (p.emissive()) {
      if (auto s = AddMap(dir, "emissive", "png_rgba8", kEmissiveChannels, resolution, &manifest, known); !s.ok()) {
        return s;
      }
    }
  }
  if (p.texture_array()) {
    for (v1::MapFile& map : *manifest.mutable_maps()) {
      map.set_width(static_cast<uint32_t>(tile));
      map.set_height(static_cast<uint32_t>(tile) * static_cast<uint32_t>(cameras.size()));
    }
  }
  if (auto s = AddMap(dir, "contact_sheet", "png_rgb8", kContactSheetChannels, 0, &manifest); !s.ok()) return s;
  manifest.mutable_maps(manifest.maps_size() - 1)->set_width(static_cast<uint32_t>(sheet->width));
  manifest.mutable_maps(manifest.maps_size() - 1)->set_height(static_cast<uint32_t>(sheet->height));
  manifest.MergeFrom(quality_manifest);  // the quality pass's maps and figures
  for (const FrameCamera& c : cameras) {
    v1::View* v = manifest.add_views();
    v->set_index(static_cast<uint32_t>(c.index));
    for (int i = 0; i < 3; ++i) v->add_direction(c.direction[i]);
    for (int i = 0; i < 3; ++i) v->add_up(c.up[i]);
    // Texture arrays: the view's layer in the strip.
    const TileRect r = p.texture_array() ? LayerRect(c.index, tile) : c.tile;
    v->mutable_tile()->set_x(static_cast<uint32_t>(r.x));
    v->mutable_tile()->set_y(static_cast<uint32_t>(r.y));
    v->mutable_tile()->set_width(static_cast<uint32_t>(r.width));
    v->mutable_tile()->set_height(static_cast<uint32_t>(r.height));
    v->set_same_view_as(static_cast<uint32_t>(CanonicalFrameIndex(view_layout, c.index)));
  }
  manifest.mutable_mesh()->set_triangles(scene->TriangleCount());
  manifest.mutable_mesh()->set_materials(static_cast<uint32_t>(scene->materials.size()));
  manifest.mutable_mesh()->set_textures(static_cast<uint32_t>(scene->textures.size()));
  // What the loader worked around (skipped points/lines, dropped images,
  // MASK without alpha...) travels with the result.
  for (const std::string& w : scene->warnings) manifest.add_warnings(w);
  manifest.set_device(renderer.device().name);
  timings->set_total_seconds(SecondsSince(start));

  absl::StatusOr<AtlasBakeOutput> out = WriteManifest(dir, std::move(manifest));
  if (!out.ok()) return out.status();
  spdlog::debug("event=bake_done cache_key={} triangles={} seconds={:.2f}", request.cache_key,
                scene->TriangleCount(), SecondsSince(start));
  return out;
}

}  // namespace impostor
