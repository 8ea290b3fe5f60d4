#include "worker/bake/lod_bake.h"

#include <chrono>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/manifest/manifest_json.h"
#include "worker/bake/bake_outputs.h"
#include "worker/lod/lod_glb_writer.h"
#include "worker/lod/lod_levels.h"
#include "worker/lod/lod_source.h"
#include "worker/lod/lod_thresholds.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Progress: mesh levels up to kMeshEnd, then the impostor's own stages.
constexpr double kLoadStart = 0.02, kMeshStart = 0.05, kMeshEnd = 0.30, kImpostorEnd = 0.97;

void AddFile(const std::string& semantic, const std::string& file, const v1::Digest& digest,
             const std::string& format, const std::string& what, v1::Manifest* m) {
  v1::MapFile* map = m->add_maps();
  map->set_semantic(semantic);
  map->set_file(file);
  *map->mutable_digest() = digest;
  map->set_format(format);
  map->add_channels(what);
}

}  // namespace

absl::StatusOr<AtlasBakeOutput> BakeLodChain(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                             const BakeProgress& progress, const std::atomic<bool>& cancelled) {
  const auto start = Clock::now();
  const v1::BakeParameters& p = request.parameters;
  const fs::path& dir = request.output_dir;
  progress("load", kLoadStart);
  // The hardened loader is the gate for untrusted input (sandbox, limits,
  // empty meshes); the model is parsed for the levels only once it passed.
  if (auto scene = SceneOf(request); !scene.ok()) return scene.status();
  auto source = LoadLodSource(request.entry_file, request.load_limits);
  if (!source.ok()) return source.status();
  const double load_seconds = SecondsSince(start);

  v1::Manifest chain;
  // Textures once, shared by every level.
  const std::vector<std::string> textures = LodTextureFileNames(source->model);
  for (size_t i = 0; i < textures.size(); ++i) {
    const auto& bytes = source->model.images[i].image;
    auto digest = WriteFileWithDigest(dir / textures[i], std::string_view(reinterpret_cast<const char*>(bytes.data()),
                                                                           bytes.size()));
    if (!digest.ok()) return digest.status();
    AddFile("lod_texture", textures[i], *digest, textures[i].substr(textures[i].rfind('.') + 1),
            absl::StrCat("image ", i, " of the input, referenced by URI from every lod<N>.glb"), &chain);
  }

  std::vector<float> ratios = {1.0f};
  for (float r : p.lod_ratios()) ratios.push_back(r);
  std::vector<float> errors;
  const uint64_t original = [&] {
    std::vector<size_t> counts;
    for (const LodPrimitive& prim : source->primitives) counts.push_back(prim.indices.size());
    return source->DrawnTriangles(counts);
  }();
  progress("simplify", kMeshStart);
  auto levels = BuildMeshLevels(*source, ratios, textures);
  if (!levels.ok()) return levels.status();
  if (cancelled) return absl::CancelledError("cancelled while simplifying");
  for (size_t level = 0; level < levels->size(); ++level) {
    const MeshLevel* built = &(*levels)[level].mesh;
    const float error = built->error;
    const bool sloppy = built->sloppy, unlocked = built->unlocked;
    const std::string file = absl::StrCat("lod", level, ".glb");
    auto digest = WriteFileWithDigest(dir / file, built->glb);
    if (!digest.ok()) return digest.status();
    const uint64_t triangles = built->triangles;
    v1::LodLevel* l = chain.add_lods();
    l->set_level(static_cast<uint32_t>(level));
    l->set_kind("mesh");
    l->set_file(file);
    *l->mutable_digest() = *digest;
    l->set_triangles(triangles);
    l->set_target_ratio(ratios[level]);
    l->set_error(error);
    l->set_sloppy(sloppy);
    errors.push_back(error);
    AddFile("lod_mesh", file, *digest, "glb", absl::StrCat("LOD", level, " mesh, glTF 2.0 binary"), &chain);
    if (sloppy) {
      chain.add_warnings(absl::StrCat("lod", level, ": quadric simplification could not reach ratio ",
                                      ratios[level], "; sloppy simplification was used"));
    } else if (unlocked) {
      chain.add_warnings(absl::StrCat("lod", level, ": open borders were unlocked to reach ratio ", ratios[level]));
    }
    if (built->welded) {
      chain.add_warnings(absl::StrCat("lod", level, ": UV/normal seams were welded to reach ratio ", ratios[level]));
    }
    spdlog::info(
        "event=lod_level level={} triangles={} original={} target_ratio={} error={} measured_error={} sloppy={} "
        "welded={} unlocked={} seconds={:.3f}",
        level, triangles, original, ratios[level], error, (*levels)[level].measured_error, sloppy, built->welded,
        unlocked, built->seconds);
  }

  // The impostor: a plain atlas bake of the same input, in a scratch folder
  // whose files are then moved up (result files are flat names).
  if (cancelled) return absl::CancelledError("cancelled before the impostor");
  const fs::path impostor_dir = dir / ".impostor";
  std::error_code ec;
  fs::create_directories(impostor_dir, ec);
  if (ec) return absl::InternalError(absl::StrCat("cannot create ", impostor_dir.string(), ": ", ec.message()));
  AtlasBakeRequest atlas_request = request;
  atlas_request.output_dir = impostor_dir;
  atlas_request.parameters.set_product(v1::PRODUCT_ATLAS);
  atlas_request.parameters.clear_lod_ratios();
  atlas_request.parameters.clear_lod_pixel_error();
  auto atlas = BakeAtlas(
      atlas_request, renderer,
      [&](std::string_view stage, double f) { progress(stage, kMeshEnd + f * (kImpostorEnd - kMeshEnd)); },
      cancelled);
  if (!atlas.ok()) return atlas.status();
  for (const v1::MapFile& map : atlas->manifest.maps()) {
    if (fs::exists(dir / map.file())) {
      return absl::InternalError(absl::StrCat("impostor map ", map.file(), " collides with a LOD file"));
    }
    fs::rename(impostor_dir / map.file(), dir / map.file(), ec);
    if (ec) return absl::InternalError(absl::StrCat("cannot move ", map.file(), ": ", ec.message()));
    *chain.add_maps() = map;
  }
  fs::rename(atlas->manifest_path, dir / kLodImpostorManifestFile, ec);
  if (ec) return absl::InternalError(absl::StrCat("cannot move the impostor manifest: ", ec.message()));
  fs::remove_all(impostor_dir, ec);
  const v1::Digest impostor_digest = atlas->manifest.manifest_json();
  AddFile("impostor_manifest", kLodImpostorManifestFile, impostor_digest, "json",
          "the impostor level's atlas manifest (manifest.json format, product atlas)", &chain);

  // Thresholds from the measured errors, in the SDK's unit. The impostor
  // takes over below the on-screen size its quality pass found it good for
  // (issue 43: good_up_to_pixels, the bounding sphere's diameter on screen);
  // without a pass (quality_views 0), or when it met its targets at no size,
  // below the fixed kImpostorDiameterPixels.
  const float radius = atlas->manifest.bounding_sphere().radius();
  const v1::AtlasQuality& quality = atlas->manifest.quality();
  const float impostor_pixels =
      quality.good_up_to_pixels() > 0 ? static_cast<float>(quality.good_up_to_pixels()) : kImpostorDiameterPixels;
  if (quality.sizes_size() > 0 && quality.good_up_to_pixels() == 0) {
    chain.add_warnings(absl::StrCat("impostor: meets its good-for targets at no measured size (",
                                    quality.sizes(0).pixels(), "..", quality.sizes(quality.sizes_size() - 1).pixels(),
                                    " px); it takes over below ", kImpostorDiameterPixels,
                                    " px, the fixed rule: more frames or a larger atlas would let it take over "
                                    "sooner"));
  }
  const std::vector<float> thresholds = LodThresholds(errors, radius, p.lod_pixel_error(), impostor_pixels);
  for (size_t i = 0; i < errors.size(); ++i) chain.mutable_lods(static_cast<int>(i))->set_threshold(thresholds[i]);
  // A level whose threshold equals the one before it is never drawn (the
  // SDK's rule): its error would show before the next switch. Files an
  // artist ships and never sees must be said, not found out.
  std::vector<std::string> never_drawn;
  for (size_t i = 1; i < errors.size(); ++i) {
    if (thresholds[i] >= thresholds[i - 1]) never_drawn.push_back(absl::StrCat("lod", i));
  }
  if (!never_drawn.empty()) {
    chain.add_warnings(absl::StrCat(absl::StrJoin(never_drawn, ", "), never_drawn.size() == 1 ? " is" : " are",
                                    " never drawn: its geometric error would show more than lod_pixel_error pixels "
                                    "until the impostor takes over, so the level before it is drawn down to the "
                                    "next switch; milder --lod-ratios keep such levels"));
  }
  v1::LodLevel* imp = chain.add_lods();
  imp->set_level(static_cast<uint32_t>(errors.size()));
  imp->set_kind("impostor");
  imp->set_file(kLodImpostorManifestFile);
  *imp->mutable_digest() = impostor_digest;
  imp->set_triangles(2);
  imp->set_target_ratio(0);
  imp->set_error(0);
  imp->set_threshold(0);

  // The chain's manifest: the impostor's description (layout, frames,
  // sphere, views, quality...) with the chain's product, files and levels.
  v1::Manifest manifest = atlas->manifest;
  manifest.clear_manifest_json();
  manifest.set_product(v1::PRODUCT_LOD_CHAIN);
  manifest.clear_maps();
  for (const v1::MapFile& map : chain.maps()) *manifest.add_maps() = map;
  *manifest.mutable_lods() = chain.lods();
  for (const std::string& w : source->warnings) manifest.add_warnings(w);
  for (const std::string& w : chain.warnings()) manifest.add_warnings(w);
  manifest.mutable_mesh()->set_triangles(original);
  v1::BakeTimings* timings = manifest.mutable_timings();
  timings->set_load_seconds(timings->load_seconds() + load_seconds);
  timings->set_total_seconds(SecondsSince(start));

  absl::StatusOr<AtlasBakeOutput> out = WriteManifest(dir, std::move(manifest));
  if (!out.ok()) return out.status();
  progress("encode", 1.0);
  return out;
}

}  // namespace impostor
