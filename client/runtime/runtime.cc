// The SDK's runtime math: thin adapters over common/runtime (the one
// implementation, shared with the baker and the reference renderer).
#include "impostor/runtime.h"

#include <algorithm>
#include <array>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "common/atlas/atlas_layout.h"
#include "common/atlas/frame_camera.h"
#include "common/runtime/depth_reconstruction.h"
#include "common/runtime/frame_blend.h"
#include "common/runtime/virtual_plane.h"

namespace impostor::sdk {
namespace {

LayoutKind ToKind(Layout layout) {
  switch (layout) {
    case Layout::kOctahedral: return LayoutKind::kOctahedral;
    case Layout::kHemiOctahedral: return LayoutKind::kHemiOctahedral;
    case Layout::kAzimuthElevation: return LayoutKind::kAzimuthElevation;
    case Layout::kRingTop: return LayoutKind::kRingTop;
    case Layout::kBillboard: return LayoutKind::kBillboard;
  }
  return LayoutKind::kOctahedral;
}

Layout FromKind(LayoutKind kind) {
  switch (kind) {
    case LayoutKind::kOctahedral: return Layout::kOctahedral;
    case LayoutKind::kHemiOctahedral: return Layout::kHemiOctahedral;
    case LayoutKind::kAzimuthElevation: return Layout::kAzimuthElevation;
    case LayoutKind::kRingTop: return Layout::kRingTop;
    case LayoutKind::kBillboard: return Layout::kBillboard;
  }
  return Layout::kOctahedral;
}

ViewLayout ToViewLayout(const AtlasLayout& layout) {
  ViewLayout v{.kind = ToKind(layout.layout), .frames = layout.frames, .ring_views = 0};
  if (layout.layout == Layout::kRingTop) v.ring_views = layout.ring_views;
  if (layout.layout == Layout::kBillboard) v.ring_views = kBillboardRingViews;
  return v;
}

// An AtlasLayout a bake produces; anything else gets empty answers (the
// header's "Layouts" paragraph), never a plausible-looking frame 0.
bool Describes(const AtlasLayout& layout) {
  if (layout.layout == Layout::kBillboard && layout.ring_views != kBillboardRingViews) return false;
  const ViewLayout v = ToViewLayout(layout);
  if (!IsBakeableLayout(v)) return false;
  // The ring layouts' `frames` is their grid side.
  return layout.frames == GridSide(v);
}

AtlasLayout FromFrames(Layout layout, int frames) {
  return {layout, frames, layout == Layout::kBillboard ? kBillboardRingViews : 0};
}

glm::vec3 Vec(const float v[3]) { return {v[0], v[1], v[2]}; }

void Store(glm::vec3 v, float out[3]) {
  out[0] = v.x;
  out[1] = v.y;
  out[2] = v.z;
}

FrameCamera CameraOf(const AtlasLayout& layout, int frame) {
  return CameraForDirection(FrameDirectionAt(ToViewLayout(layout), frame));
}

FrameUv ToUv(const PlaneSample& sample) {
  FrameUv uv;
  uv.valid = sample.valid;
  uv.u = (sample.st.x + 1.0f) * 0.5f;
  uv.v = (1.0f - sample.st.y) * 0.5f;
  return uv;
}

}  // namespace

std::optional<Layout> LayoutFromName(std::string_view manifest_name) {
  auto kind = ParseLayout(manifest_name);
  if (!kind.ok()) return std::nullopt;
  return FromKind(*kind);
}

std::string_view LayoutName(Layout layout) { return impostor::LayoutName(ToKind(layout)); }

std::optional<AtlasLayout> AtlasLayoutFromManifest(std::string_view name, int frames, int view_count) {
  const std::optional<Layout> layout = LayoutFromName(name);
  if (!layout) return std::nullopt;
  AtlasLayout out{*layout, frames, 0};
  if (*layout == Layout::kRingTop || *layout == Layout::kBillboard) {
    out.ring_views = view_count - 1;
    // The manifest's `frames` of a ring layout is the atlas grid side,
    // which the ring count fixes.
    if (frames != GridSide(ToViewLayout(out))) return std::nullopt;
  }
  if (!Describes(out) || view_count != FrameCount(out)) return std::nullopt;
  return out;
}

int FrameCount(const AtlasLayout& layout) { return impostor::FrameCount(ToViewLayout(layout)); }

std::optional<BlendMode> BlendModeFromName(std::string_view name) {
  auto mode = ParseBlendMode(name);
  if (!mode.ok()) return std::nullopt;
  return *mode == impostor::BlendMode::kTriangle3 ? BlendMode::kTriangle3 : BlendMode::kBilinear4;
}

std::string_view BlendModeName(BlendMode mode) {
  return mode == BlendMode::kTriangle3 ? "triangle3" : "bilinear4";
}

FrameBlend BlendFrames(const AtlasLayout& layout, const float view_dir[3], BlendMode mode) {
  if (!Describes(layout)) return {};
  const impostor::FrameBlend blend = impostor::BlendFrames(
      ToViewLayout(layout), Vec(view_dir),
      mode == BlendMode::kTriangle3 ? impostor::BlendMode::kTriangle3 : impostor::BlendMode::kBilinear4);
  FrameBlend out;
  out.count = blend.count;
  for (int i = 0; i < blend.count; ++i) out.entries[i] = {blend.entries[i].index, blend.entries[i].weight};
  return out;
}

FrameBlend BlendFrames(Layout layout, int frames, const float view_dir[3], BlendMode mode) {
  return BlendFrames(FromFrames(layout, frames), view_dir, mode);
}

FrameBasis FrameCameraBasis(const AtlasLayout& layout, int frame) {
  if (!Describes(layout) || frame < 0 || frame >= FrameCount(layout)) return FrameBasis{};
  const FrameCamera c = CameraOf(layout, frame);
  FrameBasis basis;
  Store(c.direction, basis.direction);
  Store(c.up, basis.up);
  Store(c.right, basis.right);
  return basis;
}

FrameBasis FrameCameraBasis(Layout layout, int frames, int frame) {
  return FrameCameraBasis(FromFrames(layout, frames), frame);
}

FrameUv VirtualPlaneUv(const AtlasLayout& layout, int frame, const float sphere_center[3], float sphere_radius,
                       const float ray_origin[3], const float ray_dir[3], float height) {
  if (!(sphere_radius > 0.0f) || !Describes(layout) || frame < 0 || frame >= FrameCount(layout)) return {};
  const glm::vec3 origin = (Vec(ray_origin) - Vec(sphere_center)) / sphere_radius;
  return ToUv(IntersectFramePlane(CameraOf(layout, frame), origin, Vec(ray_dir), height));
}

FrameUv VirtualPlaneUv(Layout layout, int frames, int frame, const float sphere_center[3], float sphere_radius,
                       const float ray_origin[3], const float ray_dir[3], float height) {
  return VirtualPlaneUv(FromFrames(layout, frames), frame, sphere_center, sphere_radius, ray_origin, ray_dir,
                        height);
}

FrameUv VirtualPlaneUvParallax(const AtlasLayout& layout, int frame, const float sphere_center[3],
                               float sphere_radius, const float ray_origin[3], const float ray_dir[3],
                               const FrameDepthReader& read_depth) {
  if (!(sphere_radius > 0.0f) || !Describes(layout) || frame < 0 || frame >= FrameCount(layout)) return {};
  const glm::vec3 origin = (Vec(ray_origin) - Vec(sphere_center)) / sphere_radius;
  return ToUv(IntersectFrameHeightField(CameraOf(layout, frame), origin, Vec(ray_dir),
                                        [&](glm::vec2 st, float* height) {
                                          float depth = 1.0f;
                                          if (!read_depth((st.x + 1.0f) * 0.5f, (1.0f - st.y) * 0.5f, &depth)) {
                                            return false;
                                          }
                                          *height = 1.0f - 2.0f * depth;
                                          return true;
                                        }));
}

FrameUv VirtualPlaneUvParallax(Layout layout, int frames, int frame, const float sphere_center[3],
                               float sphere_radius, const float ray_origin[3], const float ray_dir[3],
                               const FrameDepthReader& read_depth) {
  return VirtualPlaneUvParallax(FromFrames(layout, frames), frame, sphere_center, sphere_radius, ray_origin,
                                ray_dir, read_depth);
}

void FrameUvToAtlasUv(const AtlasLayout& layout, int resolution, int frame, const FrameUv& uv, float atlas_uv[2]) {
  const ViewLayout v = ToViewLayout(layout);
  const int tile = TileSize(resolution, GridSide(v));
  const FrameCoord f = FrameTile(v, frame);
  const float inv = resolution > 0 ? 1.0f / static_cast<float>(resolution) : 0.0f;
  atlas_uv[0] = (static_cast<float>(f.col * tile) + uv.u * static_cast<float>(tile)) * inv;
  atlas_uv[1] = (static_cast<float>(f.row * tile) + uv.v * static_cast<float>(tile)) * inv;
}

void FrameUvToAtlasUv(int frames, int resolution, int frame, const FrameUv& uv, float atlas_uv[2]) {
  FrameUvToAtlasUv(AtlasLayout{Layout::kOctahedral, frames, 0}, resolution, frame, uv, atlas_uv);
}

std::optional<Reconstruction> ReconstructionFromName(std::string_view name) {
  auto mode = ParseReconstruction(name);
  if (!mode.ok()) return std::nullopt;
  return *mode == impostor::Reconstruction::kDepth ? Reconstruction::kDepth : Reconstruction::kPlain;
}

std::string_view ReconstructionName(Reconstruction mode) {
  return impostor::ReconstructionName(mode == Reconstruction::kDepth ? impostor::Reconstruction::kDepth
                                                                     : impostor::Reconstruction::kPlain);
}

DepthReconstruction ReconstructDepth(const AtlasLayout& layout, const FrameBlend& blend, const float sphere_center[3],
                                     float sphere_radius, const float ray_origin[3], const float ray_dir[3],
                                     const FrameSurfaceReader& read) {
  DepthReconstruction out;
  const float len = glm::length(Vec(ray_dir));
  if (!(sphere_radius > 0.0f) || !(len > 0.0f) || !Describes(layout)) return out;
  const int count = std::clamp(blend.count, 0, 4);
  for (int i = 0; i < count; ++i) {
    if (blend.entries[i].frame < 0 || blend.entries[i].frame >= FrameCount(layout)) return out;
  }
  std::array<FrameCamera, 4> cameras;
  std::array<DepthEntry, 4> entries;
  for (int i = 0; i < count; ++i) {
    cameras[i] = CameraOf(layout, blend.entries[i].frame);
    entries[i] = {&cameras[i], blend.entries[i].weight};
  }
  const glm::vec3 origin = (Vec(ray_origin) - Vec(sphere_center)) / sphere_radius;
  const glm::vec3 ray = Vec(ray_dir) / len;
  // Coverage and surface height at frame coordinates st.
  const auto surface = [&](int entry, glm::vec2 st, float* height) {
    float depth = 1.0f;
    const float alpha = read(entry, (st.x + 1.0f) * 0.5f, (1.0f - st.y) * 0.5f, &depth);
    *height = 1.0f - 2.0f * depth;
    return alpha;
  };
  const DepthPixel pixel = impostor::ReconstructDepth(
      entries, count, origin, ray,
      [&](int entry) {
        return IntersectFrameHeightField(
            cameras[entry], origin, ray,
            [&](glm::vec2 st, float* height) { return surface(entry, st, height) >= 0.5f; },
            /*refine_crossings=*/true);
      },
      surface);
  out.coverage = pixel.coverage;
  float total = 0.0f;
  for (int i = 0; i < count; ++i) total += pixel.samples[i].used ? pixel.samples[i].weight : 0.0f;
  for (int i = 0; i < count; ++i) {
    const DepthSampleAt& s = pixel.samples[i];
    if (!s.used || !(total > 0.0f)) continue;
    out.uv[i] = {true, (s.st.x + 1.0f) * 0.5f, (1.0f - s.st.y) * 0.5f};
    out.weight[i] = s.weight / total;
  }
  return out;
}

}  // namespace impostor::sdk
