// One host image uploaded as a sampled 2D image (one mip level), for compute
// kernels that read an atlas: the quality pass's runtime views on the device
// (device_impostor_views.h) and the shader tests. The scene's textures go
// through StagingUploader instead, which batches and builds mip chains.
#ifndef IMPOSTOR_WORKER_GPU_SAMPLED_IMAGE_UPLOAD_H_
#define IMPOSTOR_WORKER_GPU_SAMPLED_IMAGE_UPLOAD_H_

#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/gpu_image.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::gpu {

// A `width` x `height` image of `format` holding `bytes` of `data` (rows top
// to bottom, tightly packed), in SHADER_READ_ONLY_OPTIMAL for compute
// shaders once this returns (the copy is submitted on `runner` and waited
// on). The device's size limits apply (GpuImage::Create).
absl::StatusOr<GpuImage> UploadSampledImage(const VulkanContext& ctx, CommandRunner& runner, VkFormat format,
                                            uint32_t width, uint32_t height, const void* data, size_t bytes,
                                            const std::string& name);

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_SAMPLED_IMAGE_UPLOAD_H_
