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
// T * R * S the extension defines (column-major for glm), and its texCoord
// override (-1 when absent).
struct TextureTransformExt {
  glm::mat3 matrix{1.0f};
  int tex_coord = -1;
};
std::optional<TextureTransformExt> TextureTransform(const tinygltf::ExtensionMap& extensions) {
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
  TextureTransformExt out;
  if (ext.Get("texCoord").IsNumber()) {
    const double t = ext.Get("texCoord").GetNumberAsDouble();
    out.tex_coord = t >= 0.0 && t <= 1000.0 ? static_cast<int>(t) : 1000;
  }
  const float c = std::cos(rotation), s = std::sin(rotation);
  // u' = ox + c*sx*u + s*sy*v ; v' = oy - s*sx*u + c*sy*v
  glm::mat3 m(glm::vec3(c * scale.x, -s * scale.x, 0.0f), glm::vec3(s * scale.y, c * scale.y, 0.0f),
              glm::vec3(offset, 1.0f));
  for (int col = 0; col < 3; ++col) {
    for (int row = 0; row < 3; ++row) {
      if (!std::isfinite(m[col][row])) m = glm::mat3(1.0f);
    }
  }
  out.matrix = m;
  return out;
}

}  // namespace

MaterialTable::MaterialTable(const tinygltf::Model& model, const GltfLoadLimits& limits,
                             Scene* scene, PredecodedImages* predecoded)
    : model_(model), limits_(limits), scene_(scene), predecoded_(predecoded) {}

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
    if (m.emissiveFactor.size() == 3 && AllFinite(m.emissiveFactor)) {
      out.emissive_factor =
          glm::vec3(m.emissiveFactor[0], m.emissiveFactor[1], m.emissiveFactor[2]);
    }
    if (auto it = m.extensions.find("KHR_materials_emissive_strength");
        it != m.extensions.end() && it->second.IsObject() &&
        it->second.Get("emissiveStrength").IsNumber()) {
      const double strength = it->second.Get("emissiveStrength").GetNumberAsDouble();
      if (std::isfinite(strength) && strength >= 0.0) {
        out.emissive_strength = static_cast<float>(strength);
      }
    }
    if (m.alphaMode == "MASK") {
      out.alpha_mode = AlphaMode::kMask;
    } else if (m.alphaMode == "BLEND") {
      out.alpha_mode = AlphaMode::kBlend;
    } else if (m.alphaMode != "OPAQUE") {
      spdlog::debug("gltf: {}: unknown alphaMode '{}', using OPAQUE", what, m.alphaMode);
    }
    absl::StatusOr<int> t = UseSlot(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord,
                                    pbr.baseColorTexture.extensions, /*srgb=*/true, gltf_index,
                                    kSlotBaseColor, &out);
    if (!t.ok()) return t.status();
    out.base_color_texture = *t;
    t = UseSlot(pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord,
                pbr.metallicRoughnessTexture.extensions, false, gltf_index,
                kSlotMetallicRoughness, &out);
    if (!t.ok()) return t.status();
    out.metallic_roughness_texture = *t;
    t = UseSlot(m.normalTexture.index, m.normalTexture.texCoord, m.normalTexture.extensions, false,
                gltf_index, kSlotNormal, &out);
    if (!t.ok()) return t.status();
    out.normal_texture = *t;
    t = UseSlot(m.occlusionTexture.index, m.occlusionTexture.texCoord,
                m.occlusionTexture.extensions, false, gltf_index, kSlotOcclusion, &out);
    if (!t.ok()) return t.status();
    out.occlusion_texture = *t;
    t = UseSlot(m.emissiveTexture.index, m.emissiveTexture.texCoord, m.emissiveTexture.extensions,
                /*srgb=*/true, gltf_index, kSlotEmissive, &out);
    if (!t.ok()) return t.status();
    out.emissive_texture = *t;
    // Accepted (the file's opaque fallback is what the bake draws), but an
    // artist must not learn from the atlas alone that a glass went solid.
    if (auto it = m.extensions.find("KHR_materials_transmission");
        it != m.extensions.end() && it->second.IsObject() && it->second.Get("transmissionFactor").IsNumber()) {
      const double transmission = it->second.Get("transmissionFactor").GetNumberAsDouble();
      if (std::isfinite(transmission) && transmission > 0.0) {
        AddWarning(absl::StrCat(what, " is transmissive (KHR_materials_transmission, transmissionFactor ",
                                transmission, "): baked as an opaque surface, so what shows through it is "
                                "not in the impostor; for see-through glass use alphaMode BLEND"));
      }
    }
    if (out.alpha_mode == AlphaMode::kMask && out.base_color_texture >= 0 &&
        !scene_->textures[out.base_color_texture].has_alpha_channel) {
      AddWarning(absl::StrCat(what, " is MASK but its base colour image '",
                              scene_->textures[out.base_color_texture].name,
                              "' has no alpha channel: the cutout comes from baseColorFactor "
                              "and vertex colour alone"));
    }
  }
  for (int slot = 0; slot < kTextureSlotCount; ++slot) {
    if (out.uv[slot].tex_coord == 1) uses_uv1_ = true;
  }
  scene_->materials.push_back(std::move(out));
  return static_cast<int>(scene_->materials.size() - 1);
}

void MaterialTable::AddWarning(std::string warning) {
  for (const std::string& w : scene_->warnings) {
    if (w == warning) return;
  }
  spdlog::warn("gltf: warning=\"{}\"", warning);
  scene_->warnings.push_back(std::move(warning));
}

absl::StatusOr<int> MaterialTable::UseSlot(int texture, int tex_coord,
                                           const tinygltf::ExtensionMap& extensions, bool srgb,
                                           int material, TextureSlot slot, SceneMaterial* out) {
  static constexpr const char* kSlotNames[] = {"baseColor", "metallicRoughness", "normal",
                                               "occlusion", "emissive"};
  if (texture == -1) return -1;
  const std::string what =
      absl::StrCat(MaterialName(model_, material), " ", kSlotNames[slot], "Texture");
  SlotUv& uv = out->uv[slot];
  uv.tex_coord = tex_coord;
  if (std::optional<TextureTransformExt> transform = TextureTransform(extensions)) {
    uv.transform = transform->matrix;
    if (transform->tex_coord >= 0) uv.tex_coord = transform->tex_coord;
  }
  if (uv.tex_coord != 0 && uv.tex_coord != 1) {
    AddWarning(absl::StrCat(what, " uses TEXCOORD_", uv.tex_coord,
                            "; only sets 0 and 1 are baked, TEXCOORD_0 used instead"));
    uv.tex_coord = 0;
  }
  return UseTexture(texture, srgb, material, kSlotNames[slot]);
}

absl::StatusOr<int> MaterialTable::UseTexture(int texture, bool srgb, int material,
                                              const char* slot) {
  if (texture == -1) return -1;
  const std::string what = absl::StrCat(MaterialName(model_, material), " ", slot, "Texture");
  if (texture < 0 || static_cast<size_t>(texture) >= model_.textures.size()) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": texture ", texture, " does not exist"));
  }
  const tinygltf::Texture& tex = model_.textures[texture];
  if (tex.source == -1) {
    // KHR_texture_basisu / EXT_texture_webp put the image in an extension
    // this loader cannot decode; without a fallback source the map is
    // dropped (the material factor alone is used).
    AddWarning(absl::StrCat(what, ": texture ", texture,
                            " has no PNG/JPEG source (KTX2/WebP only); the map is dropped and "
                            "the material's factors are used"));
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
  const std::string image_what = ImageWhat(model_, tex.source);
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
    out.has_alpha_channel = same.has_alpha_channel;
    out.rgba8 = same.rgba8;  // same image, other sampler or colour space: shared bytes
  } else {
    if (image.image.empty()) {
      if (!image.uri.empty() && image.uri.rfind("data:", 0) != 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(image_what, " refers to missing file '", image.uri, "'"));
      }
      return absl::InvalidArgumentError(absl::StrCat(image_what, " has no image data"));
    }
    // Decoded beforehand, side by side (image_predecode.h), or now.
    PredecodedImages::node_type predecoded =
        predecoded_ != nullptr ? predecoded_->extract(tex.source) : PredecodedImages::node_type();
    absl::StatusOr<DecodedImage> decoded =
        !predecoded.empty() ? std::move(predecoded.mapped())
                            : DecodeImageRgba8(image.image, limits_.max_texture_dimension,
                                               limits_.max_texture_bytes - texture_bytes_, image_what);
    if (decoded.status().code() == absl::StatusCode::kUnimplemented) {
      // e.g. a KTX2 image named as `source` (KHR_texture_basisu not marked
      // required): bake with the material factors alone rather than refuse.
      AddWarning(absl::StrCat(std::string(decoded.status().message()),
                              "; the map is dropped and the material's factors are used"));
      textures_[key] = -1;
      return -1;
    }
    if (!decoded.ok()) return decoded.status();
    texture_bytes_ += decoded->rgba8.size();
    out.width = decoded->width;
    out.height = decoded->height;
    out.rgba8 = std::move(decoded->rgba8);
    out.has_alpha_channel = decoded->source_channels == 2 || decoded->source_channels == 4;
    decoded_[tex.source] = static_cast<int>(scene_->textures.size());
    spdlog::debug("gltf: decoded {} ({}x{})", image_what, out.width, out.height);
  }
  scene_->textures.push_back(std::move(out));
  const int index = static_cast<int>(scene_->textures.size() - 1);
  textures_[key] = index;
  return index;
}

}  // namespace impostor::gltf_internal
