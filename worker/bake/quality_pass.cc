#include "worker/bake/quality_pass.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <utility>

#include <glm/geometric.hpp>
#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/atlas/frame_camera.h"
#include "common/request/layout_parameters.h"
#include "common/util/parallel_for.h"
#include "common/util/sha256.h"
#include "worker/bake/bake_outputs.h"
#include "worker/bake/good_for_size.h"
#include "worker/output/map_writer.h"
#include "worker/output/supersample.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;

// FNV-1a: a stable 64-bit seed from the cache key (any string).
uint64_t SeedFromKey(std::string_view key) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : key) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

// splitmix64: the next uniform number in [0, 1) from a running state.
double NextUniform(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
}

// Rodrigues' rotation of v about unit `axis` by `angle` radians.
glm::vec3 Rotate(glm::vec3 v, glm::vec3 axis, float angle) {
  const float c = std::cos(angle), s = std::sin(angle);
  return v * c + glm::cross(axis, v) * s + axis * glm::dot(axis, v) * (1.0f - c);
}

float DegreesBetween(glm::vec3 a, glm::vec3 b) {
  return std::acos(std::clamp(glm::dot(a, b), -1.0f, 1.0f)) * 180.0f / std::numbers::pi_v<float>;
}

// One view's pixels, owned.
struct ViewBuffers {
  int size = 0;
  std::vector<uint8_t> albedo_alpha;
  std::vector<uint16_t> normal_depth;
  ViewPixels Pixels() const { return {size, size, albedo_alpha, normal_depth}; }
};

FrameCamera CameraFor(glm::vec3 direction, int index, int pixels, int columns) {
  FrameCamera c = ViewCameraFor(direction);
  c.index = index;
  c.tile = {(index % columns) * pixels, (index / columns) * pixels, pixels, pixels};
  return c;
}

// The mesh from every direction, as tiles of one atlas (one Render call),
// cut apart into one buffer per view. With `supersampling` > 1 rendered
// that many times larger and filtered down on the device, as the bake
// renders its frames.
absl::StatusOr<std::vector<ViewBuffers>> RenderMeshViews(const Scene& scene, const BoundingSphere& sphere,
                                                         const std::vector<glm::vec3>& directions, int pixels,
                                                         int supersampling, AtlasRenderer& renderer) {
  const int n = static_cast<int>(directions.size());
  const int columns = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
  std::vector<FrameCamera> cameras;
  for (int i = 0; i < n; ++i) cameras.push_back(CameraFor(directions[i], i, pixels, columns));
  renderer.set_supersampling(supersampling);
  renderer.set_resolve_on_device(supersampling > 1);
  RenderTimings timings;
  auto atlas = renderer.Render(scene, sphere, SupersampledCameras(cameras, supersampling),
                               columns * pixels * supersampling, {}, &timings);
  renderer.set_supersampling(1);
  renderer.set_resolve_on_device(false);
  if (!atlas.ok()) return atlas.status();
  spdlog::debug("event=quality_pass_mesh_views views={} pixels={} supersampling={} upload_seconds={:.3f} "
                "render_seconds={:.3f} readback_seconds={:.3f}",
                n, pixels, supersampling, timings.upload_seconds, timings.render_seconds, timings.readback_seconds);
  std::vector<ViewBuffers> views(n);
  const size_t row = static_cast<size_t>(pixels) * 4;
  for (int i = 0; i < n; ++i) {
    const TileRect& t = cameras[i].tile;
    ViewBuffers& v = views[i];
    v.size = pixels;
    v.albedo_alpha.resize(row * pixels);
    v.normal_depth.resize(row * pixels);
    for (int y = 0; y < pixels; ++y) {
      const size_t src = (static_cast<size_t>(t.y + y) * atlas->width + t.x) * 4;
      std::copy_n(atlas->albedo_alpha.begin() + src, row, v.albedo_alpha.begin() + y * row);
      std::copy_n(atlas->normal_depth.begin() + src, row, v.normal_depth.begin() + y * row);
    }
  }
  return views;
}

// The impostor from every direction, rendered on all cores (the reference
// renderer is pure).
std::vector<ViewBuffers> RenderImpostorViewsOnCpu(const ImpostorAtlas& atlas, const std::vector<glm::vec3>& directions,
                                                  int pixels, const ReferenceRenderOptions& options) {
  std::vector<ViewBuffers> views(directions.size());
  ParallelFor(directions.size(), [&](size_t i) {
    FrameCamera camera = ViewCameraFor(directions[i]);
    camera.tile = {0, 0, pixels, pixels};
    ViewImages image = RenderImpostorView(atlas, camera, pixels, options);
    views[i].size = pixels;
    views[i].albedo_alpha = std::move(image.albedo_alpha);
    views[i].normal_depth = std::move(image.normal_depth);
  });
  return views;
}

// CompareViews of every pair, on all cores: with the views drawn on a GPU
// the metrics (two SSIMs, a distance transform per pair) were the pass's
// largest cost (H100, 16 views of 256 px: 0.34 s of 1.2 s one pair at a time).
std::vector<ViewMetrics> CompareAll(const std::vector<ViewBuffers>& mesh, const std::vector<ViewBuffers>& impostor) {
  std::vector<ViewMetrics> out(mesh.size());
  ParallelFor(mesh.size(), [&](size_t i) { out[i] = CompareViews(mesh[i].Pixels(), impostor[i].Pixels()); });
  return out;
}

// Draws the impostor's views for the pass, on the device or on the CPU
// (QualityPassOptions::impostor_views_on).
class ImpostorViewSource {
 public:
  static absl::StatusOr<ImpostorViewSource> Create(const ImpostorAtlas& atlas, ImpostorViewsOn on,
                                                   AtlasRenderer& renderer) {
    ImpostorViewSource source(atlas);
    if (on == ImpostorViewsOn::kCpu || (on == ImpostorViewsOn::kAuto && renderer.device().type == "cpu")) {
      return source;
    }
    auto device = renderer.UploadImpostor(atlas);
    if (device.ok()) {
      source.device_ = std::move(*device);
    } else if (on == ImpostorViewsOn::kDevice) {
      return device.status();
    } else {
      spdlog::warn("event=quality_pass_device_views_unavailable device=\"{}\" error=\"{}\" fallback=cpu",
                   renderer.device().name, device.status().ToString());
    }
    return source;
  }

  bool on_device() const { return device_ != nullptr; }

  absl::StatusOr<std::vector<ViewBuffers>> Render(const std::vector<glm::vec3>& directions, int pixels,
                                                  BlendMode blend, Reconstruction reconstruction) const {
    const ReferenceRenderOptions options{.blend = blend, .reconstruction = reconstruction};
    if (!device_) return RenderImpostorViewsOnCpu(*atlas_, directions, pixels, options);
    std::vector<FrameCamera> cameras;
    for (const glm::vec3& d : directions) cameras.push_back(ViewCameraFor(d));
    auto images = device_->RenderViews(cameras, pixels, options);
    if (!images.ok()) return images.status();
    std::vector<ViewBuffers> views(images->size());
    for (size_t i = 0; i < views.size(); ++i) {
      views[i].size = pixels;
      views[i].albedo_alpha = std::move((*images)[i].albedo_alpha);
      views[i].normal_depth = std::move((*images)[i].normal_depth);
    }
    return views;
  }

 private:
  explicit ImpostorViewSource(const ImpostorAtlas& atlas) : atlas_(&atlas) {}
  const ImpostorAtlas* atlas_;
  std::unique_ptr<DeviceImpostor> device_;
};

// `count` of the baked frames' own directions, spread over the frames in
// index order (repeating when count > frames): on_frame_directions.
std::vector<glm::vec3> FrameDirections(const std::vector<FrameCamera>& frames, int count) {
  std::vector<glm::vec3> out;
  const size_t n = frames.size();
  for (int i = 0; i < count; ++i) {
    out.push_back(frames[(static_cast<size_t>(i) * n / count + n / (2 * count)) % n].direction);
  }
  return out;
}

// MeanAbsoluteAlbedoChange of every step's pair of views.
std::vector<double> StepChanges(const std::vector<ViewBuffers>& views, const std::vector<std::pair<int, int>>& steps) {
  std::vector<double> changes;
  changes.reserve(steps.size());
  for (const auto& [a, b] : steps) changes.push_back(MeanAbsoluteAlbedoChange(views[a].Pixels(), views[b].Pixels()));
  return changes;
}

// The impostor's views drawn `factor` x `factor` times larger and box
// filtered down as the mesh's supersampled views are (DownsampleMaps).
absl::StatusOr<std::vector<ViewBuffers>> RenderImpostorViewsSupersampled(const ImpostorViewSource& source,
                                                                        const std::vector<glm::vec3>& directions,
                                                                        int pixels, int factor, BlendMode blend,
                                                                        Reconstruction reconstruction) {
  auto rendered = source.Render(directions, pixels * factor, blend, reconstruction);
  if (!rendered.ok()) return rendered.status();
  std::vector<ViewBuffers> views = std::move(*rendered);
  for (ViewBuffers& v : views) {
    AtlasMaps maps{.width = v.size,
                   .height = v.size,
                   .albedo_alpha = std::move(v.albedo_alpha),
                   .normal_depth = std::move(v.normal_depth),
                   .orm = std::vector<uint8_t>(static_cast<size_t>(v.size) * v.size * 4, 0),
                   .emissive = {}};
    if (auto s = DownsampleMaps(factor, &maps); !s.ok()) return s;
    v.size = maps.width;
    v.albedo_alpha = std::move(maps.albedo_alpha);
    v.normal_depth = std::move(maps.normal_depth);
  }
  return views;
}

struct PopFigures {
  std::vector<double> pops;  // one per mode
  double antialiased_mesh = -1, antialiased = -1;  // the pop references, or -1
  double antialiased_seconds = 0;  // drawing and comparing the 3 x 3 orbits
};

// Pop of each of `modes` (the mesh's orbit is rendered once) and, with
// o.pop_references, the references of the first mode (quality_pass.h).
absl::StatusOr<PopFigures> MeasurePop(const Scene& scene, const ImpostorAtlas& atlas, const ImpostorViewSource& source,
                                      const QualityPassOptions& o, const std::vector<Reconstruction>& modes,
                                      AtlasRenderer& renderer) {
  const float elevation = o.orbit_elevation_deg * std::numbers::pi_v<float> / 180.0f;
  const float step = 2.0f * std::numbers::pi_v<float> / static_cast<float>(o.orbit_steps);
  auto at = [&](float azimuth) {
    return glm::vec3(std::cos(elevation) * std::sin(azimuth), std::sin(elevation),
                     std::cos(elevation) * std::cos(azimuth));
  };
  // Every step (orbit_pairs 0 or >= orbit_steps): n views, step i compares
  // views i and i + 1. Sampled: pair k compares the views at azimuth
  // k * 360 / orbit_pairs and one step further.
  const bool every_step = o.orbit_pairs <= 0 || o.orbit_pairs >= o.orbit_steps;
  std::vector<glm::vec3> orbit;
  std::vector<std::pair<int, int>> steps;
  if (every_step) {
    for (int i = 0; i < o.orbit_steps; ++i) {
      orbit.push_back(at(step * static_cast<float>(i)));
      steps.emplace_back(i, (i + 1) % o.orbit_steps);
    }
  } else {
    for (int k = 0; k < o.orbit_pairs; ++k) {
      const float azimuth =
          2.0f * std::numbers::pi_v<float> * static_cast<float>(k) / static_cast<float>(o.orbit_pairs);
      orbit.push_back(at(azimuth));
      orbit.push_back(at(azimuth + step));
      steps.emplace_back(2 * k, 2 * k + 1);
    }
  }
  auto mesh = RenderMeshViews(scene, atlas.sphere, orbit, o.orbit_pixels, /*supersampling=*/1, renderer);
  if (!mesh.ok()) return mesh.status();
  const std::vector<double> mesh_changes = StepChanges(*mesh, steps);
  PopFigures out;
  for (Reconstruction mode : modes) {
    auto impostor = source.Render(orbit, o.orbit_pixels, o.blend, mode);
    if (!impostor.ok()) return impostor.status();
    out.pops.push_back(PopRatio(StepChanges(*impostor, steps), mesh_changes));
  }
  if ((o.pop_antialiased || o.pop_references) && !modes.empty()) {
    const auto smooth_start = std::chrono::steady_clock::now();
    auto smooth_mesh = RenderMeshViews(scene, atlas.sphere, orbit, o.orbit_pixels, kReferenceSupersampling, renderer);
    if (!smooth_mesh.ok()) return smooth_mesh.status();
    const std::vector<double> smooth_mesh_changes = StepChanges(*smooth_mesh, steps);
    if (o.pop_references) out.antialiased_mesh = PopRatio(smooth_mesh_changes, mesh_changes);
    auto smooth = RenderImpostorViewsSupersampled(source, orbit, o.orbit_pixels, kReferenceSupersampling, o.blend,
                                                  modes.front());
    if (!smooth.ok()) return smooth.status();
    out.antialiased = PopRatio(StepChanges(*smooth, steps), smooth_mesh_changes);
    out.antialiased_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - smooth_start).count();
  }
  return out;
}

// The good-for sizes (good_for_size.h): every half octave of
// GoodForLadder(o.good_for_top_pixels) up to the first that misses, then a
// bisection on the fine ladder between the last good size and it. Each size
// is drawn as a game shows it there: the mesh at that size with
// kReferenceSupersampling; the impostor with one sample a pixel where its
// tiles are magnified, and where they are minified (a game samples mip
// levels, the reference renderer has none) drawn finer and box filtered,
// tile / size times (at most kGoodForMaxFilter). kGoodForViews of the
// held-out views; the pass's own drawings are reused where they are the same. Silhouette IoU and shared PSNR, means over the views.
absl::Status MeasureSizes(const Scene& scene, const ImpostorAtlas& atlas, const ImpostorViewSource& source,
                          const QualityPassOptions& o, const std::vector<glm::vec3>& all_directions,
                          const std::vector<ViewBuffers>& own_mesh, const std::vector<ViewBuffers>& own_impostor,
                          AtlasRenderer& renderer, v1::AtlasQuality* q) {
  // Every (total / n)-th view: the held-out set runs from the horizon up,
  // so a prefix would see the object from low elevations only.
  const size_t total = all_directions.size(), n = std::min(total, static_cast<size_t>(kGoodForViews));
  std::vector<size_t> picked;
  std::vector<glm::vec3> directions;
  for (size_t i = 0; i < n; ++i) {
    picked.push_back(i * total / n);
    directions.push_back(all_directions[picked.back()]);
  }
  const int tile = atlas.cameras.empty() ? 0 : atlas.cameras[0].tile.width;
  std::vector<v1::SizeQuality> sizes;
  auto measure = [&](int s) -> absl::StatusOr<bool> {
    const int filter = std::clamp((tile + s - 1) / s, 1, kGoodForMaxFilter);
    std::vector<ViewBuffers> mesh, impostor;
    const bool own = s == o.view_pixels;
    if (!own) {
      auto m = RenderMeshViews(scene, atlas.sphere, directions, s, kReferenceSupersampling, renderer);
      if (!m.ok()) return m.status();
      mesh = std::move(*m);
    }
    if (!own || filter > 1) {
      auto i = filter > 1
                   ? RenderImpostorViewsSupersampled(source, directions, s, filter, o.blend, o.reconstruction)
                   : source.Render(directions, s, o.blend, o.reconstruction);
      if (!i.ok()) return i.status();
      impostor = std::move(*i);
    }
    const std::vector<ViewBuffers>& a = own ? own_mesh : mesh;
    const std::vector<ViewBuffers>& b = own && filter == 1 ? own_impostor : impostor;
    std::vector<double> iou(n), psnr(n), firm(n);
    ParallelFor(n, [&](size_t v) {
      const ViewBuffers& mv = own ? a[picked[v]] : a[v];
      const ViewBuffers& iv = own && filter == 1 ? b[picked[v]] : b[v];
      const ViewPixels pa{s, s, mv.albedo_alpha, {}}, pb{s, s, iv.albedo_alpha, {}};
      iou[v] = SilhouetteIou(pa, pb);
      psnr[v] = AlbedoPsnrSharedDb(pa, pb);
      firm[v] = SilhouetteIouOutsideEdge(pa, pb);
    });
    double iou_mean = 0, psnr_mean = 0, firm_mean = 0;
    for (size_t v = 0; v < n; ++v) {
      iou_mean += iou[v] / static_cast<double>(n);
      psnr_mean += psnr[v] / static_cast<double>(n);
      firm_mean += firm[v] / static_cast<double>(n);
    }
    v1::SizeQuality& out = sizes.emplace_back();
    out.set_pixels(static_cast<uint32_t>(s));
    out.set_silhouette_iou_mean(static_cast<float>(iou_mean));
    out.set_albedo_psnr_shared_db_mean(static_cast<float>(psnr_mean));
    out.set_silhouette_iou_firm_mean(static_cast<float>(firm_mean));
    // Judged on the figures as the manifest records them (float), so a
    // reader re-judging them agrees; the IoU outside the mesh's own edge
    // (good_for_size.h).
    out.set_meets(
        MeetsGoodForTargets(o.good_for_targets, out.silhouette_iou_firm_mean(), out.albedo_psnr_shared_db_mean()));
    return out.meets();
  };
  auto by_size = [](const v1::SizeQuality& x, const v1::SizeQuality& y) { return x.pixels() < y.pixels(); };
  // Larger sizes than the first that misses cannot raise good_up_to_pixels.
  for (int s : GoodForLadder(o.good_for_top_pixels, kGoodForCoarseStepsPerOctave)) {
    auto met = measure(s);
    if (!met.ok()) return met.status();
    if (!*met) break;
  }
  // Bisect between the last good coarse size and the next one (which
  // missed), on the fine ladder.
  const uint32_t good = GoodUpToPixels(sizes);
  if (good > 0 && good < sizes.back().pixels()) {
    const uint32_t bad = std::find_if(sizes.begin(), sizes.end(), [](const auto& x) { return !x.meets(); })->pixels();
    std::vector<int> between;
    for (int s : GoodForLadder(o.good_for_top_pixels)) {
      if (s > static_cast<int>(good) && s < static_cast<int>(bad)) between.push_back(s);
    }
    while (!between.empty()) {
      const size_t mid = between.size() / 2;
      auto met = measure(between[mid]);
      if (!met.ok()) return met.status();
      between = *met ? std::vector<int>(between.begin() + mid + 1, between.end())
                     : std::vector<int>(between.begin(), between.begin() + mid);
    }
    std::sort(sizes.begin(), sizes.end(), by_size);
  }
  q->set_good_up_to_pixels(GoodUpToPixels(sizes));
  for (v1::SizeQuality& x : sizes) *q->add_sizes() = std::move(x);
  return absl::OkStatus();
}

// Mean and min (or max) of a per-view figure.
struct Summary {
  double min = 0, mean = 0, max = 0;
};
template <typename F>
Summary Summarise(const std::vector<ViewMetrics>& views, F figure) {
  Summary s;
  if (views.empty()) return s;
  s.min = s.max = figure(views[0]);
  for (const ViewMetrics& m : views) {
    const double v = figure(m);
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
    s.mean += v / static_cast<double>(views.size());
  }
  return s;
}

v1::ReconstructionQuality ModeFigures(Reconstruction mode, const std::vector<ViewMetrics>& views) {
  v1::ReconstructionQuality r;
  r.set_reconstruction(std::string(ReconstructionName(mode)));
  const Summary iou = Summarise(views, [](const ViewMetrics& m) { return m.iou; });
  const Summary psnr = Summarise(views, [](const ViewMetrics& m) { return m.albedo_psnr_shared_db; });
  const Summary ssim = Summarise(views, [](const ViewMetrics& m) { return m.albedo_ssim_shared; });
  const Summary boundary = Summarise(views, [](const ViewMetrics& m) { return m.boundary_error_px_mean; });
  const Summary boundary_max = Summarise(views, [](const ViewMetrics& m) { return m.boundary_error_px_max; });
  r.set_silhouette_iou_min(static_cast<float>(iou.min));
  r.set_silhouette_iou_mean(static_cast<float>(iou.mean));
  r.set_albedo_psnr_shared_db_min(static_cast<float>(psnr.min));
  r.set_albedo_psnr_shared_db_mean(static_cast<float>(psnr.mean));
  r.set_albedo_ssim_shared_min(static_cast<float>(ssim.min));
  r.set_albedo_ssim_shared_mean(static_cast<float>(ssim.mean));
  r.set_boundary_error_px_mean(static_cast<float>(boundary.mean));
  r.set_boundary_error_px_max(static_cast<float>(boundary_max.max));
  r.set_normal_error_deg_mean(
      static_cast<float>(Summarise(views, [](const ViewMetrics& m) { return m.normal_error_deg_mean; }).mean));
  r.set_depth_error_mean(
      static_cast<float>(Summarise(views, [](const ViewMetrics& m) { return m.depth_error_mean; }).mean));
  r.set_albedo_psnr_union_db_mean(
      static_cast<float>(Summarise(views, [](const ViewMetrics& m) { return m.albedo_psnr_db; }).mean));
  return r;
}

// mesh | impostor | difference, each upscaled by `scale` (nearest). Mesh and
// impostor are shown over dark grey; the difference is grey where both
// cover (4 x the mean absolute colour difference), magenta where only the
// mesh covers (the impostor misses it), cyan where only the impostor covers.
absl::Status WriteSideBySide(const std::filesystem::path& path, const ViewBuffers& mesh,
                             const ViewBuffers& impostor) {
  const int n = mesh.size, scale = n < 256 ? 2 : 1, w = 3 * n * scale, h = n * scale;
  std::vector<uint8_t> out(static_cast<size_t>(w) * h * 4, 255);
  auto put = [&](int panel, int x, int y, uint8_t r, uint8_t g, uint8_t b) {
    for (int dy = 0; dy < scale; ++dy) {
      for (int dx = 0; dx < scale; ++dx) {
        uint8_t* p = &out[((static_cast<size_t>(y * scale + dy) * w) + (panel * n + x) * scale + dx) * 4];
        p[0] = r, p[1] = g, p[2] = b, p[3] = 255;
      }
    }
  };
  constexpr uint8_t kBackground = 48;
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const size_t i = (static_cast<size_t>(y) * n + x) * 4;
      const uint8_t* a = &mesh.albedo_alpha[i];
      const uint8_t* b = &impostor.albedo_alpha[i];
      const bool ca = a[3] >= 128, cb = b[3] >= 128;
      if (ca) put(0, x, y, a[0], a[1], a[2]);
      else put(0, x, y, kBackground, kBackground, kBackground);
      if (cb) put(1, x, y, b[0], b[1], b[2]);
      else put(1, x, y, kBackground, kBackground, kBackground);
      if (ca && cb) {
        const int diff = (std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2])) * 4 / 3;
        const auto g = static_cast<uint8_t>(std::min(255, diff));
        put(2, x, y, g, g, g);
      } else if (ca) {
        put(2, x, y, 255, 0, 255);
      } else if (cb) {
        put(2, x, y, 0, 255, 255);
      } else {
        put(2, x, y, 0, 0, 0);
      }
    }
  }
  return WritePngRgba8(path, out, w, h);
}

}  // namespace

std::vector<glm::vec3> HeldOutViewDirections(LayoutKind layout, int frames, std::string_view cache_key, int count) {
  return HeldOutViewDirections(ViewLayoutFor(layout, frames), cache_key, count);
}

std::vector<glm::vec3> HeldOutViewDirections(const ViewLayout& layout, std::string_view cache_key, int count) {
  uint64_t state = SeedFromKey(cache_key);
  // Ring-top and billboard are drawn from near the horizon: their views
  // span elevations 0..60 degrees (y up to sin 60), like a hemisphere.
  const bool ring = layout.kind == LayoutKind::kRingTop || layout.kind == LayoutKind::kBillboard;
  const bool upper = layout.kind == LayoutKind::kHemiOctahedral || ring;
  const double y_top = ring ? std::sin(std::numbers::pi / 3.0) : 1.0;
  // A rotation from the key: about +Y only for the hemisphere (the domain
  // must stay the upper half), about a random axis for the sphere.
  const float spin = static_cast<float>(2.0 * std::numbers::pi * NextUniform(state));
  glm::vec3 axis(0.0f, 1.0f, 0.0f);
  if (!upper) {
    const double z = 2.0 * NextUniform(state) - 1.0, phi = 2.0 * std::numbers::pi * NextUniform(state);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    axis = glm::normalize(glm::vec3(r * std::cos(phi), z, r * std::sin(phi)));
  }
  std::vector<glm::vec3> frame_directions;
  for (const FrameCamera& c : AtlasCameras(layout, GridSide(layout) * 8)) frame_directions.push_back(c.direction);
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  std::vector<glm::vec3> out;
  for (int i = 0; i < count; ++i) {
    // Spherical Fibonacci: equal-area bands in y, golden-angle steps around.
    const double t = (i + 0.5) / count;
    const double y = upper ? t * y_top : 1.0 - 2.0 * t;
    const double r = std::sqrt(std::max(0.0, 1.0 - y * y)), phi = golden * i;
    glm::vec3 d = Rotate(glm::vec3(r * std::sin(phi), y, r * std::cos(phi)), axis, spin);
    for (int attempt = 0; attempt < 16; ++attempt) {
      glm::vec3 nearest = frame_directions[0];
      for (const glm::vec3& f : frame_directions) {
        if (glm::dot(f, d) > glm::dot(nearest, d)) nearest = f;
      }
      if (DegreesBetween(d, nearest) >= kMinDegreesFromFrame) break;
      // Step 2 * the limit away, about an axis that changes with each try so
      // the nudge cannot land on the same frame twice.
      glm::vec3 side = glm::cross(d, glm::vec3(0.3f + attempt, 1.0f, 0.7f));
      if (glm::length(side) < 1e-4f) side = glm::cross(d, glm::vec3(1.0f, 0.0f, 0.0f));
      d = Rotate(d, glm::normalize(side), 2.0f * kMinDegreesFromFrame * std::numbers::pi_v<float> / 180.0f);
      if (upper && d.y < 0.0f) d.y = -d.y;
      d = glm::normalize(d);
    }
    out.push_back(glm::normalize(d));
  }
  return out;
}

absl::StatusOr<QualityPassResult> MeasureAtlasQuality(const Scene& scene, const ImpostorAtlas& atlas,
                                                      std::string_view cache_key, const QualityPassOptions& o,
                                                      AtlasRenderer& renderer) {
  if (o.views < 1 || o.views > kMaxQualityViews) {
    return absl::InvalidArgumentError(absl::StrCat("quality pass: views ", o.views, " is out of range 1..",
                                                   kMaxQualityViews));
  }
  if (o.view_pixels < 8 || o.view_pixels > 1024 || o.orbit_steps < 0 || (o.orbit_steps > 0 && o.orbit_pixels < 8)) {
    return absl::InvalidArgumentError(absl::StrCat("quality pass: view_pixels ", o.view_pixels, " orbit_pixels ",
                                                   o.orbit_pixels, " must be 8..1024"));
  }
  if (o.good_for_top_pixels != 0 && (o.good_for_top_pixels < 8 || o.good_for_top_pixels > 1024)) {
    return absl::InvalidArgumentError(
        absl::StrCat("quality pass: good_for_top_pixels ", o.good_for_top_pixels, " must be 0 or 8..1024"));
  }
  const auto start = Clock::now();
  // Each step's seconds, logged at debug level (the profile of the pass).
  std::string steps;
  auto lap_start = start;
  const auto lap = [&](std::string_view step) {
    const auto now = Clock::now();
    steps += fmt::format(" {}_seconds={:.3f}", step, std::chrono::duration<double>(now - lap_start).count());
    lap_start = now;
  };
  QualityPassResult result;
  result.directions = o.on_frame_directions ? FrameDirections(atlas.cameras, o.views)
                                             : HeldOutViewDirections(AtlasViewLayout(atlas), cache_key, o.views);
  auto mesh =
      RenderMeshViews(scene, atlas.sphere, result.directions, o.view_pixels, kReferenceSupersampling, renderer);
  if (!mesh.ok()) return mesh.status();
  lap("mesh_views");
  auto source = ImpostorViewSource::Create(atlas, o.impostor_views_on, renderer);
  if (!source.ok()) return source.status();
  result.impostor_views_on_device = source->on_device();
  auto impostor_views = source->Render(result.directions, o.view_pixels, o.blend, o.reconstruction);
  if (!impostor_views.ok()) return impostor_views.status();
  const std::vector<ViewBuffers>& impostor = *impostor_views;
  lap("impostor_views");
  const bool plain_too = o.also_plain && o.reconstruction != Reconstruction::kPlain;

  v1::AtlasQuality& q = result.quality;
  q.set_blend(std::string(BlendModeName(o.blend)));
  q.set_views(static_cast<uint32_t>(o.views));
  q.set_view_pixels(static_cast<uint32_t>(o.view_pixels));
  double iou_min = 1, iou_sum = 0, psnr_min = kMaxPsnrDb, psnr_sum = 0, ssim_min = 1, ssim_sum = 0;
  double normal_sum = 0, normal_max = 0, depth_sum = 0, depth_max = 0;
  int worst = 0;
  result.per_view = CompareAll(*mesh, impostor);
  for (int i = 0; i < o.views; ++i) {
    const ViewMetrics& m = result.per_view[i];
    if (m.iou < iou_min) worst = i;
    iou_min = std::min(iou_min, m.iou);
    psnr_min = std::min(psnr_min, m.albedo_psnr_db);
    ssim_min = std::min(ssim_min, m.albedo_ssim);
    iou_sum += m.iou;
    psnr_sum += m.albedo_psnr_db;
    ssim_sum += m.albedo_ssim;
    normal_sum += m.normal_error_deg_mean;
    normal_max = std::max(normal_max, m.normal_error_deg_max);
    depth_sum += m.depth_error_mean;
    depth_max = std::max(depth_max, m.depth_error_max);
  }
  const double n = o.views;
  q.set_silhouette_iou_min(static_cast<float>(iou_min));
  q.set_silhouette_iou_mean(static_cast<float>(iou_sum / n));
  q.set_albedo_psnr_union_db_min(static_cast<float>(psnr_min));
  q.set_albedo_psnr_union_db_mean(static_cast<float>(psnr_sum / n));
  q.set_albedo_ssim_union_min(static_cast<float>(ssim_min));
  q.set_albedo_ssim_union_mean(static_cast<float>(ssim_sum / n));
  q.set_normal_error_deg_mean(static_cast<float>(normal_sum / n));
  q.set_normal_error_deg_max(static_cast<float>(normal_max));
  q.set_depth_error_mean(static_cast<float>(depth_sum / n));
  q.set_depth_error_max(static_cast<float>(depth_max));
  q.set_worst_view(static_cast<uint32_t>(worst));
  lap("metrics");
  const v1::ReconstructionQuality headline = ModeFigures(o.reconstruction, result.per_view);
  q.set_reconstruction(headline.reconstruction());
  q.set_albedo_psnr_shared_db_min(headline.albedo_psnr_shared_db_min());
  q.set_albedo_psnr_shared_db_mean(headline.albedo_psnr_shared_db_mean());
  q.set_albedo_ssim_shared_min(headline.albedo_ssim_shared_min());
  q.set_albedo_ssim_shared_mean(headline.albedo_ssim_shared_mean());
  q.set_boundary_error_px_mean(headline.boundary_error_px_mean());
  q.set_boundary_error_px_max(headline.boundary_error_px_max());
  if (plain_too) {
    auto plain = source->Render(result.directions, o.view_pixels, o.blend, Reconstruction::kPlain);
    if (!plain.ok()) return plain.status();
    result.plain_per_view = CompareAll(*mesh, *plain);
    *q.mutable_plain() = ModeFigures(Reconstruction::kPlain, result.plain_per_view);
    lap("plain");
  }
  if (o.pop_references) {
    auto one_sample = RenderMeshViews(scene, atlas.sphere, result.directions, o.view_pixels, 1, renderer);
    if (!one_sample.ok()) return one_sample.status();
    double sum = 0, worst_iou = 1;
    for (const ViewMetrics& m : CompareAll(*mesh, *one_sample)) {
      sum += m.iou;
      worst_iou = std::min(worst_iou, m.iou);
    }
    result.one_sample_mesh_iou_mean = sum / o.views;
    result.one_sample_mesh_iou_min = worst_iou;
    lap("iou_reference");
  }
  result.views_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  if (o.orbit_steps > 0) {
    const auto pop_start = Clock::now();
    std::vector<Reconstruction> modes = {o.reconstruction};
    if (plain_too) modes.push_back(Reconstruction::kPlain);
    auto pop = MeasurePop(scene, atlas, *source, o, modes, renderer);
    if (!pop.ok()) return pop.status();
    q.set_pop(static_cast<float>(pop->pops[0]));
    if (plain_too) q.mutable_plain()->set_pop(static_cast<float>(pop->pops[1]));
    if (pop->antialiased >= 0) q.set_pop_antialiased(static_cast<float>(pop->antialiased));
    result.pop_antialiased_mesh = pop->antialiased_mesh;
    result.pop_antialiased = pop->antialiased;
    result.pop_antialiased_seconds = pop->antialiased_seconds;
    result.pop_seconds = std::chrono::duration<double>(Clock::now() - pop_start).count();
    lap("pop");
  }
  if (o.good_for_top_pixels > 0) {
    const auto sizes_start = Clock::now();
    if (auto s = MeasureSizes(scene, atlas, *source, o, result.directions, *mesh, impostor, renderer, &q); !s.ok()) {
      return s;
    }
    result.sizes_seconds = std::chrono::duration<double>(Clock::now() - sizes_start).count();
    lap("sizes");
  }
  if (!o.worst_view_png.empty()) {
    if (auto s = WriteSideBySide(o.worst_view_png, (*mesh)[worst], impostor[worst]); !s.ok()) return s;
  }
  if (!o.views_dir.empty()) {
    std::vector<QualityViewImage> images;
    for (int i = 0; i < o.views; ++i) images.push_back({(*mesh)[i].albedo_alpha, impostor[i].albedo_alpha});
    auto files = WriteQualityViews(o.views_dir, atlas.sphere, q.reconstruction(), q.blend(), o.view_pixels,
                                   kReferenceSupersampling, result.directions, images, result.per_view);
    if (!files.ok()) return files.status();
    result.view_files = std::move(*files);
  }
  lap("files");
  spdlog::debug("event=quality_pass_steps cache_key={} impostor_views={}{}", cache_key,
                result.impostor_views_on_device ? "device" : "cpu", steps);
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

bool QualityPassSupports(LayoutKind) {
  return true;  // the reference renderer draws every layout
}

absl::Status AddAtlasQuality(const Scene& scene, const BoundingSphere& sphere, const std::vector<FrameCamera>& cameras,
                             AtlasImages&& maps, const v1::BakeParameters& p, const std::string& cache_key,
                             const std::filesystem::path& dir, AtlasRenderer& renderer, v1::Manifest* manifest,
                             const QualityPassOverrides& overrides) {
  QualityPassOptions options;
  options.views = p.has_quality_views() ? static_cast<int>(p.quality_views()) : kDefaultQualityViews;
  const LayoutKind layout = ToLayoutKind(p.layout());
  if (options.views == 0) return absl::OkStatus();
  // One view size per atlas resolution, whatever the frame count, so that
  // frames_auto's candidates are judged at the same display size: at most
  // the largest tile any count of the ladder gets (resolution / 8), so a
  // small atlas is not judged far above the size it can serve.
  options.view_pixels = std::clamp(static_cast<int>(p.resolution()) / 8, 8, options.view_pixels);
  if (overrides.view_pixels > 0) options.view_pixels = overrides.view_pixels;
  options.on_frame_directions = overrides.on_frame_directions;
  options.pop_references = overrides.pop_references;
  options.impostor_views_on = overrides.impostor_views_on;
  options.orbit_pixels = std::min(options.orbit_pixels, options.view_pixels);
  // Good-for sizes up to twice the pass's size: past the atlas's tiles
  // (resolution / frames) an impostor is magnified, and that is where it
  // stops being good enough.
  options.good_for_top_pixels = overrides.good_for_top_pixels >= 0 ? overrides.good_for_top_pixels
                                                                     : std::min(1024, 2 * options.view_pixels);
  options.good_for_targets = GoodForTargets(p);
  if (!QualityPassSupports(layout)) {
    spdlog::info("event=quality_pass_skipped cache_key={} layout={} reason=\"no reference renderer for the layout\"",
                 cache_key, std::string(LayoutName(layout)));
    return absl::OkStatus();
  }
  ImpostorAtlas atlas;
  atlas.layout = layout;
  atlas.frames = static_cast<int>(p.frames());
  atlas.ring_views = ViewLayoutOf(p).ring_views;
  atlas.resolution = static_cast<int>(p.resolution());
  atlas.sphere = sphere;
  atlas.cameras = cameras;
  atlas.width = maps.width;
  atlas.height = maps.height;
  atlas.albedo_alpha = std::move(maps.albedo_alpha);
  atlas.normal_depth = std::move(maps.normal_depth);
  atlas.orm = std::move(maps.orm);
  options.worst_view_png = dir / kQualityWorstViewFile;
  options.views_dir = dir;
  auto result = MeasureAtlasQuality(scene, atlas, cache_key, options, renderer);
  if (!result.ok()) return result.status();
  auto digest = DigestFile(options.worst_view_png);
  if (!digest.ok()) return digest.status();
  v1::MapFile* map = manifest->add_maps();
  map->set_semantic(kQualityWorstViewSemantic);
  map->set_file(kQualityWorstViewFile);
  map->mutable_digest()->set_hash(digest->hash);
  map->mutable_digest()->set_size_bytes(digest->size_bytes);
  const int scale = options.view_pixels < 256 ? 2 : 1;
  map->set_width(static_cast<uint32_t>(3 * options.view_pixels * scale));
  map->set_height(static_cast<uint32_t>(options.view_pixels * scale));
  map->set_format("png_rgba8");
  for (const char* c : {"R: the quality pass's worst held-out view (quality.worst_view) side by side, sRGB: mesh "
                        "| impostor over dark grey | difference",
                        "G: difference panel: grey = 4 x mean |colour difference| where both cover",
                        "B: magenta = only the mesh covers (impostor misses), cyan = only the impostor covers",
                        "A: 255"}) {
    map->add_channels(c);
  }
  for (const QualityViewsFile& f : result->view_files) {
    auto view_digest = DigestFile(dir / f.file);
    if (!view_digest.ok()) return view_digest.status();
    v1::MapFile* view = manifest->add_maps();
    view->set_semantic(f.semantic);
    view->set_file(f.file);
    view->mutable_digest()->set_hash(view_digest->hash);
    view->mutable_digest()->set_size_bytes(view_digest->size_bytes);
    view->set_width(static_cast<uint32_t>(f.width));
    view->set_height(static_cast<uint32_t>(f.height));
    if (f.width == 0) {
      view->set_format("json");
      view->add_channels("every held-out view's camera and figures (quality_views.h)");
      continue;
    }
    view->set_format("png_rgba8");
    const bool mesh_view = f.semantic == kQualityViewMeshSemantic;
    for (const char* c : {"R: albedo, sRGB", "G: albedo, sRGB", "B: albedo, sRGB",
                          mesh_view ? "A: coverage, the fraction of the pixel's samples the mesh covers (views.json "
                                      "mesh_supersampling; straight alpha; covered iff >= 128)"
                                    : "A: coverage, 0 or 255 (straight alpha)"}) {
      view->add_channels(c);
    }
  }
  *manifest->mutable_quality() = result->quality;
  const v1::AtlasQuality& q = result->quality;
  spdlog::info(
      "event=quality_pass cache_key={} frames={} views={} view_pixels={} blend={} reconstruction={} iou_mean={:.4f} "
      "iou_min={:.4f} shared_psnr_db_mean={:.2f} shared_ssim_mean={:.4f} boundary_px_mean={:.2f} plain_iou_mean={:.4f} "
      "plain_shared_psnr_db_mean={:.2f} normal_deg_mean={:.2f} depth_error_mean={:.4f} pop={:.3f} "
      "pop_antialiased={:.3f} good_up_to_pixels={} worst_view={} impostor_views={} views_seconds={:.2f} "
      "pop_seconds={:.2f} pop_antialiased_seconds={:.2f} sizes_seconds={:.2f} seconds={:.2f}",
      cache_key, atlas.frames, q.views(), q.view_pixels(), q.blend(), q.reconstruction(), q.silhouette_iou_mean(),
      q.silhouette_iou_min(), q.albedo_psnr_shared_db_mean(), q.albedo_ssim_shared_mean(), q.boundary_error_px_mean(),
      q.plain().silhouette_iou_mean(), q.plain().albedo_psnr_shared_db_mean(), q.normal_error_deg_mean(),
      q.depth_error_mean(), q.pop(), q.pop_antialiased(), q.good_up_to_pixels(), q.worst_view(),
      result->impostor_views_on_device ? "device" : "cpu", result->views_seconds, result->pop_seconds,
      result->pop_antialiased_seconds, result->sizes_seconds, result->seconds);
  if (result->pop_antialiased_mesh >= 0) {
    spdlog::info("event=quality_pass_pop_references cache_key={} pop={:.3f} pop_antialiased_mesh={:.3f} "
                 "pop_antialiased={:.3f} one_sample_mesh_iou_mean={:.4f} one_sample_mesh_iou_min={:.4f}",
                 cache_key, q.pop(), result->pop_antialiased_mesh, result->pop_antialiased,
                 result->one_sample_mesh_iou_mean, result->one_sample_mesh_iou_min);
  }
  return absl::OkStatus();
}

}  // namespace impostor
