#include "worker/lod/lod_glb_writer.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "worker/scene/gltf_accessor.h"

namespace impostor {
namespace {

constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;

// Extensions whose data this writer does not carry over.
bool DroppedExtension(const std::string& name) {
  return name == "KHR_mesh_quantization" || name == "EXT_mesh_gpu_instancing" ||
         name == "KHR_draco_mesh_compression" || name == "EXT_meshopt_compression";
}

std::string ImageExtension(const std::vector<unsigned char>& b) {
  auto starts = [&](const char* magic, size_t n, size_t at = 0) {
    return b.size() >= at + n && std::memcmp(b.data() + at, magic, n) == 0;
  };
  if (starts("\x89PNG", 4)) return "png";
  if (starts("\xFF\xD8\xFF", 3)) return "jpg";
  if (starts("RIFF", 4) && starts("WEBP", 4, 8)) return "webp";
  if (starts("\xABKTX 20", 7)) return "ktx2";
  return "bin";
}

// The images already carry their final URI: nothing to write or embed.
bool KeepImageUri(const std::string*, const std::string*, const tinygltf::Image* image, bool, std::string* out_uri,
                  void*) {
  *out_uri = image->uri;
  return true;
}

// Appends 4-byte aligned buffer views to one binary buffer.
class BinaryBuilder {
 public:
  explicit BinaryBuilder(tinygltf::Model* model) : model_(model) {}

  int AddView(const void* data, size_t bytes, int target) {
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = bin_.size();
    view.byteLength = bytes;
    view.target = target;
    const auto* p = static_cast<const unsigned char*>(data);
    bin_.insert(bin_.end(), p, p + bytes);
    while (bin_.size() % 4 != 0) bin_.push_back(0);
    model_->bufferViews.push_back(view);
    return static_cast<int>(model_->bufferViews.size()) - 1;
  }

  int AddAccessor(int view, int component_type, size_t count, int type) {
    tinygltf::Accessor a;
    a.bufferView = view;
    a.byteOffset = 0;
    a.componentType = component_type;
    a.count = count;
    a.type = type;
    model_->accessors.push_back(a);
    return static_cast<int>(model_->accessors.size()) - 1;
  }

  std::vector<unsigned char> Take() { return std::move(bin_); }

 private:
  tinygltf::Model* model_;
  std::vector<unsigned char> bin_;
};

int Components(int type) {
  switch (type) {
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    default: return 0;
  }
}

}  // namespace

std::vector<std::string> LodTextureFileNames(const tinygltf::Model& model) {
  std::vector<std::string> names;
  for (size_t i = 0; i < model.images.size(); ++i) {
    names.push_back(absl::StrCat("texture_", i, ".", ImageExtension(model.images[i].image)));
  }
  return names;
}

absl::StatusOr<std::string> EncodeLodGlb(const LodSource& source, const std::vector<std::vector<uint32_t>>& indices,
                                         const std::vector<std::string>& texture_files) {
  const tinygltf::Model& in = source.model;
  tinygltf::Model out;
  out.asset = in.asset;
  out.asset.generator = "impostor-baker lod-chain";
  out.materials = in.materials;
  out.textures = in.textures;
  out.samplers = in.samplers;
  out.cameras = in.cameras;
  out.lights = in.lights;
  out.scenes = in.scenes;
  out.defaultScene = in.defaultScene;
  out.nodes = in.nodes;
  out.extensions = in.extensions;
  out.extras = in.extras;
  for (const std::string& e : in.extensionsUsed) {
    if (!DroppedExtension(e)) out.extensionsUsed.push_back(e);
  }
  for (const std::string& e : in.extensionsRequired) {
    if (!DroppedExtension(e)) out.extensionsRequired.push_back(e);
  }
  for (size_t i = 0; i < in.images.size(); ++i) {
    tinygltf::Image image;
    image.name = in.images[i].name;
    image.uri = texture_files.at(i);
    image.extras = in.images[i].extras;
    out.images.push_back(std::move(image));
  }

  BinaryBuilder bin(&out);
  std::vector<int> new_mesh(in.meshes.size(), -1);
  for (size_t k = 0; k < source.primitives.size(); ++k) {
    const LodPrimitive& lp = source.primitives[k];
    // A primitive simplified away is left out (glTF accessors need count >= 1).
    if (indices.at(k).empty()) continue;
    if (new_mesh[lp.mesh] < 0) {
      tinygltf::Mesh mesh;
      mesh.name = in.meshes[lp.mesh].name;
      mesh.extras = in.meshes[lp.mesh].extras;
      mesh.extensions = in.meshes[lp.mesh].extensions;
      out.meshes.push_back(std::move(mesh));
      new_mesh[lp.mesh] = static_cast<int>(out.meshes.size()) - 1;
    }
    const tinygltf::Primitive& src = in.meshes[lp.mesh].primitives[lp.primitive];
    const size_t vertex_count = lp.positions.size() / 3;
    const std::vector<uint32_t>& level = indices.at(k);
    std::vector<uint32_t> remap(vertex_count);
    const size_t unique = meshopt_optimizeVertexFetchRemap(remap.data(), level.data(), level.size(), vertex_count);
    std::vector<uint32_t> new_indices(level.size());
    meshopt_remapIndexBuffer(new_indices.data(), level.data(), level.size(), remap.data());

    tinygltf::Primitive prim;
    prim.material = src.material;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.extras = src.extras;
    for (const auto& [name, ext] : src.extensions) {
      if (!DroppedExtension(name)) prim.extensions[name] = ext;
    }
    for (const auto& [name, accessor] : src.attributes) {
      if (name.rfind("JOINTS_", 0) == 0 || name.rfind("WEIGHTS_", 0) == 0) continue;
      if (accessor < 0 || accessor >= static_cast<int>(in.accessors.size())) continue;
      const int type = in.accessors[accessor].type;
      const int comps = Components(type);
      if (comps == 0) continue;
      // An attribute whose count differs from POSITION's is dropped unread:
      // reading first with no bound let a count-only accessor (no
      // bufferView) allocate count x 16 bytes (issue 23).
      if (in.accessors[accessor].count != vertex_count) continue;
      auto values = gltf_internal::ReadFloatAccessor(in, accessor, type, vertex_count,
                                                     absl::StrCat("mesh ", lp.mesh, " primitive ", lp.primitive, " ", name));
      if (!values.ok()) return values.status();
      std::vector<float> packed(unique * comps);
      meshopt_remapVertexBuffer(packed.data(), values->data(), vertex_count, sizeof(float) * comps, remap.data());
      const int view = bin.AddView(packed.data(), packed.size() * sizeof(float), kArrayBuffer);
      const int acc = bin.AddAccessor(view, TINYGLTF_COMPONENT_TYPE_FLOAT, unique, type);
      if (name == "POSITION") {
        std::vector<double> lo(3, std::numeric_limits<double>::max()), hi(3, std::numeric_limits<double>::lowest());
        for (size_t v = 0; v < unique; ++v) {
          for (int c = 0; c < 3; ++c) {
            lo[c] = std::min<double>(lo[c], packed[v * 3 + c]);
            hi[c] = std::max<double>(hi[c], packed[v * 3 + c]);
          }
        }
        out.accessors[acc].minValues = lo;
        out.accessors[acc].maxValues = hi;
      }
      prim.attributes[name] = acc;
    }
    if (unique <= 0xFFFF) {
      std::vector<uint16_t> small(new_indices.begin(), new_indices.end());
      const int view = bin.AddView(small.data(), small.size() * sizeof(uint16_t), kElementArrayBuffer);
      prim.indices = bin.AddAccessor(view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, small.size(), TINYGLTF_TYPE_SCALAR);
    } else {
      const int view = bin.AddView(new_indices.data(), new_indices.size() * sizeof(uint32_t), kElementArrayBuffer);
      prim.indices =
          bin.AddAccessor(view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, new_indices.size(), TINYGLTF_TYPE_SCALAR);
    }
    out.meshes[new_mesh[lp.mesh]].primitives.push_back(std::move(prim));
  }
  for (tinygltf::Node& node : out.nodes) {
    node.skin = -1;
    node.weights.clear();
    node.extensions.erase("EXT_mesh_gpu_instancing");
    if (node.mesh >= 0) node.mesh = node.mesh < static_cast<int>(new_mesh.size()) ? new_mesh[node.mesh] : -1;
  }
  tinygltf::Buffer buffer;
  buffer.data = bin.Take();
  if (!buffer.data.empty()) out.buffers.push_back(std::move(buffer));

  tinygltf::TinyGLTF gltf;
  gltf.SetImageWriter(&KeepImageUri, nullptr);
  std::ostringstream glb;
  if (!gltf.WriteGltfSceneToStream(&out, glb, /*prettyPrint=*/false, /*writeBinary=*/true)) {
    return absl::InternalError("tinygltf could not serialise the LOD level");
  }
  return glb.str();
}

}  // namespace impostor
