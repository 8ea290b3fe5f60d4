#include "worker/bake/surfel_bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <numbers>

#include <glm/geometric.hpp>
#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/atlas/atlas_layout.h"
#include "common/request/bake_request.h"
#include "common/atlas/frame_camera.h"
#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "worker/bake/bake_outputs.h"
#include "worker/scene/bounding_sphere.h"
#include "worker/scene/gltf_loader.h"
#include "worker/surfels/atlas_samples.h"
#include "worker/surfels/ply_writer.h"
#include "worker/surfels/point_buffer.h"
#include "worker/surfels/splat_renderer.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Progress fractions at which each stage starts.
constexpr double kLoadStart = 0.05, kRenderStart = 0.15, kClusterStart = 0.65, kQualityStart = 0.8,
                 kWriteStart = 0.9, kWriteEnd = 0.95;

// Voxels smaller than this fraction of a capture texel are not tried: the
// views together sample the surface a few times denser than one view's
// texels, but not arbitrarily densely, and smaller cells would only split
// samples of the same spot and leave holes between splats.
constexpr float kMinVoxelPerTexel = 0.25f;

const std::vector<std::string> kBufferChannels = {
    "f0..2: position x, y, z, scene space, scene units", "f3..5: unit normal x, y, z, scene space",
    "f6..8: albedo r, g, b, linear 0..1", "f9..11: occlusion, roughness, metalness, linear 0..1"};
const std::vector<std::string> kPlyChannels = {
    "x, y, z: float32 position", "nx, ny, nz: float32 unit normal", "red, green, blue: uint8 albedo, sRGB",
    "occlusion, roughness, metalness: float32"};

// Renders the mesh from held-out directions on the GPU and the cloud on the
// CPU, and compares them.
absl::StatusOr<SurfelQualityFigures> JudgeCloud(const Scene& scene, const SurfelCloudResult& cloud, bool upper_only,
                                                AtlasRenderer& renderer) {
  SurfelQualityFigures q;
  q.views = kQualityViews;
  q.view_pixels = std::clamp(static_cast<int>(std::lround(2.0f * cloud.sphere.radius / cloud.voxel_size)),
                             kMinQualityPixels, kMaxQualityPixels);
  constexpr int kGrid = 3;  // 3 x 3 tiles hold the 8 views
  std::vector<FrameCamera> cameras;
  const std::vector<glm::vec3> dirs = HeldOutDirections(kQualityViews, upper_only);
  for (int i = 0; i < kQualityViews; ++i) {
    FrameCamera c;
    c.index = i;
    c.direction = dirs[i];
    c.up = CameraUpFor(c.direction);
    c.right = glm::normalize(glm::cross(c.up, c.direction));
    c.tile = {(i % kGrid) * q.view_pixels, (i / kGrid) * q.view_pixels, q.view_pixels, q.view_pixels};
    cameras.push_back(c);
  }
  RenderTimings timings;
  auto reference = renderer.Render(scene, cloud.sphere, cameras, kGrid * q.view_pixels, {}, &timings);
  if (!reference.ok()) return reference.status();
  double iou_sum = 0, squared_error = 0;
  size_t both = 0;
  q.iou_min = 1.0;
  for (const FrameCamera& c : cameras) {
    const SplatImage splats = RenderSplats(cloud.points, cloud.point_diameter, c, cloud.sphere, q.view_pixels);
    const ViewComparison cmp = CompareWithAtlasTile(splats, *reference, c.tile);
    iou_sum += cmp.Iou();
    q.iou_min = std::min(q.iou_min, cmp.Iou());
    squared_error += cmp.albedo_squared_error;
    both += cmp.both;
  }
  q.iou_mean = iou_sum / kQualityViews;
  q.albedo_psnr_db = PsnrDb(both == 0 ? 1.0 : squared_error / (3.0 * both));
  return q;
}

}  // namespace

absl::StatusOr<SurfelCloudResult> BakeSurfelCloud(const Scene& scene, const v1::BakeParameters& p,
                                                  AtlasRenderer& renderer, const BakeProgress& progress,
                                                  const std::atomic<bool>& cancelled) {
  SurfelCloudResult cloud;
  absl::StatusOr<BoundingSphere> framing = FramingSphere(scene);
  if (!framing.ok()) return framing.status();
  cloud.sphere = *framing;
  const LayoutKind layout = ToLayoutKind(p.layout());
  const int frames = static_cast<int>(p.frames());
  const int resolution = static_cast<int>(p.resolution());
  // Frames on the octahedron's folded border repeat a view: capture each
  // direction once, so that no direction's samples weigh double.
  std::vector<FrameCamera> cameras;
  for (const FrameCamera& c : AtlasCameras(layout, frames, resolution)) {
    if (CanonicalFrame(layout, frames, c.frame) == c.frame) cameras.push_back(c);
  }

  progress("render", kRenderStart);
  renderer.set_cancel_flag(&cancelled);
  auto atlas = renderer.Render(
      scene, cloud.sphere, cameras, resolution,
      [&](double f) { progress("render", kRenderStart + f * (kClusterStart - kRenderStart)); },
      &cloud.capture_timings);
  renderer.set_cancel_flag(nullptr);
  if (!atlas.ok()) return atlas.status();
  if (cancelled) return absl::CancelledError("cancelled after rendering");

  progress("encode", kClusterStart);
  auto t = Clock::now();
  std::vector<Surfel> samples = AtlasToSamples(*atlas, cameras, cloud.sphere);
  atlas->albedo_alpha = {};
  atlas->normal_depth = {};
  atlas->orm = {};
  cloud.sample_count = samples.size();
  if (samples.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("mesh: no texel of the ", cameras.size(),
                                                   " capture frames is covered (everything culled or cut by "
                                                   "alpha?); there is nothing to turn into surfels"));
  }
  const float texel = 2.0f * cloud.sphere.radius / static_cast<float>(TileSize(resolution, frames));
  cloud.fit = FitVoxelSizeToBudget(samples, p.point_budget(), kMinVoxelPerTexel * texel);
  cloud.voxel_size = cloud.fit.voxel_size;
  cloud.point_diameter = cloud.voxel_size * std::numbers::sqrt2_v<float>;
  cloud.points = BinSamples(samples, VoxelGrid{BoundsOf(samples).min, cloud.voxel_size});
  samples = {};
  cloud.cluster_seconds = SecondsSince(t);
  if (cancelled) return absl::CancelledError("cancelled after clustering");

  progress("encode", kQualityStart);
  t = Clock::now();
  auto quality = JudgeCloud(scene, cloud, layout == LayoutKind::kHemiOctahedral, renderer);
  if (!quality.ok()) return quality.status();
  cloud.quality = *quality;
  cloud.quality_seconds = SecondsSince(t);
  return cloud;
}

absl::StatusOr<AtlasBakeOutput> BakeSurfels(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                            const BakeProgress& progress, const std::atomic<bool>& cancelled) {
  const auto start = Clock::now();
  const v1::BakeParameters& p = request.parameters;
  v1::Manifest manifest;
  v1::BakeTimings* timings = manifest.mutable_timings();

  progress("load", kLoadStart);
  auto t = Clock::now();
  absl::StatusOr<std::shared_ptr<const Scene>> loaded = SceneOf(request);
  if (!loaded.ok()) return loaded.status();
  const Scene* scene = loaded->get();
  timings->set_load_seconds(SecondsSince(t));
  if (cancelled) return absl::CancelledError("cancelled after loading");

  auto cloud = BakeSurfelCloud(*scene, p, renderer, progress, cancelled);
  if (!cloud.ok()) return cloud.status();
  timings->set_render_seconds(cloud->capture_timings.upload_seconds + cloud->capture_timings.render_seconds);
  timings->set_readback_seconds(cloud->capture_timings.readback_seconds);

  progress("encode", kWriteStart);
  t = Clock::now();
  const std::filesystem::path& dir = request.output_dir;
  const auto n = static_cast<uint32_t>(cloud->points.size());
  auto buffer_digest = WriteFileWithDigest(dir / kSurfelBufferFile, EncodePointBuffer(cloud->points));
  if (!buffer_digest.ok()) return buffer_digest.status();
  const std::vector<std::string> comments = {
      absl::StrCat("impostor surfels baker ", std::string(BakerVersion()), " cache_key ", request.cache_key),
      absl::StrCat("voxel_size ", cloud->voxel_size, " point_diameter ", cloud->point_diameter,
                   " (draw each point as a camera-facing square of this side)")};
  auto ply_digest = WriteFileWithDigest(dir / kSurfelPlyFile, EncodePly(cloud->points, comments));
  if (!ply_digest.ok()) return ply_digest.status();

  manifest.set_format_version(kManifestFormatVersion);
  manifest.set_cache_key(request.cache_key);
  manifest.set_baker_version(std::string(BakerVersion()));
  manifest.set_product(v1::PRODUCT_SURFELS);
  manifest.set_layout(p.layout());
  manifest.set_frames(p.frames());
  manifest.set_resolution(p.resolution());
  manifest.set_tile_size(static_cast<uint32_t>(TileSize(static_cast<int>(p.resolution()), static_cast<int>(p.frames()))));
  for (int i = 0; i < 3; ++i) manifest.mutable_bounding_sphere()->add_center(cloud->sphere.center[i]);
  manifest.mutable_bounding_sphere()->set_radius(cloud->sphere.radius);
  auto add_map = [&](const char* semantic, const char* file, const char* format, const v1::Digest& digest,
                     const std::vector<std::string>& channels) {
    v1::MapFile* map = manifest.add_maps();
    map->set_semantic(semantic);
    map->set_file(file);
    *map->mutable_digest() = digest;
    map->set_width(n);
    map->set_height(1);
    map->set_format(format);
    for (const auto& c : channels) map->add_channels(c);
  };
  add_map("surfels", kSurfelBufferFile, kPointBufferFormat, *buffer_digest, kBufferChannels);
  add_map("surfels_ply", kSurfelPlyFile, kPlyFormat, *ply_digest, kPlyChannels);

  v1::SurfelCloud* s = manifest.mutable_surfels();
  s->set_file(kSurfelBufferFile);
  *s->mutable_digest() = *buffer_digest;
  s->set_ply_file(kSurfelPlyFile);
  *s->mutable_ply_digest() = *ply_digest;
  s->set_point_count(n);
  s->set_point_budget(p.point_budget());
  s->set_budget_fill(static_cast<float>(n) / static_cast<float>(p.point_budget()));
  s->set_voxel_size(cloud->voxel_size);
  s->set_point_diameter(cloud->point_diameter);
  SampleBounds box = BoundsOf(cloud->points);
  for (int i = 0; i < 3; ++i) s->add_bounds_min(box.min[i]);
  for (int i = 0; i < 3; ++i) s->add_bounds_max(box.max[i]);
  s->set_stride_bytes(static_cast<uint32_t>(kPointStrideBytes));
  s->set_sample_count(cloud->sample_count);
  s->set_capture_layout(p.layout());
  s->set_capture_frames(p.frames());
  s->set_capture_resolution(p.resolution());
  v1::SurfelQuality* q = s->mutable_quality();
  q->set_views(static_cast<uint32_t>(cloud->quality.views));
  q->set_view_pixels(static_cast<uint32_t>(cloud->quality.view_pixels));
  q->set_silhouette_iou_mean(static_cast<float>(cloud->quality.iou_mean));
  q->set_silhouette_iou_min(static_cast<float>(cloud->quality.iou_min));
  q->set_albedo_psnr_db(static_cast<float>(cloud->quality.albedo_psnr_db));

  manifest.mutable_mesh()->set_triangles(scene->TriangleCount());
  manifest.mutable_mesh()->set_materials(static_cast<uint32_t>(scene->materials.size()));
  manifest.mutable_mesh()->set_textures(static_cast<uint32_t>(scene->textures.size()));
  manifest.set_device(renderer.device().name);
  timings->set_encode_seconds(cloud->cluster_seconds + cloud->quality_seconds + SecondsSince(t));
  timings->set_total_seconds(SecondsSince(start));

  absl::StatusOr<AtlasBakeOutput> out = WriteManifest(dir, std::move(manifest));
  if (!out.ok()) return out.status();
  progress("encode", kWriteEnd);
  spdlog::info(
      "event=surfel_bake_done cache_key={} samples={} points={} budget={} fill={:.4f} voxel_size={:.6g} "
      "evaluations={} iou_mean={:.4f} iou_min={:.4f} albedo_psnr_db={:.2f} seconds={:.2f}",
      request.cache_key, cloud->sample_count, n, p.point_budget(), s->budget_fill(), cloud->voxel_size,
      cloud->fit.evaluations, cloud->quality.iou_mean, cloud->quality.iou_min, cloud->quality.albedo_psnr_db,
      SecondsSince(start));
  return out;
}

}  // namespace impostor
