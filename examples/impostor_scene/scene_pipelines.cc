#include "examples/impostor_scene/scene_pipelines.h"

#include <array>
#include <cstdint>
#include <vector>

#include "worker/gpu/vk_check.h"
#include "worker/scene/scene.h"
// Generated SPIR-V (shaders/CMakeLists.txt); <cstdint> first.
#include "shaders/impostor_material_lit_frag.h"
#include "shaders/impostor_runtime_check_vert.h"
#include "shaders/impostor_scene_deferred_frag.h"
#include "shaders/impostor_scene_depth_vert.h"
#include "shaders/impostor_scene_fullscreen_vert.h"
#include "shaders/impostor_scene_ground_frag.h"
#include "shaders/impostor_scene_ground_vert.h"
#include "shaders/impostor_shadow_caster_frag.h"

namespace impostor::example {
namespace {

using gpu::UniquePipeline;
using gpu::UniqueShaderModule;

struct Spirv {
  const uint32_t* code;
  size_t bytes;
};

// What differs between the pipelines; the rest is fixed below.
struct PipelineSpec {
  Spirv vert;
  Spirv frag{nullptr, 0};  // none: depth only
  VkPipelineLayout layout = VK_NULL_HANDLE;
  bool mesh_positions = false;  // vertex input: SceneVertex::position
  bool depth_test = true;
  bool depth_write = true;
  bool colour = true;  // one kColourFormat attachment, else depth only
  VkFormat depth_format = VK_FORMAT_D32_SFLOAT;
  const VkSpecializationInfo* specialization = nullptr;  // fragment stage
};

absl::StatusOr<UniqueShaderModule> Module(const gpu::VulkanContext& ctx, Spirv spirv) {
  VkShaderModuleCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
  info.codeSize = spirv.bytes;
  info.pCode = spirv.code;
  VkShaderModule module = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateShaderModule(ctx.device(), &info, nullptr, &module));
  return UniqueShaderModule(ctx.device(), module);
}

absl::StatusOr<UniquePipeline> Build(const gpu::VulkanContext& ctx, const PipelineSpec& spec) {
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(UniqueShaderModule vert, Module(ctx, spec.vert));
  UniqueShaderModule frag;
  std::vector<VkPipelineShaderStageCreateInfo> stages(1);
  stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vert.get();
  stages[0].pName = "main";
  if (spec.frag.code != nullptr) {
    IMPOSTOR_GPU_ASSIGN_OR_RETURN(frag, Module(ctx, spec.frag));
    VkPipelineShaderStageCreateInfo f{};
    f.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    f.stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    f.module = frag.get();
    f.pName = "main";
    f.pSpecializationInfo = spec.specialization;
    stages.push_back(f);
  }
  const VkVertexInputBindingDescription binding{0, sizeof(SceneVertex), VK_VERTEX_INPUT_RATE_VERTEX};
  const VkVertexInputAttributeDescription position{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(SceneVertex, position)};
  VkPipelineVertexInputStateCreateInfo vertex_input{};
  vertex_input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
  if (spec.mesh_positions) {
    vertex_input.vertexBindingDescriptionCount = 1;
    vertex_input.pVertexBindingDescriptions = &binding;
    vertex_input.vertexAttributeDescriptionCount = 1;
    vertex_input.pVertexAttributeDescriptions = &position;
  }
  VkPipelineInputAssemblyStateCreateInfo input_assembly{};
  input_assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
  input_assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport{};
  viewport.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  // No culling anywhere: the impostor's card and the ground are seen from
  // either side, and the shadow pass draws both faces of the mesh.
  VkPipelineRasterizationStateCreateInfo raster{};
  raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = VK_CULL_MODE_NONE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample{};
  multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo depth{};
  depth.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
  depth.depthTestEnable = spec.depth_test ? VK_TRUE : VK_FALSE;
  depth.depthWriteEnable = spec.depth_write ? VK_TRUE : VK_FALSE;
  depth.depthCompareOp = VK_COMPARE_OP_LESS;
  VkPipelineColorBlendAttachmentState attachment{};
  attachment.colorWriteMask =
      VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  VkPipelineColorBlendStateCreateInfo blend{};
  blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
  blend.attachmentCount = spec.colour ? 1 : 0;
  blend.pAttachments = &attachment;
  const std::array<VkDynamicState, 2> dynamic_states = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{};
  dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
  dynamic.dynamicStateCount = static_cast<uint32_t>(dynamic_states.size());
  dynamic.pDynamicStates = dynamic_states.data();
  const VkFormat colour_format = kColourFormat;
  VkPipelineRenderingCreateInfo rendering{};
  rendering.sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO;
  rendering.colorAttachmentCount = spec.colour ? 1 : 0;
  rendering.pColorAttachmentFormats = &colour_format;
  rendering.depthAttachmentFormat = spec.depth_format;

  VkGraphicsPipelineCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
  info.pNext = &rendering;
  info.stageCount = static_cast<uint32_t>(stages.size());
  info.pStages = stages.data();
  info.pVertexInputState = &vertex_input;
  info.pInputAssemblyState = &input_assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pDepthStencilState = &depth;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = spec.layout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateGraphicsPipelines(ctx.device(), VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
  return UniquePipeline(ctx.device(), pipeline);
}

absl::StatusOr<gpu::UniqueDescriptorSetLayout> SetLayout(const gpu::VulkanContext& ctx,
                                                         const std::vector<VkDescriptorType>& bindings) {
  std::vector<VkDescriptorSetLayoutBinding> b(bindings.size());
  for (uint32_t i = 0; i < b.size(); ++i) {
    b[i].binding = i;
    b[i].descriptorType = bindings[i];
    b[i].descriptorCount = 1;
    b[i].stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT;
  }
  VkDescriptorSetLayoutCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
  info.bindingCount = static_cast<uint32_t>(b.size());
  info.pBindings = b.data();
  VkDescriptorSetLayout layout = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreateDescriptorSetLayout(ctx.device(), &info, nullptr, &layout));
  return gpu::UniqueDescriptorSetLayout(ctx.device(), layout);
}

absl::StatusOr<gpu::UniquePipelineLayout> PipelineLayout(const gpu::VulkanContext& ctx, VkDescriptorSetLayout set) {
  const VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, kPushBytes};
  VkPipelineLayoutCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  info.setLayoutCount = 1;
  info.pSetLayouts = &set;
  info.pushConstantRangeCount = 1;
  info.pPushConstantRanges = &range;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  IMPOSTOR_VK_RETURN_IF_ERROR(vkCreatePipelineLayout(ctx.device(), &info, nullptr, &layout));
  return gpu::UniquePipelineLayout(ctx.device(), layout);
}

#define IMPOSTOR_SPIRV(name) Spirv{name, sizeof(name)}

}  // namespace

absl::StatusOr<ScenePipelines> ScenePipelines::Create(const gpu::VulkanContext& ctx, int layout, int blend_mode,
                                                      bool parallax) {
  ScenePipelines p;
  // constant_id 0 = the parallax march (a VkBool32), 1 = layout, 2 = blend mode.
  const std::array<int32_t, 3> constants = {parallax ? 1 : 0, layout, blend_mode};
  const std::array<VkSpecializationMapEntry, 3> entries = {{{0, 0, 4}, {1, 4, 4}, {2, 8, 4}}};
  const VkSpecializationInfo specialization{3, entries.data(), sizeof(constants), constants.data()};
  constexpr VkDescriptorType kTexture = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  constexpr VkDescriptorType kUniform = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.lit_set, SetLayout(ctx, {kTexture, kTexture, kTexture, kTexture, kUniform, kUniform}));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.caster_set, SetLayout(ctx, {kTexture, kTexture}));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.lit_layout, PipelineLayout(ctx, p.lit_set.get()));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.caster_layout, PipelineLayout(ctx, p.caster_set.get()));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.mesh_depth, Build(ctx, {.vert = IMPOSTOR_SPIRV(impostor_scene_depth_vert),
                                                          .layout = p.caster_layout.get(),
                                                          .mesh_positions = true,
                                                          .colour = false,
                                                          .depth_format = kShadowFormat}));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.impostor_caster, Build(ctx, {.vert = IMPOSTOR_SPIRV(impostor_runtime_check_vert),
                                                               .frag = IMPOSTOR_SPIRV(impostor_shadow_caster_frag),
                                                               .layout = p.caster_layout.get(),
                                                               .colour = false,
                                                               .depth_format = kShadowFormat,
                                                               .specialization = &specialization}));
  // The deferred pass writes colour only: the depth buffer already holds
  // the mesh's depth from the G-buffer pass.
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.deferred, Build(ctx, {.vert = IMPOSTOR_SPIRV(impostor_scene_fullscreen_vert),
                                                        .frag = IMPOSTOR_SPIRV(impostor_scene_deferred_frag),
                                                        .layout = p.lit_layout.get(),
                                                        .depth_test = false,
                                                        .depth_write = false}));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.ground, Build(ctx, {.vert = IMPOSTOR_SPIRV(impostor_scene_ground_vert),
                                                      .frag = IMPOSTOR_SPIRV(impostor_scene_ground_frag),
                                                      .layout = p.lit_layout.get()}));
  IMPOSTOR_GPU_ASSIGN_OR_RETURN(p.impostor_lit, Build(ctx, {.vert = IMPOSTOR_SPIRV(impostor_runtime_check_vert),
                                                            .frag = IMPOSTOR_SPIRV(impostor_material_lit_frag),
                                                            .layout = p.lit_layout.get(),
                                                            .specialization = &specialization}));
  return p;
}

}  // namespace impostor::example
