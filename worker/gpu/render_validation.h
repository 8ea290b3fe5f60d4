// Checks a Render() request before any GPU work, so bad input is reported as
// INVALID_ARGUMENT with the offending numbers instead of as a Vulkan error
// (or undefined behaviour) halfway through a bake. Pure; thread-safe.
#ifndef IMPOSTOR_WORKER_GPU_RENDER_VALIDATION_H_
#define IMPOSTOR_WORKER_GPU_RENDER_VALIDATION_H_

#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "common/atlas/frame_camera.h"
#include "worker/scene/scene.h"

namespace impostor::gpu {

// `max_image_dimension` is the device's maxImageDimension2D: it bounds both
// the atlas and every texture.
absl::Status ValidateRenderRequest(const Scene& scene, const BoundingSphere& sphere,
                                   const std::vector<FrameCamera>& cameras, int atlas_size,
                                   uint32_t max_image_dimension);

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_RENDER_VALIDATION_H_
