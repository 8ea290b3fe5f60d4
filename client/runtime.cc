// The SDK's runtime math: thin adapters over common/runtime (the one
// implementation, shared with the baker and the reference renderer).
#include "impostor/runtime.h"

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "common/atlas_layout.h"
#include "common/frame_camera.h"
#include "common/runtime/frame_blend.h"
#include "common/runtime/virtual_plane.h"

namespace impostor::sdk {
namespace {

LayoutKind ToKind(Layout layout) {
  return layout == Layout::kOctahedral ? LayoutKind::kOctahedral : LayoutKind::kHemiOctahedral;
}

glm::vec3 Vec(const float v[3]) { return {v[0], v[1], v[2]}; }

void Store(glm::vec3 v, float out[3]) {
  out[0] = v.x;
  out[1] = v.y;
  out[2] = v.z;
}

FrameCamera CameraOf(Layout layout, int frames, int frame) {
  return CameraForDirection(FrameDirection(ToKind(layout), frames, FrameFromIndex(frames, frame)));
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
  return *kind == LayoutKind::kOctahedral ? Layout::kOctahedral : Layout::kHemiOctahedral;
}

std::string_view LayoutName(Layout layout) { return impostor::LayoutName(ToKind(layout)); }

std::optional<BlendMode> BlendModeFromName(std::string_view name) {
  auto mode = ParseBlendMode(name);
  if (!mode.ok()) return std::nullopt;
  return *mode == impostor::BlendMode::kTriangle3 ? BlendMode::kTriangle3 : BlendMode::kBilinear4;
}

std::string_view BlendModeName(BlendMode mode) {
  return mode == BlendMode::kTriangle3 ? "triangle3" : "bilinear4";
}

FrameBlend BlendFrames(Layout layout, int frames, const float view_dir[3], BlendMode mode) {
  const impostor::FrameBlend blend = impostor::BlendFrames(
      ToKind(layout), frames, Vec(view_dir),
      mode == BlendMode::kTriangle3 ? impostor::BlendMode::kTriangle3 : impostor::BlendMode::kBilinear4);
  FrameBlend out;
  out.count = blend.count;
  for (int i = 0; i < blend.count; ++i) out.entries[i] = {blend.entries[i].index, blend.entries[i].weight};
  return out;
}

FrameBasis FrameCameraBasis(Layout layout, int frames, int frame) {
  const FrameCamera c = CameraOf(layout, frames, frame);
  FrameBasis basis;
  Store(c.direction, basis.direction);
  Store(c.up, basis.up);
  Store(c.right, basis.right);
  return basis;
}

FrameUv VirtualPlaneUv(Layout layout, int frames, int frame, const float sphere_center[3], float sphere_radius,
                       const float ray_origin[3], const float ray_dir[3], float height) {
  if (!(sphere_radius > 0.0f)) return {};
  const glm::vec3 origin = (Vec(ray_origin) - Vec(sphere_center)) / sphere_radius;
  return ToUv(IntersectFramePlane(CameraOf(layout, frames, frame), origin, Vec(ray_dir), height));
}

FrameUv VirtualPlaneUvParallax(Layout layout, int frames, int frame, const float sphere_center[3],
                               float sphere_radius, const float ray_origin[3], const float ray_dir[3],
                               const FrameDepthReader& read_depth) {
  if (!(sphere_radius > 0.0f)) return {};
  const glm::vec3 origin = (Vec(ray_origin) - Vec(sphere_center)) / sphere_radius;
  return ToUv(IntersectFrameHeightField(CameraOf(layout, frames, frame), origin, Vec(ray_dir),
                                        [&](glm::vec2 st, float* height) {
                                          float depth = 1.0f;
                                          if (!read_depth((st.x + 1.0f) * 0.5f, (1.0f - st.y) * 0.5f, &depth)) {
                                            return false;
                                          }
                                          *height = 1.0f - 2.0f * depth;
                                          return true;
                                        }));
}

void FrameUvToAtlasUv(int frames, int resolution, int frame, const FrameUv& uv, float atlas_uv[2]) {
  const int tile = TileSize(resolution, frames);
  const FrameCoord f = FrameFromIndex(frames, frame);
  const float inv = resolution > 0 ? 1.0f / static_cast<float>(resolution) : 0.0f;
  atlas_uv[0] = (static_cast<float>(f.col * tile) + uv.u * static_cast<float>(tile)) * inv;
  atlas_uv[1] = (static_cast<float>(f.row * tile) + uv.v * static_cast<float>(tile)) * inv;
}

}  // namespace impostor::sdk
