#include "examples/impostor_scene/scene_renderer.h"

#include <array>
#include <cmath>
#include <cstring>
#include <utility>

#include <glm/ext/matrix_clip_space.hpp>
#include <glm/ext/matrix_transform.hpp>
#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include "absl/strings/str_cat.h"
#include "examples/impostor_scene/scene_pipelines.h"
#include "worker/gpu/bake_pipeline.h"
#include "worker/gpu/barriers.h"
#include "worker/gpu/command_runner.h"
#include "worker/gpu/device_selection.h"
#include "worker/gpu/gpu_buffer.h"
#include "worker/gpu/gpu_image.h"
#include "worker/gpu/scene_resources.h"
#include "worker/gpu/texture_filter.h"
#include "worker/gpu/vk_check.h"
#include "worker/gpu/vulkan_context.h"

namespace impostor::example {
namespace {

using gpu::GpuBuffer;
using gpu::GpuImage;
using gpu::ImageTransition;

constexpr uint32_t kShadowSize = 2048;
constexpr VkImageLayout kAttachment = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
constexpr VkImageLayout kDepthAttachment = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
constexpr VkImageLayout kRead = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;

// std140 / push-constant mirrors of the shaders' blocks.
struct ImpostorPush {  // impostor_runtime_check.vert, impostor_material_lit.frag, impostor_shadow_caster.frag
  glm::mat4 view_projection;
  glm::vec4 eye_object;
  glm::ivec4 params;  // layout, frames, tile_size, blend mode
  glm::ivec4 flags;   // unused, has_orm, ring_views, no depth offset
  glm::vec4 sphere;
};
static_assert(sizeof(ImpostorPush) == kPushBytes);
struct GroundPush {  // impostor_scene_ground.{vert,frag}
  glm::mat4 world_to_clip;
  glm::vec4 ground;  // centre x, height, centre z, half side
  glm::vec4 albedo;
};
struct LightUniform {  // impostor_material_light.glsl
  glm::mat4 light_view_projection;
  glm::vec4 toward_light;
  glm::vec4 colour;  // rgb radiance, a ambient
};
struct InstanceUniform {  // impostor_material_lit.frag
  glm::mat4 object_to_world;
  glm::mat4 world_to_clip;
};

const glm::vec4 kSky{0.45f, 0.6f, 0.85f, 0.0f};  // linear; alpha 0 = not an object
const glm::vec4 kGroundAlbedo{0.45f, 0.42f, 0.38f, 1.0f};
const glm::vec4 kLightColour{1.0f, 0.97f, 0.92f, 0.25f};

// Vulkan clip space (depth 0..1, y down) for a right-handed camera.
glm::mat4 CameraMatrix(const SceneSetup& s) {
  const float distance = glm::length(s.eye - s.target);
  glm::mat4 projection = glm::perspectiveRH_ZO(glm::radians(s.fov_y_degrees),
                                               static_cast<float>(s.width) / s.height, 0.05f * distance,
                                               10.0f * distance);
  projection[1][1] *= -1.0f;
  return projection * glm::lookAtRH(s.eye, s.target, glm::vec3(0.0f, 1.0f, 0.0f));
}

// Orthographic, along the light, covering the ground square. The shadow map
// texel for clip (x, y) is uv = (x, y) * 0.5 + 0.5, as impostorShadow reads it.
glm::mat4 LightMatrix(const SceneSetup& s, glm::vec3 toward_light) {
  const float extent = s.ground_half_side * 1.5f;
  const glm::vec3 up = std::abs(toward_light.y) > 0.99f ? glm::vec3(0.0f, 0.0f, 1.0f) : glm::vec3(0.0f, 1.0f, 0.0f);
  const glm::vec3 centre(s.target.x, s.ground_height, s.target.z);
  const glm::mat4 view = glm::lookAtRH(centre + toward_light * 2.0f * extent, centre, up);
  return glm::orthoRH_ZO(-extent, extent, -extent, extent, 0.0f, 4.0f * extent) * view;
}

absl::StatusOr<GpuImage> Image(const gpu::VulkanContext& ctx, uint32_t w, uint32_t h, VkFormat format,
                               VkImageUsageFlags usage, const char* name) {
  gpu::ImageSpec spec;
  spec.width = w;
  spec.height = h;
  spec.format = format;
  spec.usage = usage;
  if (format == VK_FORMAT_D32_SFLOAT) spec.aspect = VK_IMAGE_ASPECT_DEPTH_BIT;
  return GpuImage::Create(ctx, spec, name);
}

absl::StatusOr<GpuBuffer> HostBuffer(const gpu::VulkanContext& ctx, const void* data, size_t bytes,
                                     VkBufferUsageFlags usage, const char* name) {
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer b, GpuBuffer::Create(ctx, bytes, usage, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                                                               VK_MEMORY_PROPERTY_HOST_CACHED_BIT, name));
  if (data != nullptr) {
    std::memcpy(b.mapped(), data, bytes);
    IMPOSTOR_GPU_RETURN_IF_ERROR(b.FlushHostWrites());
  }
  return b;
}

// Records the copy of `staging` into `image` (level 0), leaving it ready
// for fragment-shader sampling.
void RecordUpload(VkCommandBuffer cmd, const GpuBuffer& staging, const GpuImage& image) {
  ImageTransition t;
  t.image = image.image();
  t.new_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  t.dst_stage = VK_PIPELINE_STAGE_2_COPY_BIT;
  t.dst_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  gpu::TransitionImage(cmd, t);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {image.spec().width, image.spec().height, 1};
  vkCmdCopyBufferToImage(cmd, staging.buffer(), image.image(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  t.old_layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  t.new_layout = kRead;
  t.src_stage = VK_PIPELINE_STAGE_2_COPY_BIT;
  t.src_access = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  t.dst_stage = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  t.dst_access = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  gpu::TransitionImage(cmd, t);
}

VkRenderingAttachmentInfo Attachment(VkImageView view, VkImageLayout layout, bool clear, VkClearValue value) {
  VkRenderingAttachmentInfo a{};
  a.sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO;
  a.imageView = view;
  a.imageLayout = layout;
  a.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  a.clearValue = value;
  return a;
}

void BeginRendering(VkCommandBuffer cmd, uint32_t w, uint32_t h, const std::vector<VkRenderingAttachmentInfo>& colour,
                    const VkRenderingAttachmentInfo& depth) {
  VkRenderingInfo info{};
  info.sType = VK_STRUCTURE_TYPE_RENDERING_INFO;
  info.renderArea = {{0, 0}, {w, h}};
  info.layerCount = 1;
  info.colorAttachmentCount = static_cast<uint32_t>(colour.size());
  info.pColorAttachments = colour.data();
  info.pDepthAttachment = &depth;
  vkCmdBeginRendering(cmd, &info);
  const VkViewport viewport{0.0f, 0.0f, static_cast<float>(w), static_cast<float>(h), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, {w, h}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

class VulkanSceneRenderer final : public SceneRenderer {
 public:
  absl::Status Init(const std::string& device) {
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(ctx_, gpu::VulkanContext::Create(device));
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(bake_, gpu::BakePipeline::Create(*ctx_));
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(runner_, gpu::CommandRunner::Create(*ctx_));
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(linear_, Sampler(VK_FILTER_LINEAR, false));
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(nearest_, Sampler(VK_FILTER_NEAREST, false));
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(shadow_, Sampler(VK_FILTER_LINEAR, true));
    return absl::OkStatus();
  }

  absl::StatusOr<SceneImage> Render(const Scene& mesh, const BakedImpostor& impostor,
                                    const SceneSetup& setup) override;

 private:
  absl::StatusOr<gpu::UniqueSampler> Sampler(VkFilter filter, bool compare) {
    VkSamplerCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    info.magFilter = info.minFilter = filter;
    info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    info.addressModeU = info.addressModeV = info.addressModeW =
        compare ? VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_BORDER : VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    info.borderColor = VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;  // outside the shadow map: lit
    info.compareEnable = compare ? VK_TRUE : VK_FALSE;
    info.compareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
    info.maxLod = 0.0f;  // level 0 only: a generic mip chain would mix atlas frames
    VkSampler sampler = VK_NULL_HANDLE;
    IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateSampler(ctx_->device(), &info, nullptr, &sampler));
    return gpu::UniqueSampler(ctx_->device(), sampler);
  }

  // The three descriptor sets of a frame (impostor lit, deferred, caster).
  struct Sets {
    gpu::UniqueDescriptorPool pool;
    VkDescriptorSet impostor = VK_NULL_HANDLE, deferred = VK_NULL_HANDLE, caster = VK_NULL_HANDLE;
  };
  absl::StatusOr<Sets> AllocateSets();
  void WriteTexture(VkDescriptorSet set, uint32_t binding, VkImageView view, VkSampler sampler,
                    VkImageLayout layout = kRead) const {
    VkDescriptorImageInfo image{sampler, view, layout};
    VkWriteDescriptorSet w{};
    w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    w.dstSet = set;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    w.pImageInfo = &image;
    vkUpdateDescriptorSets(ctx_->device(), 1, &w, 0, nullptr);
  }
  void WriteUniform(VkDescriptorSet set, uint32_t binding, const GpuBuffer& buffer) const {
    VkDescriptorBufferInfo info{buffer.buffer(), 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet w{};
    w.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    w.dstSet = set;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    w.pBufferInfo = &info;
    vkUpdateDescriptorSets(ctx_->device(), 1, &w, 0, nullptr);
  }

  std::unique_ptr<gpu::VulkanContext> ctx_;  // first: destroyed last
  gpu::BakePipeline bake_;
  gpu::CommandRunner runner_;
  // Built for the layout and blend mode of the impostor drawn last.
  ScenePipelines pipelines_;
  int pipelines_for_ = -1;  // (layout * 2 + blend mode) * 2 + parallax
  gpu::UniqueSampler linear_, nearest_, shadow_;
};

absl::StatusOr<VulkanSceneRenderer::Sets> VulkanSceneRenderer::AllocateSets() {
  const std::array<VkDescriptorPoolSize, 2> sizes = {{{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 10},
                                                       {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 4}}};
  VkDescriptorPoolCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  info.maxSets = 3;
  info.poolSizeCount = static_cast<uint32_t>(sizes.size());
  info.pPoolSizes = sizes.data();
  VkDescriptorPool pool = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateDescriptorPool(ctx_->device(), &info, nullptr, &pool));
  Sets sets;
  sets.pool = gpu::UniqueDescriptorPool(ctx_->device(), pool);
  const std::array<VkDescriptorSetLayout, 3> layouts = {pipelines_.lit_set.get(), pipelines_.lit_set.get(),
                                                        pipelines_.caster_set.get()};
  std::array<VkDescriptorSet, 3> out{};
  VkDescriptorSetAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  alloc.descriptorPool = pool;
  alloc.descriptorSetCount = static_cast<uint32_t>(layouts.size());
  alloc.pSetLayouts = layouts.data();
  IMPOSTOR_VK_RETURN_IF_ERROR(vkAllocateDescriptorSets(ctx_->device(), &alloc, out.data()));
  sets.impostor = out[0];
  sets.deferred = out[1];
  sets.caster = out[2];
  return sets;
}

absl::StatusOr<SceneImage> VulkanSceneRenderer::Render(const Scene& mesh, const BakedImpostor& imp,
                                                       const SceneSetup& setup) {
  if (setup.width < 16 || setup.height < 16 || setup.width > 4096 || setup.height > 4096) {
    return absl::InvalidArgumentError(
        absl::StrCat("image size ", setup.width, "x", setup.height, " is outside 16..4096 per side"));
  }
  const size_t texels = static_cast<size_t>(imp.width) * imp.height;
  if (texels == 0 || imp.albedo_alpha.size() != texels * 4 || imp.normal_depth.size() != texels * 4 ||
      imp.orm.size() != texels * 4) {
    return absl::InvalidArgumentError("the impostor's maps are missing or of different sizes");
  }
  if (const int key = (imp.layout * 2 + setup.blend_mode) * 2 + (setup.parallax ? 1 : 0); key != pipelines_for_) {
    pipelines_ = {};
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(pipelines_,
                                  ScenePipelines::Create(*ctx_, imp.layout, setup.blend_mode, setup.parallax));
    pipelines_for_ = key;
  }
  const auto w = static_cast<uint32_t>(setup.width), h = static_cast<uint32_t>(setup.height);
  const auto iw = static_cast<uint32_t>(imp.width), ih = static_cast<uint32_t>(imp.height);
  const gpu::VulkanContext& ctx = *ctx_;
  const SceneSetup& s = setup;
  const glm::vec3 toward_light = glm::normalize(s.toward_light);
  const glm::mat4 world_to_clip = CameraMatrix(s);
  const glm::mat4 light_to_clip = LightMatrix(s, toward_light);
  const glm::mat4 mesh_to_world = glm::translate(glm::mat4(1.0f), s.mesh_offset);
  const glm::mat4 impostor_to_world = glm::translate(glm::mat4(1.0f), s.impostor_offset);
  const bool draw_mesh = s.draw_mesh && !mesh.indices.empty();

  // ---- Resources: the mesh (the worker's uploader), the atlas maps, the
  // render targets, the uniforms and descriptor sets.
  std::unique_ptr<gpu::SceneResources> resources;
  if (draw_mesh) {
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(resources, gpu::SceneResources::Upload(ctx, runner_, bake_, mesh,
                                                                         gpu::TextureFilterFor(1, ctx.max_anisotropy())));
  }
  constexpr VkImageUsageFlags kTexture = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  constexpr VkImageUsageFlags kTarget = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuImage albedo, Image(ctx, iw, ih, VK_FORMAT_R8G8B8A8_SRGB, kTexture, "albedo"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuImage normal_depth,
                                Image(ctx, iw, ih, VK_FORMAT_R16G16B16A16_UNORM, kTexture, "normal_depth"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuImage orm, Image(ctx, iw, ih, VK_FORMAT_R8G8B8A8_UNORM, kTexture, "orm"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer albedo_staging, HostBuffer(ctx, imp.albedo_alpha.data(), texels * 4,
                                                                     VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "staging"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer nd_staging, HostBuffer(ctx, imp.normal_depth.data(), texels * 8,
                                                                 VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "staging"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer orm_staging, HostBuffer(ctx, imp.orm.data(), texels * 4,
                                                                  VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "staging"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      GpuImage shadow_map, Image(ctx, kShadowSize, kShadowSize, kShadowFormat,
                                 VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT, "shadow"));
  std::array<GpuImage, 4> gbuffer;  // the bake pipeline's four outputs
  const std::array<VkFormat, 4> gbuffer_formats = {gpu::kAlbedoFormat, gpu::kNormalDepthFormat, gpu::kOrmFormat,
                                                   gpu::kEmissiveFormat};
  for (size_t i = 0; i < gbuffer.size(); ++i) {
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(gbuffer[i], Image(ctx, w, h, gbuffer_formats[i], kTarget, "gbuffer"));
  }
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      GpuImage depth, Image(ctx, w, h, gpu::kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "depth"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      GpuImage colour, Image(ctx, w, h, kColourFormat,
                             VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, "colour"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer readback, HostBuffer(ctx, nullptr, static_cast<size_t>(w) * h * 4,
                                                               VK_BUFFER_USAGE_TRANSFER_DST_BIT, "readback"));
  const LightUniform light{light_to_clip, glm::vec4(toward_light, 0.0f), kLightColour};
  const InstanceUniform instance{impostor_to_world, world_to_clip};
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer light_ubo, HostBuffer(ctx, &light, sizeof(light),
                                                                VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, "light"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(GpuBuffer instance_ubo, HostBuffer(ctx, &instance, sizeof(instance),
                                                                   VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, "instance"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(Sets sets, AllocateSets());
  const VkImageLayout kShadowRead = VK_IMAGE_LAYOUT_DEPTH_STENCIL_READ_ONLY_OPTIMAL;
  const std::array<VkImageView, 3> atlas_views = {albedo.view(), normal_depth.view(), orm.view()};
  for (uint32_t i = 0; i < 3; ++i) {
    WriteTexture(sets.impostor, i, atlas_views[i], linear_.get());
    WriteTexture(sets.deferred, i, gbuffer[i].view(), nearest_.get());
    if (i < 2) WriteTexture(sets.caster, i, atlas_views[i], linear_.get());
  }
  for (VkDescriptorSet set : {sets.impostor, sets.deferred}) {
    WriteTexture(set, 3, shadow_map.view(), shadow_.get(), kShadowRead);
    WriteUniform(set, 4, light_ubo);
    WriteUniform(set, 5, instance_ubo);
  }

  // The impostor's draw parameters: the camera's and the light's.
  const glm::vec4 sphere(imp.sphere_center, imp.sphere_radius);
  ImpostorPush impostor_push{world_to_clip * impostor_to_world,
                             glm::vec4((s.eye - s.impostor_offset - imp.sphere_center) / imp.sphere_radius, 0.0f),
                             {imp.layout, imp.frames, imp.tile_size, s.blend_mode},
                             {0, 1, imp.ring_views, s.depth_offset ? 0 : 1},
                             sphere};
  ImpostorPush caster_push = impostor_push;
  caster_push.view_projection = light_to_clip * impostor_to_world;
  caster_push.eye_object = glm::vec4(toward_light, 0.0f);  // object axes = world axes (a translation)
  caster_push.flags = {0, 0, imp.ring_views, 0};
  constexpr VkShaderStageFlags kStages = VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;

  IMPOSTOR_GPU_ASSIGN_OR_RETURN(VkCommandBuffer cmd, runner_.Begin());
  RecordUpload(cmd, albedo_staging, albedo);
  RecordUpload(cmd, nd_staging, normal_depth);
  RecordUpload(cmd, orm_staging, orm);
  auto bind_mesh = [&] {
    const VkDeviceSize offset = 0;
    const VkBuffer vertices = resources->vertex_buffer();
    vkCmdBindVertexBuffers(cmd, 0, 1, &vertices, &offset);
    vkCmdBindIndexBuffer(cmd, resources->index_buffer(), 0, VK_INDEX_TYPE_UINT32);
  };

  // ---- Pass 1: the shadow map, from the light. The mesh as depth only; the
  // impostor through impostor_shadow_caster.frag (alpha-tested, depth offset).
  ImageTransition t;
  t.image = shadow_map.image();
  t.aspect = VK_IMAGE_ASPECT_DEPTH_BIT;
  t.new_layout = kDepthAttachment;
  t.dst_stage = VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  t.dst_access = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  gpu::TransitionImage(cmd, t);
  VkClearValue far_depth{};
  far_depth.depthStencil.depth = 1.0f;
  BeginRendering(cmd, kShadowSize, kShadowSize, {}, Attachment(shadow_map.view(), kDepthAttachment, true, far_depth));
  if (draw_mesh) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.mesh_depth.get());
    const glm::mat4 mesh_to_light = light_to_clip * mesh_to_world;
    vkCmdPushConstants(cmd, pipelines_.caster_layout.get(), kStages, 0, sizeof(mesh_to_light), &mesh_to_light);
    bind_mesh();
    for (const SceneBatch& b : mesh.batches) vkCmdDrawIndexed(cmd, b.index_count, 1, b.first_index, 0, 0);
  }
  if (s.draw_impostor) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.impostor_caster.get());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.caster_layout.get(), 0, 1, &sets.caster,
                            0, nullptr);
    vkCmdPushConstants(cmd, pipelines_.caster_layout.get(), kStages, 0, sizeof(caster_push), &caster_push);
    vkCmdDraw(cmd, 6, 1, 0, 0);
  }
  vkCmdEndRendering(cmd);
  t.old_layout = kDepthAttachment;
  t.new_layout = kShadowRead;
  t.src_stage = VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  t.src_access = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  t.dst_stage = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  t.dst_access = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  gpu::TransitionImage(cmd, t);

  // ---- Pass 2: the mesh's G-buffer with the worker's bake pipeline (its
  // material code: textures, normal map, ORM) from the camera.
  std::vector<ImageTransition> to_target;
  for (const GpuImage& g : gbuffer) {
    ImageTransition c;
    c.image = g.image();
    c.new_layout = kAttachment;
    c.dst_stage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    c.dst_access = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    to_target.push_back(c);
  }
  ImageTransition d = t;
  d.image = depth.image();
  d.old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
  d.new_layout = kDepthAttachment;
  d.src_stage = VK_PIPELINE_STAGE_2_NONE;
  d.src_access = VK_ACCESS_2_NONE;
  d.dst_stage = VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  d.dst_access = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  to_target.push_back(d);
  gpu::TransitionImages(cmd, to_target.data(), static_cast<uint32_t>(to_target.size()));
  std::vector<VkRenderingAttachmentInfo> gbuffer_attachments;
  for (const GpuImage& g : gbuffer) gbuffer_attachments.push_back(Attachment(g.view(), kAttachment, true, {}));
  BeginRendering(cmd, w, h, gbuffer_attachments, Attachment(depth.view(), kDepthAttachment, true, far_depth));
  if (draw_mesh) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, bake_.pipeline());
    const glm::mat4 mesh_to_clip = world_to_clip * mesh_to_world;
    vkCmdPushConstants(cmd, bake_.layout(), VK_SHADER_STAGE_VERTEX_BIT, gpu::kFramePushOffset, gpu::kFramePushSize,
                       &mesh_to_clip);
    bind_mesh();
    for (const SceneBatch& b : mesh.batches) {
      const SceneMaterial& m = mesh.materials[b.material];
      const VkDescriptorSet set = resources->material_set(b.material);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, bake_.layout(), 0, 1, &set, 0, nullptr);
      const gpu::MaterialPushConstants push = gpu::MakeMaterialPushConstants(m);
      vkCmdPushConstants(cmd, bake_.layout(), VK_SHADER_STAGE_FRAGMENT_BIT, gpu::kMaterialPushOffset, sizeof(push),
                         &push);
      // As the bake: glTF front faces are counter-clockwise, and the camera
      // matrix flips y as FrameViewProjection does.
      vkCmdSetCullMode(cmd, m.double_sided ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
      vkCmdSetFrontFace(cmd, b.flipped_winding ? VK_FRONT_FACE_CLOCKWISE : VK_FRONT_FACE_COUNTER_CLOCKWISE);
      vkCmdDrawIndexed(cmd, b.index_count, 1, b.first_index, 0, 0);
    }
  }
  vkCmdEndRendering(cmd);
  std::vector<ImageTransition> to_read;
  for (const GpuImage& g : gbuffer) {
    ImageTransition c;
    c.image = g.image();
    c.old_layout = kAttachment;
    c.new_layout = kRead;
    c.src_stage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    c.src_access = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    c.dst_stage = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    c.dst_access = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
    to_read.push_back(c);
  }
  d.old_layout = kDepthAttachment;  // kept: the colour pass tests against the mesh's depth
  d.src_stage = VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  d.src_access = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  to_read.push_back(d);
  ImageTransition c;
  c.image = colour.image();
  c.new_layout = kAttachment;
  c.dst_stage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
  c.dst_access = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
  to_read.push_back(c);
  gpu::TransitionImages(cmd, to_read.data(), static_cast<uint32_t>(to_read.size()));

  // ---- Pass 3: colour. The lit mesh (deferred), the ground, then the
  // impostor: depth-tested against both, writing its offset depth.
  VkClearValue sky{};
  for (int i = 0; i < 4; ++i) sky.color.float32[i] = kSky[i];
  BeginRendering(cmd, w, h, {Attachment(colour.view(), kAttachment, true, sky)},
                 Attachment(depth.view(), kDepthAttachment, false, far_depth));
  if (draw_mesh) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.deferred.get());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.lit_layout.get(), 0, 1, &sets.deferred,
                            0, nullptr);
    const glm::mat4 clip_to_world = glm::inverse(world_to_clip);
    vkCmdPushConstants(cmd, pipelines_.lit_layout.get(), kStages, 0, sizeof(clip_to_world), &clip_to_world);
    vkCmdDraw(cmd, 3, 1, 0, 0);
  }
  if (s.draw_ground) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.ground.get());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.lit_layout.get(), 0, 1, &sets.deferred,
                            0, nullptr);
    const GroundPush ground{world_to_clip, glm::vec4(s.target.x, s.ground_height, s.target.z, s.ground_half_side),
                            kGroundAlbedo};
    vkCmdPushConstants(cmd, pipelines_.lit_layout.get(), kStages, 0, sizeof(ground), &ground);
    vkCmdDraw(cmd, 6, 1, 0, 0);
  }
  if (s.draw_impostor) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.impostor_lit.get());
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelines_.lit_layout.get(), 0, 1, &sets.impostor,
                            0, nullptr);
    vkCmdPushConstants(cmd, pipelines_.lit_layout.get(), kStages, 0, sizeof(impostor_push), &impostor_push);
    vkCmdDraw(cmd, 6, 1, 0, 0);
  }
  vkCmdEndRendering(cmd);

  c.old_layout = kAttachment;
  c.new_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  c.src_stage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
  c.src_access = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
  c.dst_stage = VK_PIPELINE_STAGE_2_COPY_BIT;
  c.dst_access = VK_ACCESS_2_TRANSFER_READ_BIT;
  gpu::TransitionImage(cmd, c);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {w, h, 1};
  vkCmdCopyImageToBuffer(cmd, colour.image(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback.buffer(), 1, &region);
  gpu::MemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  IMPOSTOR_GPU_RETURN_IF_ERROR(runner_.SubmitAndWait());
  IMPOSTOR_GPU_RETURN_IF_ERROR(readback.InvalidateForHostRead());
  SceneImage out;
  out.width = setup.width;
  out.height = setup.height;
  const auto* bytes = static_cast<const uint8_t*>(readback.mapped());
  out.rgba.assign(bytes, bytes + static_cast<size_t>(w) * h * 4);
  return out;
}

}  // namespace

SceneSetup DefaultSetup(glm::vec3 center, float radius, bool side_by_side) {
  SceneSetup s;
  const float r = radius;
  if (side_by_side) {
    s.mesh_offset = glm::vec3(-1.15f * r, 0.0f, 0.0f);
    s.impostor_offset = glm::vec3(1.15f * r, 0.0f, 0.0f);
  }
  s.target = center;
  s.ground_height = center.y - 0.5f * r;  // a quarter of the way up the bounding sphere
  s.ground_half_side = (side_by_side ? 4.0f : 3.0f) * r;
  s.eye = center + glm::normalize(glm::vec3(0.25f, 0.5f, 0.85f)) * ((side_by_side ? 7.5f : 4.0f) * r);
  // From behind and to the right: the shadows fall toward the camera, left.
  s.toward_light = glm::normalize(glm::vec3(0.3f, 0.75f, -0.6f));
  return s;
}

absl::StatusOr<std::unique_ptr<SceneRenderer>> SceneRenderer::Create(const std::string& device) {
  auto renderer = std::make_unique<VulkanSceneRenderer>();
  if (absl::Status s = renderer->Init(device); !s.ok()) return s;
  return renderer;
}

}  // namespace impostor::example
