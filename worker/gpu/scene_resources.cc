#include "worker/gpu/scene_resources.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <string>

#include "absl/strings/str_cat.h"
#include "worker/gpu/gpu_memory.h"
#include "worker/gpu/vk_check.h"

namespace impostor::gpu {
namespace {

VkSamplerAddressMode AddressMode(int gltf_wrap) {
  switch (gltf_wrap) {
    case 33071:
      return VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    case 33648:
      return VK_SAMPLER_ADDRESS_MODE_MIRRORED_REPEAT;
    default:  // 10497 REPEAT, and glTF's default for anything unknown
      return VK_SAMPLER_ADDRESS_MODE_REPEAT;
  }
}

}  // namespace

absl::StatusOr<VkSampler> SceneResources::SamplerFor(const VulkanContext& ctx, int wrap_s,
                                                     int wrap_t) {
  auto it = samplers_.find({wrap_s, wrap_t});
  if (it != samplers_.end()) return it->second.get();
  VkSamplerCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
  // Trilinear (+ anisotropic or a mip bias, texture_filter.h): atlas tiles
  // nearly always show textures minified.
  info.magFilter = VK_FILTER_LINEAR;
  info.minFilter = VK_FILTER_LINEAR;
  info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
  info.addressModeU = AddressMode(wrap_s);
  info.addressModeV = AddressMode(wrap_t);
  info.addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT;
  info.anisotropyEnable = filter_.anisotropy ? VK_TRUE : VK_FALSE;
  info.maxAnisotropy = filter_.max_anisotropy;
  info.mipLodBias = filter_.mip_lod_bias;
  info.minLod = 0.0f;
  info.maxLod = VK_LOD_CLAMP_NONE;
  VkSampler sampler = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateSampler(ctx.device(), &info, nullptr, &sampler));
  samplers_.emplace(std::make_pair(wrap_s, wrap_t), UniqueSampler(ctx.device(), sampler));
  return sampler;
}

absl::Status SceneResources::UseFilter(const VulkanContext& ctx, const BakePipeline& pipeline, const Scene& scene,
                                     const TextureFilter& filter) {
  if (filter == filter_) return absl::OkStatus();
  // The sets name the old samplers: the pool (and with it the sets) first.
  material_sets_.clear();
  descriptor_pool_.Reset();
  samplers_.clear();
  filter_ = filter;
  return BindMaterials(ctx, pipeline, scene);
}

absl::Status SceneResources::BindMaterials(const VulkanContext& ctx, const BakePipeline& pipeline,
                                           const Scene& scene) {
  const uint32_t material_count = static_cast<uint32_t>(scene.materials.size());
  const std::array<VkDescriptorPoolSize, 2> pool_sizes = {{
      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, material_count * kMaterialTextureCount},
      {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, material_count},
  }};
  VkDescriptorPoolCreateInfo pool_info{};
  pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
  pool_info.maxSets = material_count;
  pool_info.poolSizeCount = static_cast<uint32_t>(pool_sizes.size());
  pool_info.pPoolSizes = pool_sizes.data();
  VkDescriptorPool pool = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateDescriptorPool(ctx.device(), &pool_info, nullptr, &pool));
  descriptor_pool_ = UniqueDescriptorPool(ctx.device(), pool);

  const std::vector<VkDescriptorSetLayout> layouts(material_count, pipeline.set_layout());
  VkDescriptorSetAllocateInfo alloc{};
  alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
  alloc.descriptorPool = pool;
  alloc.descriptorSetCount = material_count;
  alloc.pSetLayouts = layouts.data();
  material_sets_.resize(material_count);
  IMPOSTOR_VK_RETURN_IF_ERROR(
      vkAllocateDescriptorSets(ctx.device(), &alloc, material_sets_.data()));

  for (uint32_t m = 0; m < material_count; ++m) {
    const SceneMaterial& material = scene.materials[m];
    // Slot order matches the bindings in shaders/bake.frag.
    const std::array<int, kMaterialTextureCount> texture_of = {
        material.base_color_texture, material.metallic_roughness_texture, material.normal_texture,
        material.occlusion_texture, material.emissive_texture};
    std::array<VkDescriptorImageInfo, kMaterialTextureCount> images{};
    for (uint32_t slot = 0; slot < kMaterialTextureCount; ++slot) {
      const int t = texture_of[slot];
      const bool color = slot == kSlotBaseColor || slot == kSlotEmissive;
      if (t < 0) {
        const UploadedTexture& fallback = slot == 2 ? flat_normal_ : white_;
        IMPOSTOR_GPU_ASSIGN_OR_RETURN(images[slot].sampler, SamplerFor(ctx, 10497, 10497));
        images[slot].imageView = fallback.unorm_view;
      } else {
        const SceneTexture& source = scene.textures[t];
        IMPOSTOR_GPU_ASSIGN_OR_RETURN(images[slot].sampler,
                                      SamplerFor(ctx, source.wrap_s, source.wrap_t));
        // Base colour and emissive decode sRGB to linear in the sampler; the
        // other maps are data and read raw.
        images[slot].imageView = color ? textures_[t].srgb_view : textures_[t].unorm_view;
      }
      images[slot].imageLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    }
    const VkDescriptorBufferInfo uniforms{material_uniforms_.buffer(), m * uniform_stride_,
                                          sizeof(MaterialUniforms)};
    std::array<VkWriteDescriptorSet, kMaterialTextureCount + 1> writes{};
    for (uint32_t slot = 0; slot < writes.size(); ++slot) {
      writes[slot].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
      writes[slot].dstSet = material_sets_[m];
      writes[slot].dstBinding = slot;
      writes[slot].descriptorCount = 1;
      if (slot == kMaterialUniformBinding) {
        writes[slot].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        writes[slot].pBufferInfo = &uniforms;
      } else {
        writes[slot].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        writes[slot].pImageInfo = &images[slot];
      }
    }
    vkUpdateDescriptorSets(ctx.device(), static_cast<uint32_t>(writes.size()), writes.data(), 0,
                           nullptr);
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<SceneResources>> SceneResources::Upload(const VulkanContext& ctx,
                                                                       CommandRunner& runner,
                                                                       const BakePipeline& pipeline,
                                                                       const Scene& scene,
                                                                       const TextureFilter& filter) {
  // Checked before anything is staged, naming the scene's counts: instancing
  // can flatten a few-KB glTF into more vertices than one device allocation
  // holds, and the staging copy (same size) would not fit either.
  const VkDeviceSize vertex_bytes = VkDeviceSize{scene.vertices.size()} * sizeof(SceneVertex);
  const VkDeviceSize index_bytes = VkDeviceSize{scene.indices.size()} * sizeof(uint32_t);
  IMPOSTOR_GPU_RETURN_IF_ERROR(CheckBufferFits(
      ctx, "vertex buffer", vertex_bytes,
      VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
      absl::StrCat(scene.vertices.size(), " vertices after instancing")));
  IMPOSTOR_GPU_RETURN_IF_ERROR(CheckBufferFits(
      ctx, "index buffer", index_bytes,
      VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
      absl::StrCat(scene.indices.size(), " indices after instancing")));

  std::unique_ptr<SceneResources> res(new SceneResources());
  res->filter_ = filter;
  StagingUploader uploader(ctx, runner);

  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      res->vertices_,
      uploader.UploadBuffer(scene.vertices.data(), scene.vertices.size() * sizeof(SceneVertex),
                            VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "scene vertices"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      res->indices_,
      uploader.UploadBuffer(scene.indices.data(), scene.indices.size() * sizeof(uint32_t),
                            VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "scene indices"));

  const uint8_t white[4] = {255, 255, 255, 255};
  const uint8_t flat_normal[4] = {128, 128, 255, 255};
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(res->white_,
                                uploader.UploadTexture(white, 1, 1, false, "default white"));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(
      res->flat_normal_, uploader.UploadTexture(flat_normal, 1, 1, false, "default flat normal"));

  // One MaterialUniforms block per material, each at a multiple of the
  // device's uniform offset alignment (at most 256 by the spec).
  const uint32_t material_count = static_cast<uint32_t>(scene.materials.size());
  const VkDeviceSize align =
      std::max<VkDeviceSize>(ctx.limits().minUniformBufferOffsetAlignment, 16);
  const VkDeviceSize uniform_stride = (sizeof(MaterialUniforms) + align - 1) / align * align;
  res->uniform_stride_ = uniform_stride;
  {
    std::vector<uint8_t> blocks(uniform_stride * material_count, 0);
    for (uint32_t m = 0; m < material_count; ++m) {
      const MaterialUniforms u = MakeMaterialUniforms(scene.materials[m]);
      std::memcpy(blocks.data() + m * uniform_stride, &u, sizeof(u));
    }
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(
        res->material_uniforms_,
        uploader.UploadBuffer(blocks.data(), blocks.size(), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                              "material uniforms"));
  }

  res->textures_.reserve(scene.textures.size());
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const SceneTexture& t = scene.textures[i];
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(
        UploadedTexture uploaded,
        uploader.UploadTexture(t.rgba8.data(), static_cast<uint32_t>(t.width),
                               static_cast<uint32_t>(t.height), t.srgb,
                               absl::StrCat("texture ", i, " ", t.name)));
    res->textures_.push_back(std::move(uploaded));
  }
  IMPOSTOR_GPU_RETURN_IF_ERROR(uploader.Finish());
  res->uploaded_bytes_ = uploader.uploaded_bytes();

  IMPOSTOR_GPU_RETURN_IF_ERROR(res->BindMaterials(ctx, pipeline, scene));
  spdlog::debug("gpu: uploaded {} vertices, {} triangles, {} textures ({} bytes staged)",
                scene.vertices.size(), scene.TriangleCount(), scene.textures.size(),
                res->uploaded_bytes_);
  return res;
}

}  // namespace impostor::gpu
