#include "worker/lod/lod_source.h"

#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <unordered_map>

#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat4x4.hpp>

#include "absl/strings/str_cat.h"
#include "worker/scene/gltf_accessor.h"
#include "worker/scene/gltf_sandbox.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

// Keeps the encoded bytes: levels reference the input's image files as they
// are, nothing is decoded or re-encoded.
bool KeepEncodedBytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void*) {
  if (size > 0) image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

glm::mat4 LocalMatrix(const tinygltf::Node& node) {
  if (node.matrix.size() == 16) {
    glm::dmat4 m = glm::make_mat4(node.matrix.data());
    return glm::mat4(m);
  }
  glm::dmat4 m(1.0);
  if (node.translation.size() == 3) m = glm::translate(m, glm::make_vec3(node.translation.data()));
  if (node.rotation.size() == 4) {
    const auto& r = node.rotation;
    m *= glm::mat4_cast(glm::normalize(glm::dquat(r[3], r[0], r[1], r[2])));
  }
  if (node.scale.size() == 3) m = glm::scale(m, glm::make_vec3(node.scale.data()));
  return glm::mat4(m);
}

float LargestScale(const glm::mat4& m) {
  return std::max({glm::length(glm::vec3(m[0])), glm::length(glm::vec3(m[1])), glm::length(glm::vec3(m[2]))});
}

}  // namespace

uint64_t LodSource::DrawnTriangles(const std::vector<size_t>& index_counts) const {
  uint64_t total = 0;
  for (size_t i = 0; i < primitives.size() && i < index_counts.size(); ++i) {
    total += uint64_t{index_counts[i] / 3} * mesh_instances[primitives[i].mesh];
  }
  return total;
}

absl::StatusOr<LodSource> LoadLodSource(const fs::path& entry_file, const GltfLoadLimits& limits) {
  std::error_code ec;
  const fs::path path = fs::absolute(entry_file, ec);
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  in.read(magic, 4);
  const bool is_glb = in.gcount() == 4 && std::memcmp(magic, "glTF", 4) == 0;
  in.close();

  LodSource source;
  const gltf_internal::Sandbox sandbox(path.parent_path());
  tinygltf::TinyGLTF gltf;
  gltf.SetFsCallbacks(sandbox.FsCallbacks());
  gltf.SetImageLoader(&KeepEncodedBytes, nullptr);
  std::string err, warn;
  const bool ok = is_glb ? gltf.LoadBinaryFromFile(&source.model, &err, &warn, path.string())
                         : gltf.LoadASCIIFromFile(&source.model, &err, &warn, path.string());
  if (!ok) return absl::InvalidArgumentError(absl::StrCat("cannot parse '", path.filename().string(), "': ", err));
  tinygltf::Model& model = source.model;

  // Instances and scales from the default scene (as the loader picks it).
  const size_t mesh_count = model.meshes.size();
  source.mesh_instances.assign(mesh_count, 0);
  source.mesh_scale.assign(mesh_count, 0.0f);
  std::vector<glm::mat4> first_world(mesh_count, glm::mat4(1.0f));
  std::vector<int> roots;
  const int scene = model.defaultScene >= 0 ? model.defaultScene : (model.scenes.empty() ? -1 : 0);
  if (scene >= 0 && scene < static_cast<int>(model.scenes.size())) {
    roots = model.scenes[scene].nodes;
  } else {
    std::vector<bool> child(model.nodes.size(), false);
    for (const auto& n : model.nodes) {
      for (int c : n.children) {
        if (c >= 0 && c < static_cast<int>(child.size())) child[c] = true;
      }
    }
    for (size_t i = 0; i < child.size(); ++i) {
      if (!child[i]) roots.push_back(static_cast<int>(i));
    }
  }
  // LoadGltfScene already refused cycles and deep hierarchies; the depth
  // bound only keeps this walk finite should it ever be called alone.
  std::function<void(int, const glm::mat4&, int)> visit = [&](int index, const glm::mat4& parent, int depth) {
    if (index < 0 || index >= static_cast<int>(model.nodes.size()) || depth > limits.max_node_depth) return;
    const tinygltf::Node& node = model.nodes[index];
    const glm::mat4 world = parent * LocalMatrix(node);
    if (node.mesh >= 0 && node.mesh < static_cast<int>(mesh_count)) {
      if (source.mesh_instances[node.mesh]++ == 0) first_world[node.mesh] = world;
      source.mesh_scale[node.mesh] = std::max(source.mesh_scale[node.mesh], LargestScale(world));
    }
    for (int c : node.children) visit(c, world, depth + 1);
  };
  for (int r : roots) visit(r, glm::mat4(1.0f), 0);

  const uint64_t max_count = limits.max_triangles * 3;
  for (size_t m = 0; m < mesh_count; ++m) {
    if (source.mesh_instances[m] == 0) continue;
    const tinygltf::Mesh& mesh = model.meshes[m];
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
      const tinygltf::Primitive& prim = mesh.primitives[p];
      const std::string what = absl::StrCat("mesh ", m, " '", mesh.name, "' primitive ", p);
      if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) {
        source.warnings.push_back(absl::StrCat(what, ": mode ", prim.mode, " is not TRIANGLES; dropped from the LOD levels"));
        continue;
      }
      auto pos = prim.attributes.find("POSITION");
      if (pos == prim.attributes.end()) {
        source.warnings.push_back(absl::StrCat(what, ": no POSITION; dropped from the LOD levels"));
        continue;
      }
      LodPrimitive out;
      out.mesh = static_cast<int>(m);
      out.primitive = static_cast<int>(p);
      auto positions =
          gltf_internal::ReadFloatAccessor(model, pos->second, TINYGLTF_TYPE_VEC3, max_count, what + " POSITION");
      if (!positions.ok()) return positions.status();
      out.positions = std::move(*positions);
      const size_t vertices = out.positions.size() / 3;
      if (prim.indices >= 0) {
        auto indices = gltf_internal::ReadIndexAccessor(model, prim.indices, max_count, what + " indices");
        if (!indices.ok()) return indices.status();
        out.indices = std::move(*indices);
      } else {
        out.indices.resize(vertices);
        for (size_t i = 0; i < vertices; ++i) out.indices[i] = static_cast<uint32_t>(i);
      }
      out.indices.resize(out.indices.size() / 3 * 3);
      for (uint32_t i : out.indices) {
        if (i >= vertices) {
          return absl::InvalidArgumentError(
              absl::StrCat(what, ": index ", i, " is out of range for ", vertices, " vertices"));
        }
      }
      if (out.indices.empty()) {
        source.warnings.push_back(absl::StrCat(what, ": no triangles; dropped from the LOD levels"));
        continue;
      }
      source.primitives.push_back(std::move(out));
    }
  }
  source.mesh_world = std::move(first_world);
  if (source.primitives.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", path.filename().string(), "': the default scene draws no triangle primitives"));
  }
  if (!model.skins.empty() || !model.animations.empty()) {
    source.warnings.push_back("skins and animations are not carried into the LOD levels (static, bind pose)");
  }
  return source;
}

}  // namespace impostor
