// Test helper: runs one compute shader on the worker's Vulkan context (a
// dispatch, waited on) and uploads images for it, so the GLSL reference
// runtime can be checked against the C++ on any Vulkan device.
#ifndef IMPOSTOR_TESTS_RUNTIME_COMPUTE_KERNEL_H_
#define IMPOSTOR_TESTS_RUNTIME_COMPUTE_KERNEL_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include <vulkan/vulkan.h>

#include "absl/status/statusor.h"
#include "worker/gpu/compute_pipeline.h"
#include "worker/gpu/gpu_image.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::testing {

// One descriptor of set 0, binding = its position in the list.
using KernelBinding = gpu::ComputeBinding;

// Builds a pipeline from `spirv`, binds `bindings`, pushes `push`
// (push_size bytes) and dispatches groups_x x groups_y groups; returns when
// the device is done and shader writes are visible to the host.
absl::Status RunKernel(const gpu::VulkanContext& ctx, const uint32_t* spirv, size_t spirv_bytes,
                       const std::vector<KernelBinding>& bindings, const void* push, uint32_t push_size,
                       uint32_t groups_x, uint32_t groups_y);

// A sampled 2D image of `format` holding `bytes` (rows top to bottom), in
// SHADER_READ_ONLY_OPTIMAL layout.
absl::StatusOr<gpu::GpuImage> UploadImage(const gpu::VulkanContext& ctx, VkFormat format, uint32_t width,
                                          uint32_t height, const void* data, size_t bytes);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_RUNTIME_COMPUTE_KERNEL_H_
