#include "worker/scene/gltf_materials.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <span>
#include <string>

#include "absl/strings/str_cat.h"
#include "worker/scene/texture_decode.h"

namespace impostor::gltf_internal {
namespace {

std::string MaterialName(const tinygltf::Model& model, int index) {
  if (index < 0) return "default material";
  return absl::StrCat("material ", index, " '", model.materials[index].name, "'");
}

bool AllFinite(std::span<const double> values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

int WrapMode(int mode) {
  switch (mode) {
    case TINYGLTF_TEXTURE_WRAP_REPEAT:
    case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE:
    case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT:
      return mode;
    default:
      spdlog::debug("gltf: sampler wrap mode {} is invalid, using REPEAT", mode);
      return TINYGLTF_TEXTURE_WRAP_REPEAT;
  }
}

// KHR_texture_transform of a texture reference, as the 3x3 matrix
// T * R * S the extension defines (column-major for glm).
std::optional<glm::mat3> TextureTransform(const tinygltf::ExtensionMap& extensions) {
  auto it = extensions.find("KHR_texture_transform");
  if (it == extensions.end() || !it->second.IsObject()) return std::nullopt;
  const tinygltf::Value& ext = it->second;
  glm::vec2 offset(0.0f), scale(1.0f);
  float rotation = 0.0f;
  auto vec2 = [&](const char* key, glm::vec2* out) {
    const tinygltf::Value& v = ext.Get(key);
    if (v.IsArray() && v.ArrayLen() == 2 && v.Get(0).IsNumber() && v.Get(1).IsNumber()) {
      *out = glm::vec2(v.Get(0).GetNumberAsDouble(), v.Get(1).GetNumberAsDouble());
    }
  };
  vec2("offset", &offset);
  vec2("scale", &scale);
  if (ext.Get("rotation").IsNumber()) rotation = ext.Get("rotation").GetNumberAsDouble();
  if (ext.Has("texCoord")) {
    spdlog::debug("gltf: KHR_texture_transform texCoord override ignored (TEXCOORD_0 used)");
  }
  const float c = std::cos(rotation), s = std::sin(rotation);
  // u' = ox + c*sx*u + s*sy*v ; v' = oy - s*sx*u + c*sy*v
  glm::mat3 m(glm::vec3(c * scale.x, -s * scale.x, 0.0f), glm::vec3(s * scale.y, c * scale.y, 0.0f),
              glm::vec3(offset, 1.0f));
  for (int col = 0; col < 3; ++col) {
    for (int row = 0; row < 3; ++row) {
      if (!std::isfinite(m[col][row])) return std::nullopt;
    }
  }
  return m;
}

}  // namespace

MaterialTable::MaterialTable(const tinygltf::Model& model, const GltfLoadLimits& limits,
                             Scene* scene)
    : model_(model), limits_(limits), scene_(scene) {}

absl::StatusOr<int> MaterialTable::Use(int gltf_index) {
  if (gltf_index < -1 ||
      (gltf_index >= 0 && static_cast<size_t>(gltf_index) >= model_.materials.size())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "material ", gltf_index, " does not exist (the file has ", model_.materials.size(), ")"));
  }
  auto it = materials_.find(gltf_index);
  if (it != materials_.end()) return it->second;
  absl::StatusOr<int> index = Convert(gltf_index);
  if (index.ok()) materials_[gltf_index] = *index;
  return index;
}

absl::StatusOr<int> MaterialTable::Convert(int gltf_index) {
  SceneMaterial out;  // defaults are the glTF default material
  std::optional<glm::mat3> uv_transform;
  if (gltf_index >= 0) {
    const tinygltf::Material& m = model_.materials[gltf_index];
    const std::string what = MaterialName(model_, gltf_index);
    const tinygltf::PbrMetallicRoughness& pbr = m.pbrMetallicRoughness;
    const double scalars[] = {pbr.metallicFactor, pbr.roughnessFactor, m.alphaCutoff,
                              m.normalTexture.scale, m.occlusionTexture.strength};
    if (pbr.baseColorFactor.size() != 4 || !AllFinite(pbr.baseColorFactor) || !AllFinite(scalars)) {
      return absl::InvalidArgumentError(
          absl::StrCat(what,
                       ": baseColorFactor/metallic/roughness/alphaCutoff/scale/strength "
                       "must be finite numbers (baseColorFactor has 4)"));
    }
    out.name = m.name;
    out.base_color_factor = glm::vec4(pbr.baseColorFactor[0], pbr.baseColorFactor[1],
                                      pbr.baseColorFactor[2], pbr.baseColorFactor[3]);
    out.metallic_factor = static_cast<float>(pbr.metallicFactor);
    out.roughness_factor = static_cast<float>(pbr.roughnessFactor);
    out.normal_scale = static_cast<float>(m.normalTexture.scale);
    out.occlusion_strength = static_cast<float>(m.occlusionTexture.strength);
    out.alpha_cutoff = static_cast<float>(m.alphaCutoff);
    out.double_sided = m.doubleSided;
    if (m.alphaMode == "MASK") {
      out.alpha_mode = AlphaMode::kMask;
    } else if (m.alphaMode == "BLEND") {
      out.alpha_mode = AlphaMode::kBlend;
    } else if (m.alphaMode != "OPAQUE") {
      spdlog::debug("gltf: {}: unknown alphaMode '{}', using OPAQUE", what, m.alphaMode);
    }
    absl::StatusOr<int> t = UseTexture(pbr.baseColorTexture, /*srgb=*/true, gltf_index);
    if (!t.ok()) return t.status();
    out.base_color_texture = *t;
    t = UseTexture(pbr.metallicRoughnessTexture, false, gltf_index);
    if (!t.ok()) return t.status();
    out.metallic_roughness_texture = *t;
    t = UseTexture(m.normalTexture.index, m.normalTexture.texCoord, false, gltf_index, "normal");
    if (!t.ok()) return t.status();
    out.normal_texture = *t;
    t = UseTexture(m.occlusionTexture.index, m.occlusionTexture.texCoord, false, gltf_index,
                   "occlusion");
    if (!t.ok()) return t.status();
    out.occlusion_texture = *t;
    // One UV set per vertex: the base colour texture's transform wins; the
    // other maps of the same material are assumed to share it.
    if (pbr.baseColorTexture.index >= 0) {
      uv_transform = TextureTransform(pbr.baseColorTexture.extensions);
    }
  }
  scene_->materials.push_back(std::move(out));
  uv_transforms_.push_back(uv_transform);
  return static_cast<int>(scene_->materials.size() - 1);
}

absl::StatusOr<int> MaterialTable::UseTexture(const tinygltf::TextureInfo& info, bool srgb,
                                              int material) {
  return UseTexture(info.index, info.texCoord, srgb, material,
                    srgb ? "baseColor" : "metallicRoughness");
}

absl::StatusOr<int> MaterialTable::UseTexture(int texture, int tex_coord, bool srgb, int material,
                                              const char* slot) {
  if (texture == -1) return -1;
  const std::string what = absl::StrCat(MaterialName(model_, material), " ", slot, "Texture");
  if (texture < 0 || static_cast<size_t>(texture) >= model_.textures.size()) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": texture ", texture, " does not exist"));
  }
  if (tex_coord != 0) {
    spdlog::debug("gltf: {} uses TEXCOORD_{}; falling back to TEXCOORD_0", what, tex_coord);
  }
  const tinygltf::Texture& tex = model_.textures[texture];
  if (tex.source == -1) {
    // KHR_texture_basisu / EXT_texture_webp put the image in an extension
    // this loader cannot decode; without a fallback source the map is
    // dropped (the material factor alone is used).
    spdlog::debug("gltf: {}: texture {} has no PNG/JPEG source; ignored", what, texture);
    return -1;
  }
  if (tex.source < 0 || static_cast<size_t>(tex.source) >= model_.images.size()) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": texture ", texture, " names image ",
                                                   tex.source, " which does not exist"));
  }
  int wrap_s = TINYGLTF_TEXTURE_WRAP_REPEAT, wrap_t = TINYGLTF_TEXTURE_WRAP_REPEAT;
  if (tex.sampler != -1) {
    if (tex.sampler < 0 || static_cast<size_t>(tex.sampler) >= model_.samplers.size()) {
      return absl::InvalidArgumentError(absl::StrCat(what, ": texture ", texture, " names sampler ",
                                                     tex.sampler, " which does not exist"));
    }
    wrap_s = WrapMode(model_.samplers[tex.sampler].wrapS);
    wrap_t = WrapMode(model_.samplers[tex.sampler].wrapT);
  }
  const auto key = std::make_tuple(tex.source, wrap_s, wrap_t, srgb);
  if (auto it = textures_.find(key); it != textures_.end()) return it->second;

  const tinygltf::Image& image = model_.images[tex.source];
  const std::string image_what =
      absl::StrCat("image[", tex.source, "] '", image.name.empty() ? image.uri : image.name, "'");
  SceneTexture out;
  out.srgb = srgb;
  out.wrap_s = wrap_s;
  out.wrap_t = wrap_t;
  out.name = image.name.empty() ? image.uri : image.name;
  if (auto it = decoded_.find(tex.source); it != decoded_.end()) {
    const SceneTexture& same = scene_->textures[it->second];
    out.width = same.width;
    out.height = same.height;
    const uint64_t bytes = same.rgba8.size();
    if (texture_bytes_ + bytes > limits_.max_texture_bytes) {
      return absl::ResourceExhaustedError(
          absl::StrCat(image_what, ": textures need more than GltfLoadLimits::max_texture_bytes = ",
                       limits_.max_texture_bytes, " bytes"));
    }
    texture_bytes_ += bytes;
    out.rgba8 = same.rgba8;  // same image, other sampler or colour space
  } else {
    if (image.image.empty()) {
      if (!image.uri.empty() && image.uri.rfind("data:", 0) != 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(image_what, " refers to missing file '", image.uri, "'"));
      }
      return absl::InvalidArgumentError(absl::StrCat(image_what, " has no image data"));
    }
    absl::StatusOr<DecodedImage> decoded =
        DecodeImageRgba8(image.image, limits_.max_texture_dimension,
                         limits_.max_texture_bytes - texture_bytes_, image_what);
    if (decoded.status().code() == absl::StatusCode::kUnimplemented) {
      // e.g. a KTX2 image named as `source` (KHR_texture_basisu not marked
      // required): bake with the material factors alone rather than refuse.
      spdlog::warn("gltf: {}; texture ignored", std::string(decoded.status().message()));
      textures_[key] = -1;
      return -1;
    }
    if (!decoded.ok()) return decoded.status();
    texture_bytes_ += decoded->rgba8.size();
    out.width = decoded->width;
    out.height = decoded->height;
    out.rgba8 = std::move(decoded->rgba8);
    decoded_[tex.source] = static_cast<int>(scene_->textures.size());
    spdlog::debug("gltf: decoded {} ({}x{})", image_what, out.width, out.height);
  }
  scene_->textures.push_back(std::move(out));
  const int index = static_cast<int>(scene_->textures.size() - 1);
  textures_[key] = index;
  return index;
}

}  // namespace impostor::gltf_internal
