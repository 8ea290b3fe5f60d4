#include "worker/scene/gltf_scene_builder.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <map>
#include <memory>
#include <numeric>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "worker/scene/gltf_accessor.h"
#include "worker/scene/gltf_materials.h"
#include "worker/scene/tangent_space.h"

namespace impostor::gltf_internal {
namespace {

// One mesh primitive in mesh space, ready to be instanced by nodes.
struct LocalPrimitive {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
  std::vector<glm::vec4> tangents;
  std::vector<glm::vec2> uvs;     // TEXCOORD_0
  std::vector<glm::vec2> uvs1;    // TEXCOORD_1
  std::vector<glm::vec4> colors;  // COLOR_0, clamped to [0, 1]
  std::vector<uint32_t> indices;  // triangle list
  int material = 0;               // scene material
};

absl::Status Prefixed(const absl::Status& status, const std::string& prefix) {
  return absl::Status(status.code(), absl::StrCat(prefix, ": ", status.message()));
}

bool AllFinite(const std::vector<double>& values) {
  for (double v : values) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

template <typename Vec>
std::vector<Vec> Unflatten(const std::vector<float>& flat) {
  constexpr int kN = Vec::length();
  std::vector<Vec> out(flat.size() / kN);
  for (size_t i = 0; i < out.size(); ++i) {
    for (int c = 0; c < kN; ++c) out[i][c] = flat[i * kN + c];
  }
  return out;
}

// Triangle list from the indices of a TRIANGLES/TRIANGLE_STRIP/TRIANGLE_FAN
// primitive, with the winding the glTF spec defines for each mode.
std::vector<uint32_t> Triangulate(int mode, const std::vector<uint32_t>& v) {
  std::vector<uint32_t> out;
  const size_t n = v.size();
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (n % 3 != 0) spdlog::debug("gltf: {} trailing indices of a triangle list dropped", n % 3);
    out.assign(v.begin(), v.begin() + static_cast<ptrdiff_t>(n - n % 3));
    return out;
  }
  if (n < 3) return out;
  out.reserve((n - 2) * 3);
  for (size_t i = 0; i + 2 < n; ++i) {
    if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      // p_i = {v_i, v_(i + 1 + i%2), v_(i + 2 - i%2)}
      out.insert(out.end(), {v[i], v[i + 1 + i % 2], v[i + 2 - i % 2]});
    } else {  // fan: p_i = {v_(i+1), v_(i+2), v_0}
      out.insert(out.end(), {v[i + 1], v[i + 2], v[0]});
    }
  }
  return out;
}

class Builder {
 public:
  Builder(const tinygltf::Model& model, const GltfLoadLimits& limits, PredecodedImages* predecoded)
      : model_(model),
        limits_(limits),
        materials_(model, limits, &scene_, predecoded),
        max_vertices_(limits.max_triangles * 3) {}

  absl::StatusOr<Scene> Build() {
    if (absl::Status s = CheckHierarchy(); !s.ok()) return s;
    absl::StatusOr<std::vector<int>> roots = Roots();
    if (!roots.ok()) return roots.status();
    visited_.assign(model_.nodes.size(), false);
    for (int root : *roots) {
      if (absl::Status s = Visit(root); !s.ok()) return s;
    }
    if (scene_.indices.empty()) {
      if (!skipped_non_triangles_.empty()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "no triangles in the default scene: only points/lines, which an impostor cannot "
            "bake (",
            skipped_non_triangles_, ")"));
      }
      return absl::InvalidArgumentError("no triangles in the default scene");
    }
    if (!skipped_non_triangles_.empty()) {
      materials_.AddWarning(absl::StrCat("points/lines primitives skipped (",
                                         skipped_non_triangles_,
                                         "): impostors bake triangles only"));
    }
    if (skinned_nodes_ > 0) {
      materials_.AddWarning(absl::StrCat(skinned_nodes_,
                                         " skinned mesh node(s) baked in their bind pose "
                                         "(joints and animations ignored)"));
    }
    return std::move(scene_);
  }

 private:
  std::string NodeName(int node) const {
    return absl::StrCat("node ", node, " '", model_.nodes[node].name, "'");
  }

  // Every child index in range, at most one parent per node, no cycles.
  absl::Status CheckHierarchy() {
    const int n = static_cast<int>(model_.nodes.size());
    parent_.assign(n, -1);
    for (int i = 0; i < n; ++i) {
      for (int c : model_.nodes[i].children) {
        if (c < 0 || c >= n) {
          return absl::InvalidArgumentError(
              absl::StrCat(NodeName(i), " lists child ", c, " which does not exist"));
        }
        if (c == i) {
          return absl::InvalidArgumentError(
              absl::StrCat("node cycle: ", NodeName(i), " is its own child"));
        }
        if (parent_[c] != -1) {
          return absl::InvalidArgumentError(absl::StrCat(
              "node ", c, " has more than one parent (nodes ", parent_[c], " and ", i, ")"));
        }
        parent_[c] = i;
      }
    }
    // With one parent per node, a cycle is a parent chain that returns to
    // itself. Each walk stops at a node already known to reach a root.
    std::vector<int> state(n, 0);  // 0 unknown, 1 reaches a root, k+2 on walk k
    for (int start = 0; start < n; ++start) {
      const int walk = start + 2;
      int v = start;
      while (v != -1 && state[v] == 0) {
        state[v] = walk;
        v = parent_[v];
      }
      if (v != -1 && state[v] == walk) {
        std::string path = absl::StrCat(v);
        for (int u = parent_[v]; u != v; u = parent_[u]) absl::StrAppend(&path, " <- ", u);
        return absl::InvalidArgumentError(
            absl::StrCat("node cycle: nodes ", path, " <- ", v, " are their own ancestors"));
      }
      for (v = start; v != -1 && state[v] == walk; v = parent_[v]) state[v] = 1;
    }
    return absl::OkStatus();
  }

  absl::StatusOr<std::vector<int>> Roots() const {
    const int scenes = static_cast<int>(model_.scenes.size());
    int scene = -1;
    if (model_.defaultScene != -1) {
      if (model_.defaultScene < 0 || model_.defaultScene >= scenes) {
        return absl::InvalidArgumentError(absl::StrCat(
            "default scene ", model_.defaultScene, " does not exist (the file has ", scenes, ")"));
      }
      scene = model_.defaultScene;
    } else if (scenes > 0) {
      scene = 0;
    }
    std::vector<int> roots;
    if (scene < 0) {
      for (int i = 0; i < static_cast<int>(model_.nodes.size()); ++i) {
        if (parent_[i] == -1) roots.push_back(i);
      }
      return roots;
    }
    for (int r : model_.scenes[scene].nodes) {
      if (r < 0 || static_cast<size_t>(r) >= model_.nodes.size()) {
        return absl::InvalidArgumentError(
            absl::StrCat("scene ", scene, " lists node ", r, " which does not exist"));
      }
      if (parent_[r] != -1) {
        return absl::InvalidArgumentError(absl::StrCat("scene ", scene, " lists node ", r,
                                                       ", which is a child of node ", parent_[r],
                                                       "; roots must be roots"));
      }
      roots.push_back(r);
    }
    return roots;
  }

  absl::StatusOr<glm::dmat4> LocalMatrix(int index) const {
    const tinygltf::Node& node = model_.nodes[index];
    const bool finite = AllFinite(node.matrix) && AllFinite(node.translation) &&
                        AllFinite(node.rotation) && AllFinite(node.scale);
    if (!finite) {
      return absl::InvalidArgumentError(
          absl::StrCat(NodeName(index), " has a non-finite transform"));
    }
    if (!node.matrix.empty()) {
      if (node.matrix.size() != 16) {
        return absl::InvalidArgumentError(
            absl::StrCat(NodeName(index), ": matrix has ", node.matrix.size(), " values, not 16"));
      }
      return glm::make_mat4(node.matrix.data());  // glTF and glm are column-major
    }
    glm::dmat4 m(1.0);
    if (!node.translation.empty()) {
      if (node.translation.size() != 3) {
        return absl::InvalidArgumentError(
            absl::StrCat(NodeName(index), ": translation needs 3 values"));
      }
      m = glm::translate(m, glm::make_vec3(node.translation.data()));
    }
    if (!node.rotation.empty()) {
      if (node.rotation.size() != 4) {
        return absl::InvalidArgumentError(
            absl::StrCat(NodeName(index), ": rotation needs 4 values"));
      }
      const auto& r = node.rotation;  // glTF: x, y, z, w; glm::dquat(w, x, y, z)
      glm::dquat q(r[3], r[0], r[1], r[2]);
      const double len = glm::length(q);
      if (!(len > 0.0)) {
        return absl::InvalidArgumentError(
            absl::StrCat(NodeName(index), ": rotation is a zero quaternion"));
      }
      m = m * glm::mat4_cast(q / len);  // tolerate slightly non-unit exports
    }
    if (!node.scale.empty()) {
      if (node.scale.size() != 3) {
        return absl::InvalidArgumentError(absl::StrCat(NodeName(index), ": scale needs 3 values"));
      }
      m = glm::scale(m, glm::make_vec3(node.scale.data()));
    }
    return m;
  }

  // Depth-first over the subtree of `root`, with an explicit stack so that a
  // deep (hostile) hierarchy cannot exhaust the thread's stack.
  absl::Status Visit(int root) {
    struct Item {
      int node;
      glm::dmat4 parent_world;
      int depth;
    };
    std::vector<Item> stack = {{root, glm::dmat4(1.0), 0}};
    while (!stack.empty()) {
      const Item item = stack.back();
      stack.pop_back();
      if (item.depth > limits_.max_node_depth) {
        return absl::InvalidArgumentError(
            absl::StrCat("node hierarchy is deeper than GltfLoadLimits::max_node_depth = ",
                         limits_.max_node_depth, " (at ", NodeName(item.node), ")"));
      }
      if (visited_[item.node]) {
        return absl::InvalidArgumentError(absl::StrCat(
            NodeName(item.node), " is reached twice from the scene (listed twice as a root?)"));
      }
      visited_[item.node] = true;
      absl::StatusOr<glm::dmat4> local = LocalMatrix(item.node);
      if (!local.ok()) return local.status();
      const glm::dmat4 world = item.parent_world * *local;
      const tinygltf::Node& node = model_.nodes[item.node];
      if (node.mesh != -1) {
        if (node.mesh < 0 || static_cast<size_t>(node.mesh) >= model_.meshes.size()) {
          return absl::InvalidArgumentError(
              absl::StrCat(NodeName(item.node), " uses mesh ", node.mesh, " which does not exist"));
        }
        // glTF: a skinned mesh's vertices are placed by its joints, and the
        // transform of the node holding it is ignored; at the bind pose
        // (joint world matrix = inverse bind matrix^-1) the skinned position
        // is the stored position, so the bind pose is the mesh as stored.
        const bool skinned = node.skin >= 0;
        if (skinned) ++skinned_nodes_;
        absl::StatusOr<InstanceSet> instances = Instances(item.node);
        if (!instances.ok()) return instances.status();
        const glm::dmat4 base = skinned ? glm::dmat4(1.0) : world;
        for (size_t i = 0; i < instances->count; ++i) {
          if (absl::Status s = DrawMesh(item.node, node.mesh, instances->Matrix(base, i)); !s.ok()) {
            return s;
          }
        }
      }
      for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) {
        stack.push_back({*it, world, item.depth + 1});
      }
    }
    return absl::OkStatus();
  }

  // A node's EXT_mesh_gpu_instancing attributes, read once; instance i's
  // matrix is made on demand (Matrix), never all at once: 4x4 doubles per
  // instance was 128 bytes each before the triangle limit could refuse a
  // file declaring millions (issue 23; the count itself is bounded first,
  // by CheckLoadBudget's GltfLoadLimits::max_draws).
  struct InstanceSet {
    size_t count = 1;  // 1 and no attributes: the node's world matrix alone
    std::vector<float> t, r, s;

    glm::dmat4 Matrix(const glm::dmat4& world, size_t i) const {
      glm::dmat4 m = world;
      if (!t.empty()) m = glm::translate(m, glm::dvec3(t[3 * i], t[3 * i + 1], t[3 * i + 2]));
      if (!r.empty()) {
        glm::dquat q(r[4 * i + 3], r[4 * i], r[4 * i + 1], r[4 * i + 2]);
        const double len = glm::length(q);
        if (len > 0.0 && std::isfinite(len)) m = m * glm::mat4_cast(q / len);
      }
      if (!s.empty()) m = glm::scale(m, glm::dvec3(s[3 * i], s[3 * i + 1], s[3 * i + 2]));
      return m;
    }
  };

  absl::StatusOr<InstanceSet> Instances(int index) {
    const tinygltf::Node& node = model_.nodes[index];
    auto ext = node.extensions.find("EXT_mesh_gpu_instancing");
    if (ext == node.extensions.end() || !ext->second.IsObject() ||
        !ext->second.Get("attributes").IsObject()) {
      return InstanceSet{};
    }
    const tinygltf::Value& attributes = ext->second.Get("attributes");
    const std::string what = absl::StrCat(NodeName(index), " EXT_mesh_gpu_instancing");
    InstanceSet set;
    bool any = false;
    for (auto [key, type, out] : {std::make_tuple("TRANSLATION", TINYGLTF_TYPE_VEC3, &set.t),
                                  std::make_tuple("ROTATION", TINYGLTF_TYPE_VEC4, &set.r),
                                  std::make_tuple("SCALE", TINYGLTF_TYPE_VEC3, &set.s)}) {
      const tinygltf::Value& accessor = attributes.Get(key);
      if (!accessor.IsNumber()) continue;
      // A double outside int range would make GetNumberAsInt undefined.
      const double number = accessor.GetNumberAsDouble();
      const int accessor_index =
          number >= 0.0 && number <= 2147483647.0 ? static_cast<int>(number) : -1;
      absl::StatusOr<std::vector<float>> values = ReadFloatAccessor(
          model_, accessor_index, type, limits_.max_draws, absl::StrCat(what, " ", key));
      if (!values.ok()) return values.status();
      const size_t n = values->size() / (type == TINYGLTF_TYPE_VEC4 ? 4 : 3);
      if (any && n != set.count) {
        return absl::InvalidArgumentError(
            absl::StrCat(what, ": attribute counts differ (", set.count, " vs ", n, ")"));
      }
      set.count = n;
      any = true;
      *out = std::move(*values);
    }
    return set;
  }

  // OK if accessor `accessor` has `n` elements (POSITION's count);
  // INVALID_ARGUMENT naming both counts otherwise, or a missing accessor.
  absl::Status CheckSameCount(int accessor, size_t n, const std::string& what) const {
    absl::StatusOr<uint64_t> count = AccessorCount(model_, accessor, what);
    if (!count.ok()) return count.status();
    if (*count != n) {
      return absl::InvalidArgumentError(absl::StrCat(what, " (accessor ", accessor, ") has ",
                                                     *count, " elements but POSITION has ", n));
    }
    return absl::OkStatus();
  }

  // Default morph weights of `mesh` drawn by `node`: node.weights, else
  // mesh.weights, else none (all zero).
  const std::vector<double>& MorphWeights(int node, int mesh) const {
    const std::vector<double>& w = model_.nodes[node].weights;
    return w.empty() ? model_.meshes[mesh].weights : w;
  }

  absl::Status DrawMesh(int node, int mesh, const glm::dmat4& world) {
    // Primitives are shared between nodes unless the node has its own
    // morph weights.
    const int weights_key = model_.nodes[node].weights.empty() ? -1 : node;
    for (size_t p = 0; p < model_.meshes[mesh].primitives.size(); ++p) {
      absl::StatusOr<const LocalPrimitive*> prim =
          Primitive(node, weights_key, mesh, static_cast<int>(p));
      if (!prim.ok()) return prim.status();
      if (*prim == nullptr) continue;
      if (absl::Status s = Emit(**prim, world); !s.ok()) return s;
    }
    return absl::OkStatus();
  }

  absl::StatusOr<const LocalPrimitive*> Primitive(int node, int weights_key, int mesh, int prim) {
    const auto key = std::make_tuple(weights_key, mesh, prim);
    if (auto it = cache_.find(key); it != cache_.end()) return it->second.get();
    absl::StatusOr<std::unique_ptr<LocalPrimitive>> read =
        ReadPrimitive(mesh, prim, MorphWeights(node, mesh));
    if (!read.ok()) return read.status();
    return (cache_[key] = std::move(*read)).get();
  }

  // Reads and validates one primitive in mesh space; nullptr when it draws
  // no triangles (points, lines, no POSITION, empty).
  absl::StatusOr<std::unique_ptr<LocalPrimitive>> ReadPrimitive(
      int mesh, int prim_index, const std::vector<double>& morph_weights) {
    const tinygltf::Primitive& prim = model_.meshes[mesh].primitives[prim_index];
    const std::string what =
        absl::StrCat("mesh ", mesh, " '", model_.meshes[mesh].name, "' primitive ", prim_index);
    const int mode = prim.mode == -1 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode >= TINYGLTF_MODE_POINTS && mode <= TINYGLTF_MODE_LINE_STRIP) {
      spdlog::debug("gltf: {}: mode {} (points/lines) skipped", what, mode);
      if (!skipped_non_triangles_.empty()) skipped_non_triangles_ += ", ";
      // glTF's names for modes 0..3.
      static constexpr const char* kModeNames[] = {" POINTS", " LINES", " LINE_LOOP", " LINE_STRIP"};
      absl::StrAppend(&skipped_non_triangles_, what, " mode ", mode, kModeNames[mode - TINYGLTF_MODE_POINTS]);
      return nullptr;
    }
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN) {
      return absl::InvalidArgumentError(absl::StrCat(what, ": mode ", mode, " is invalid"));
    }
    const auto attribute = [&](const char* name) {
      auto it = prim.attributes.find(name);
      return it == prim.attributes.end() ? -1 : it->second;
    };
    const int position_accessor = attribute("POSITION");
    if (position_accessor == -1) {
      spdlog::debug("gltf: {}: no POSITION, skipped", what);
      return nullptr;
    }
    auto out = std::make_unique<LocalPrimitive>();
    absl::StatusOr<std::vector<float>> flat = ReadFloatAccessor(
        model_, position_accessor, TINYGLTF_TYPE_VEC3, max_vertices_, what + " POSITION");
    if (!flat.ok()) return flat.status();
    out->positions = Unflatten<glm::vec3>(*flat);
    const size_t n = out->positions.size();
    for (const glm::vec3& p : out->positions) {
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        return absl::InvalidArgumentError(absl::StrCat(
            what, " POSITION (accessor ", position_accessor, ") has non-finite values"));
      }
    }

    std::vector<glm::vec3> normal_deltas;  // summed weighted NORMAL targets
    if (absl::Status s = ApplyMorphTargets(prim, what, morph_weights, out.get(), &normal_deltas);
        !s.ok()) {
      return s;
    }

    std::vector<uint32_t> indices;
    if (prim.indices != -1) {
      absl::StatusOr<std::vector<uint32_t>> read =
          ReadIndexAccessor(model_, prim.indices, max_vertices_ + 2, what + " indices");
      if (!read.ok()) return read.status();
      indices = std::move(*read);
      for (size_t i = 0; i < indices.size(); ++i) {
        if (indices[i] >= n) {
          return absl::InvalidArgumentError(
              absl::StrCat(what, " indices (accessor ", prim.indices, "): index ", indices[i],
                           " at position ", i, " is out of range (vertex count ", n, ")"));
        }
      }
    } else {
      indices.resize(n);
      std::iota(indices.begin(), indices.end(), 0u);
    }
    out->indices = Triangulate(mode, indices);
    if (out->indices.empty()) return nullptr;
    if (out->indices.size() / 3 > limits_.max_triangles) {
      return absl::ResourceExhaustedError(
          absl::StrCat(what, " has ", out->indices.size() / 3,
                       " triangles, over GltfLoadLimits::max_triangles = ", limits_.max_triangles));
    }

    absl::StatusOr<int> material = materials_.Use(prim.material);
    if (!material.ok()) return Prefixed(material.status(), what);
    out->material = *material;
    const SceneMaterial& scene_material = scene_.materials[*material];

    // Optional attributes must match POSITION's count.
    const auto read_optional = [&](const char* name,
                                   int type) -> absl::StatusOr<std::vector<float>> {
      const int accessor = attribute(name);
      if (accessor == -1) return std::vector<float>();
      // The count is compared before reading: a NORMAL declaring 60,000,000
      // elements next to a 3-vertex POSITION is refused unread (issue 23).
      if (absl::Status s = CheckSameCount(accessor, n, absl::StrCat(what, " ", name)); !s.ok()) {
        return s;
      }
      return ReadFloatAccessor(model_, accessor, type, n, absl::StrCat(what, " ", name));
    };

    absl::StatusOr<std::vector<float>> normals = read_optional("NORMAL", TINYGLTF_TYPE_VEC3);
    if (!normals.ok()) return normals.status();
    std::vector<glm::vec3> smooth;
    if (normals->empty()) {
      out->normals = ComputeSmoothNormals(out->positions, out->indices);
    } else {
      out->normals = Unflatten<glm::vec3>(*normals);
      if (!normal_deltas.empty()) {
        for (size_t i = 0; i < n; ++i) out->normals[i] += normal_deltas[i];
      }
      for (size_t i = 0; i < n; ++i) {
        const float len = glm::length(out->normals[i]);
        if (len > 0.0f && std::isfinite(len)) {
          out->normals[i] /= len;
        } else {  // broken exporter data: fall back to the generated normal
          if (smooth.empty()) smooth = ComputeSmoothNormals(out->positions, out->indices);
          out->normals[i] = smooth[i];
        }
      }
    }

    absl::StatusOr<std::vector<float>> uvs = read_optional("TEXCOORD_0", TINYGLTF_TYPE_VEC2);
    if (!uvs.ok()) return uvs.status();
    out->uvs =
        uvs->empty() ? std::vector<glm::vec2>(n, glm::vec2(0.0f)) : Unflatten<glm::vec2>(*uvs);
    for (glm::vec2& uv : out->uvs) {
      if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) uv = glm::vec2(0.0f);
    }
    absl::StatusOr<std::vector<float>> uvs1 = read_optional("TEXCOORD_1", TINYGLTF_TYPE_VEC2);
    if (!uvs1.ok()) return uvs1.status();
    out->uvs1 =
        uvs1->empty() ? std::vector<glm::vec2>(n, glm::vec2(0.0f)) : Unflatten<glm::vec2>(*uvs1);
    for (glm::vec2& uv : out->uvs1) {
      if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) uv = glm::vec2(0.0f);
    }

    // COLOR_0 is VEC3 or VEC4 (float, normalized ubyte/ushort).
    out->colors.assign(n, glm::vec4(1.0f));
    if (const int color_accessor = attribute("COLOR_0"); color_accessor != -1) {
      const bool vec3 = color_accessor >= 0 &&
                        static_cast<size_t>(color_accessor) < model_.accessors.size() &&
                        model_.accessors[color_accessor].type == TINYGLTF_TYPE_VEC3;
      absl::StatusOr<std::vector<float>> colors =
          read_optional("COLOR_0", vec3 ? TINYGLTF_TYPE_VEC3 : TINYGLTF_TYPE_VEC4);
      if (!colors.ok()) return colors.status();
      const int k = vec3 ? 3 : 4;
      for (size_t i = 0; i < n; ++i) {
        for (int c = 0; c < k; ++c) {
          const float v = (*colors)[i * k + c];
          // Out-of-range values are exporter errors (the glTF validator's
          // ACCESSOR_NON_CLAMPED); clamping keeps them from over-brightening.
          out->colors[i][c] = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 1.0f;
        }
      }
    }

    absl::StatusOr<std::vector<float>> tangents = read_optional("TANGENT", TINYGLTF_TYPE_VEC4);
    if (!tangents.ok()) return tangents.status();
    if (!tangents->empty()) {
      out->tangents = Unflatten<glm::vec4>(*tangents);
      for (size_t i = 0; i < n; ++i) {
        glm::vec3 t(out->tangents[i]);
        const float len = glm::length(t);
        t = (len > 0.0f && std::isfinite(len)) ? t / len : AnyOrthogonal(out->normals[i]);
        out->tangents[i] = glm::vec4(t, out->tangents[i].w < 0.0f ? -1.0f : 1.0f);
      }
    } else if (scene_material.normal_texture >= 0) {
      // Tangents follow the UVs the normal map is sampled with: its set
      // and its KHR_texture_transform.
      const SlotUv& slot = scene_material.uv[kSlotNormal];
      std::vector<glm::vec2> normal_uvs = slot.tex_coord == 1 ? out->uvs1 : out->uvs;
      for (glm::vec2& uv : normal_uvs) uv = glm::vec2(slot.transform * glm::vec3(uv, 1.0f));
      out->tangents = ComputeTangents(out->positions, out->normals, normal_uvs, out->indices);
    } else {  // unused by the renderer without a normal map; keep it valid
      out->tangents.resize(n);
      for (size_t i = 0; i < n; ++i)
        out->tangents[i] = glm::vec4(AnyOrthogonal(out->normals[i]), 1.0f);
    }
    return out;
  }

  // Adds the morph targets' POSITION deltas, weighted by the default
  // weights, to out->positions, and returns the weighted NORMAL deltas in
  // `normal_deltas` (empty when none), to be added to NORMAL before it is
  // normalised.
  absl::Status ApplyMorphTargets(const tinygltf::Primitive& prim, const std::string& what,
                                 const std::vector<double>& weights, LocalPrimitive* out,
                                 std::vector<glm::vec3>* normal_deltas) {
    const size_t n = out->positions.size();
    for (size_t t = 0; t < prim.targets.size() && t < weights.size(); ++t) {
      const float w = static_cast<float>(weights[t]);
      if (w == 0.0f || !std::isfinite(w)) continue;
      for (const char* name : {"POSITION", "NORMAL"}) {
        auto it = prim.targets[t].find(name);
        if (it == prim.targets[t].end()) continue;
        const std::string target_what = absl::StrCat(what, " morph target ", t, " ", name);
        if (absl::Status s = CheckSameCount(it->second, n, target_what); !s.ok()) return s;
        absl::StatusOr<std::vector<float>> deltas =
            ReadFloatAccessor(model_, it->second, TINYGLTF_TYPE_VEC3, n, target_what);
        if (!deltas.ok()) return deltas.status();
        const bool position = name[0] == 'P';
        if (!position && normal_deltas->empty()) normal_deltas->assign(n, glm::vec3(0.0f));
        for (size_t i = 0; i < n; ++i) {
          const glm::vec3 d((*deltas)[3 * i], (*deltas)[3 * i + 1], (*deltas)[3 * i + 2]);
          if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z)) continue;
          if (position) {
            out->positions[i] += w * d;
          } else {
            (*normal_deltas)[i] += w * d;
          }
        }
      }
    }
    return absl::OkStatus();
  }

  // Appends one instance of `prim` transformed by `world`.
  absl::Status Emit(const LocalPrimitive& prim, const glm::dmat4& world) {
    const uint64_t triangles = prim.indices.size() / 3;
    if (triangles_ + triangles > limits_.max_triangles) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "the default scene has more than GltfLoadLimits::max_triangles = ", limits_.max_triangles,
          " triangles (", triangles_ + triangles, " so far)"));
    }
    if (scene_.vertices.size() + prim.positions.size() > max_vertices_) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "the default scene has more than ", max_vertices_,
          " vertices (3 x GltfLoadLimits::max_triangles = ", limits_.max_triangles, ")"));
    }
    triangles_ += triangles;
    const glm::dmat3 m3(world);
    const double det = glm::determinant(m3);
    // Normals transform by the inverse transpose, i.e. the cofactor matrix
    // divided by det; the cofactor matrix times sign(det) has the same
    // direction and stays defined when det == 0 (a flattened axis).
    const double sign = det < 0.0 ? -1.0 : 1.0;
    const glm::mat3 normal_matrix(glm::cross(m3[1], m3[2]) * sign, glm::cross(m3[2], m3[0]) * sign,
                                  glm::cross(m3[0], m3[1]) * sign);
    const glm::mat4 position_matrix(world);
    const glm::mat3 tangent_matrix(m3);
    // A mirroring transform flips handedness: bitangent = cross(n, t) * w
    // must keep pointing along the transformed dP/dv, so w flips too.
    const float w_sign = static_cast<float>(sign);

    const uint32_t base = static_cast<uint32_t>(scene_.vertices.size());
    if (base == 0)
      scene_.bounds_min = scene_.bounds_max =
          glm::vec3(position_matrix * glm::vec4(prim.positions[0], 1.0f));
    for (size_t i = 0; i < prim.positions.size(); ++i) {
      SceneVertex v;
      v.position = glm::vec3(position_matrix * glm::vec4(prim.positions[i], 1.0f));
      if (!std::isfinite(v.position.x) || !std::isfinite(v.position.y) ||
          !std::isfinite(v.position.z)) {
        return absl::InvalidArgumentError(
            "a node transform makes vertex positions overflow to non-finite values");
      }
      const glm::vec3 n = normal_matrix * prim.normals[i];
      const float n_len = glm::length(n);
      v.normal = (n_len > 0.0f && std::isfinite(n_len)) ? n / n_len : glm::vec3(0, 1, 0);
      const glm::vec3 t = tangent_matrix * glm::vec3(prim.tangents[i]);
      const float t_len = glm::length(t);
      v.tangent =
          glm::vec4((t_len > 0.0f && std::isfinite(t_len)) ? t / t_len : AnyOrthogonal(v.normal),
                    prim.tangents[i].w * w_sign);
      v.uv = prim.uvs[i];
      v.uv1 = prim.uvs1[i];
      v.color = prim.colors[i];
      scene_.bounds_min = glm::min(scene_.bounds_min, v.position);
      scene_.bounds_max = glm::max(scene_.bounds_max, v.position);
      scene_.vertices.push_back(v);
    }
    SceneBatch batch;
    batch.first_index = static_cast<uint32_t>(scene_.indices.size());
    batch.index_count = static_cast<uint32_t>(prim.indices.size());
    batch.material = prim.material;
    batch.flipped_winding = det < 0.0;
    for (uint32_t i : prim.indices) scene_.indices.push_back(base + i);
    scene_.batches.push_back(batch);
    return absl::OkStatus();
  }

  const tinygltf::Model& model_;
  const GltfLoadLimits& limits_;
  Scene scene_;
  MaterialTable materials_;
  const uint64_t max_vertices_;
  std::vector<int> parent_;
  std::vector<bool> visited_;
  // (node with its own morph weights or -1, mesh, primitive) -> primitive
  std::map<std::tuple<int, int, int>, std::unique_ptr<LocalPrimitive>> cache_;
  uint64_t triangles_ = 0;
  std::string skipped_non_triangles_;  // "mesh 0 'x' primitive 1 mode 0 POINTS, ..."
  int skinned_nodes_ = 0;
};

}  // namespace

absl::StatusOr<Scene> BuildScene(const tinygltf::Model& model, const GltfLoadLimits& limits,
                                 PredecodedImages* predecoded) {
  return Builder(model, limits, predecoded).Build();
}

}  // namespace impostor::gltf_internal
