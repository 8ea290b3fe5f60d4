// Thin helpers over vkCmdPipelineBarrier2 (synchronization2) so call sites
// read as "this image goes from layout A after X to layout B before Y".
#ifndef IMPOSTOR_WORKER_GPU_BARRIERS_H_
#define IMPOSTOR_WORKER_GPU_BARRIERS_H_

#include <vulkan/vulkan.h>

#include <cstdint>

namespace impostor::gpu {

struct ImageTransition {
  VkImage image = VK_NULL_HANDLE;
  VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;
  uint32_t base_mip = 0;
  uint32_t mip_count = 1;
  VkImageLayout old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImageLayout new_layout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkPipelineStageFlags2 src_stage = VK_PIPELINE_STAGE_2_NONE;
  VkAccessFlags2 src_access = VK_ACCESS_2_NONE;
  VkPipelineStageFlags2 dst_stage = VK_PIPELINE_STAGE_2_NONE;
  VkAccessFlags2 dst_access = VK_ACCESS_2_NONE;
};

inline VkImageMemoryBarrier2 ToBarrier(const ImageTransition& t) {
  VkImageMemoryBarrier2 b{};
  b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2;
  b.srcStageMask = t.src_stage;
  b.srcAccessMask = t.src_access;
  b.dstStageMask = t.dst_stage;
  b.dstAccessMask = t.dst_access;
  b.oldLayout = t.old_layout;
  b.newLayout = t.new_layout;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = t.image;
  b.subresourceRange = {t.aspect, t.base_mip, t.mip_count, 0, 1};
  return b;
}

// Records one barrier holding every transition in [transitions, +count).
inline void TransitionImages(VkCommandBuffer cmd, const ImageTransition* transitions,
                             uint32_t count) {
  VkImageMemoryBarrier2 barriers[8];
  for (uint32_t first = 0; first < count; first += 8) {
    const uint32_t n = count - first < 8 ? count - first : 8;
    for (uint32_t i = 0; i < n; ++i) barriers[i] = ToBarrier(transitions[first + i]);
    VkDependencyInfo dep{};
    dep.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
    dep.imageMemoryBarrierCount = n;
    dep.pImageMemoryBarriers = barriers;
    vkCmdPipelineBarrier2(cmd, &dep);
  }
}

inline void TransitionImage(VkCommandBuffer cmd, const ImageTransition& t) {
  TransitionImages(cmd, &t, 1);
}

// A global memory barrier (covers every resource).
inline void MemoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 src_stage,
                          VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage,
                          VkAccessFlags2 dst_access) {
  VkMemoryBarrier2 b{};
  b.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2;
  b.srcStageMask = src_stage;
  b.srcAccessMask = src_access;
  b.dstStageMask = dst_stage;
  b.dstAccessMask = dst_access;
  VkDependencyInfo dep{};
  dep.sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO;
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

}  // namespace impostor::gpu

#endif  // IMPOSTOR_WORKER_GPU_BARRIERS_H_
