#include "worker/gpu/render_validation.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "worker/scene/scene_invariants.h"

namespace impostor::gpu {
namespace {

std::string TileString(const TileRect& t) {
  return absl::StrCat("(x ", t.x, ", y ", t.y, ", ", t.width, "x", t.height, ")");
}

}  // namespace

absl::Status ValidateRenderRequest(const Scene& scene, const BoundingSphere& sphere,
                                   const std::vector<FrameCamera>& cameras, int atlas_size,
                                   uint32_t max_image_dimension) {
  if (atlas_size <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("atlas size ", atlas_size, " is not positive"));
  }
  if (static_cast<uint32_t>(atlas_size) > max_image_dimension) {
    return absl::InvalidArgumentError(absl::StrCat("atlas size ", atlas_size,
                                                   " exceeds the device's maxImageDimension2D ",
                                                   max_image_dimension));
  }
  if (cameras.empty()) return absl::InvalidArgumentError("no cameras to render");
  for (const FrameCamera& c : cameras) {
    const TileRect& t = c.tile;
    if (t.width <= 0 || t.height <= 0 || t.x < 0 || t.y < 0 ||
        static_cast<int64_t>(t.x) + t.width > atlas_size ||
        static_cast<int64_t>(t.y) + t.height > atlas_size) {
      return absl::InvalidArgumentError(absl::StrCat("frame ", c.index, " tile ", TileString(t),
                                                     " lies outside the ", atlas_size, "x",
                                                     atlas_size, " atlas"));
    }
  }
  if (!(sphere.radius > 0.0f) || !std::isfinite(sphere.radius)) {
    return absl::InvalidArgumentError(
        absl::StrCat("bounding sphere radius ", sphere.radius, " is not positive"));
  }

  if (absl::Status s = CheckSceneInvariants(scene); !s.ok()) return s;
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const SceneTexture& t = scene.textures[i];
    if (static_cast<uint32_t>(t.width) > max_image_dimension ||
        static_cast<uint32_t>(t.height) > max_image_dimension) {
      return absl::InvalidArgumentError(
          absl::StrCat("texture ", i, " \"", t.name, "\" is ", t.width, "x", t.height,
                       ", above the device's maxImageDimension2D ", max_image_dimension));
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor::gpu
