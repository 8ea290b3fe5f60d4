#include "worker/cards/cards_glb.h"

#include <algorithm>
#include <cstring>
#include <sstream>

#include <tiny_gltf.h>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

// Appends `bytes` to the buffer as a new bufferView (4-byte aligned) and
// returns its index.
int AddView(tinygltf::Model& model, const void* bytes, size_t size, int target) {
  std::vector<unsigned char>& data = model.buffers[0].data;
  data.resize((data.size() + 3) & ~size_t{3}, 0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = size;
  view.target = target;
  const auto* p = static_cast<const unsigned char*>(bytes);
  data.insert(data.end(), p, p + size);
  model.bufferViews.push_back(view);
  return static_cast<int>(model.bufferViews.size()) - 1;
}

int AddAccessor(tinygltf::Model& model, int view, int component, int type, size_t count,
                std::vector<double> min = {}, std::vector<double> max = {}) {
  tinygltf::Accessor a;
  a.bufferView = view;
  a.byteOffset = 0;
  a.componentType = component;
  a.type = type;
  a.count = count;
  a.minValues = std::move(min);
  a.maxValues = std::move(max);
  model.accessors.push_back(a);
  return static_cast<int>(model.accessors.size()) - 1;
}

int AddPngTexture(tinygltf::Model& model, const std::string& png, const char* name) {
  tinygltf::Image image;
  image.name = name;
  image.mimeType = "image/png";
  image.bufferView = AddView(model, png.data(), png.size(), 0);
  model.images.push_back(image);
  tinygltf::Texture texture;
  texture.source = static_cast<int>(model.images.size()) - 1;
  texture.sampler = 0;
  texture.name = name;
  model.textures.push_back(texture);
  return static_cast<int>(model.textures.size()) - 1;
}

}  // namespace

absl::StatusOr<std::string> EncodeCardsGlb(const CardsGlbInput& in) {
  if (in.cards.empty()) return absl::InvalidArgumentError("cards.glb: no cards");
  if (in.cards.size() != in.tiles.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("cards.glb: ", in.cards.size(), " cards but ", in.tiles.size(), " tiles"));
  }
  if (in.albedo_png.empty() || in.orm_png.empty() || in.atlas_size <= 0) {
    return absl::InvalidArgumentError("cards.glb: the albedo and ORM atlases are required");
  }

  std::vector<float> positions, normals, tangents, uvs;
  std::vector<uint32_t> indices;
  std::vector<double> lo(3, 1e300), hi(3, -1e300);
  const float inv = 1.0f / static_cast<float>(in.atlas_size);
  for (size_t c = 0; c < in.cards.size(); ++c) {
    const CardRect& card = in.cards[c];
    const TileRect& t = in.tiles[c];
    const auto corners = card.Corners();
    // (-u,-v) is the tile's bottom-left, (+u,+v) its top-right.
    const float u0 = t.x * inv, u1 = (t.x + t.width) * inv, v_top = t.y * inv, v_bottom = (t.y + t.height) * inv;
    const float corner_uv[4][2] = {{u0, v_bottom}, {u1, v_bottom}, {u1, v_top}, {u0, v_top}};
    const auto base = static_cast<uint32_t>(positions.size() / 3);
    for (int k = 0; k < 4; ++k) {
      for (int i = 0; i < 3; ++i) {
        positions.push_back(corners[k][i]);
        lo[i] = std::min(lo[i], static_cast<double>(corners[k][i]));
        hi[i] = std::max(hi[i], static_cast<double>(corners[k][i]));
        normals.push_back(card.normal[i]);
        tangents.push_back(card.u[i]);
      }
      tangents.push_back(1.0f);
      uvs.push_back(corner_uv[k][0]);
      uvs.push_back(corner_uv[k][1]);
    }
    for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) indices.push_back(base + i);
  }

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = in.generator;
  model.buffers.emplace_back();
  const size_t vertex_count = positions.size() / 3;
  const int position = AddAccessor(
      model, AddView(model, positions.data(), positions.size() * sizeof(float), kArrayBuffer),
      TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, vertex_count, lo, hi);
  const int normal =
      AddAccessor(model, AddView(model, normals.data(), normals.size() * sizeof(float), kArrayBuffer),
                  TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, vertex_count);
  const int tangent =
      AddAccessor(model, AddView(model, tangents.data(), tangents.size() * sizeof(float), kArrayBuffer),
                  TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, vertex_count);
  const int uv = AddAccessor(model, AddView(model, uvs.data(), uvs.size() * sizeof(float), kArrayBuffer),
                             TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, vertex_count);
  const int index =
      AddAccessor(model, AddView(model, indices.data(), indices.size() * sizeof(uint32_t), kElementArrayBuffer),
                  TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, indices.size());

  tinygltf::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
  sampler.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  model.samplers.push_back(sampler);

  tinygltf::Material material;
  material.name = "cards";
  material.alphaMode = "MASK";
  material.alphaCutoff = in.alpha_cutoff;
  material.doubleSided = true;
  material.pbrMetallicRoughness.baseColorTexture.index = AddPngTexture(model, in.albedo_png, "albedo_alpha");
  const int orm = AddPngTexture(model, in.orm_png, "orm");
  material.pbrMetallicRoughness.metallicRoughnessTexture.index = orm;
  material.pbrMetallicRoughness.metallicFactor = 1.0;
  material.pbrMetallicRoughness.roughnessFactor = 1.0;
  material.occlusionTexture.index = orm;
  if (!in.normal_png.empty()) material.normalTexture.index = AddPngTexture(model, in.normal_png, "normal_tangent");
  model.materials.push_back(material);

  tinygltf::Primitive primitive;
  primitive.attributes = {{"POSITION", position}, {"NORMAL", normal}, {"TANGENT", tangent}, {"TEXCOORD_0", uv}};
  primitive.indices = index;
  primitive.material = 0;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  tinygltf::Mesh mesh;
  mesh.name = "cards";
  mesh.primitives.push_back(primitive);
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.name = "cards";
  node.mesh = 0;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;
  std::vector<unsigned char>& data = model.buffers[0].data;
  data.resize((data.size() + 3) & ~size_t{3}, 0);

  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/false, /*writeBinary=*/true)) {
    return absl::InternalError("cards.glb: tinygltf could not serialise the model");
  }
  return out.str();
}

}  // namespace impostor
