#include "worker/scene/load_budget.h"

#include <algorithm>
#include <limits>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "worker/scene/scene.h"
#include "worker/scene/texture_decode.h"

namespace impostor::gltf_internal {
namespace {

constexpr uint64_t kMax = std::numeric_limits<uint64_t>::max();

// Saturating arithmetic: declared counts are whatever the file says.
uint64_t Mul(uint64_t a, uint64_t b) { return a != 0 && b > kMax / a ? kMax : a * b; }
uint64_t Add(uint64_t a, uint64_t b) { return a > kMax - b ? kMax : a + b; }

// Bytes the builder holds per distinct primitive vertex (LocalPrimitive:
// position, normal, tangent, two UV sets, colour) and per drawn vertex.
constexpr uint64_t kLocalVertexBytes = 12 + 12 + 16 + 8 + 8 + 16;
constexpr uint64_t kSceneVertexBytes = sizeof(SceneVertex);
// Per instance, the TRANSLATION/ROTATION/SCALE floats read at once.
constexpr uint64_t kInstanceBytes = (3 + 4 + 3) * sizeof(float);

std::optional<uint64_t> Count(const tinygltf::Model& model, int accessor) {
  if (accessor < 0 || static_cast<size_t>(accessor) >= model.accessors.size()) return std::nullopt;
  return static_cast<uint64_t>(model.accessors[accessor].count);
}

bool IsTriangles(int mode) {
  return mode == -1 || mode == TINYGLTF_MODE_TRIANGLES || mode == TINYGLTF_MODE_TRIANGLE_STRIP ||
         mode == TINYGLTF_MODE_TRIANGLE_FAN;
}

uint64_t Triangles(int mode, uint64_t corners) {
  if (mode == TINYGLTF_MODE_TRIANGLE_STRIP || mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    return corners < 3 ? 0 : corners - 2;
  }
  return corners / 3;
}

std::string NodeName(const tinygltf::Model& model, int node) {
  return absl::StrCat("node ", node, " '", model.nodes[node].name, "'");
}

// The walk, with the limits checked as each total grows, so a refusal names
// the node or primitive that crossed the line. `limits` null: no checks.
class CostWalk {
 public:
  CostWalk(const tinygltf::Model& model, const GltfLoadLimits* limits)
      : model_(model), limits_(limits) {}

  absl::Status Run() {
    std::vector<bool> visited(model_.nodes.size(), false);
    std::vector<int> stack = Roots();
    while (!stack.empty()) {
      const int node = stack.back();
      stack.pop_back();
      if (node < 0 || static_cast<size_t>(node) >= model_.nodes.size() || visited[node]) continue;
      visited[node] = true;
      if (absl::Status s = Node(node); !s.ok()) return s;
      for (int child : model_.nodes[node].children) stack.push_back(child);
    }
    if (absl::Status s = Textures(); !s.ok()) return s;
    return Total();
  }

  const LoadCost& cost() const { return cost_; }

 private:
  // As gltf_scene_builder.cc picks them.
  std::vector<int> Roots() const {
    const int scenes = static_cast<int>(model_.scenes.size());
    int scene = model_.defaultScene;
    if (scene < 0 || scene >= scenes) scene = scenes > 0 ? 0 : -1;
    if (scene >= 0) return model_.scenes[scene].nodes;
    std::vector<bool> child(model_.nodes.size(), false);
    for (const tinygltf::Node& n : model_.nodes) {
      for (int c : n.children) {
        if (c >= 0 && static_cast<size_t>(c) < child.size()) child[c] = true;
      }
    }
    std::vector<int> roots;
    for (size_t i = 0; i < child.size(); ++i) {
      if (!child[i]) roots.push_back(static_cast<int>(i));
    }
    return roots;
  }

  // EXT_mesh_gpu_instancing's instance count: the largest of its attribute
  // accessors' counts (the builder refuses counts that differ), 1 without.
  uint64_t Instances(const tinygltf::Node& node) const {
    auto ext = node.extensions.find("EXT_mesh_gpu_instancing");
    if (ext == node.extensions.end() || !ext->second.IsObject()) return 1;
    const tinygltf::Value& attributes = ext->second.Get("attributes");
    if (!attributes.IsObject()) return 1;
    uint64_t instances = 0;
    bool any = false;
    for (const char* key : {"TRANSLATION", "ROTATION", "SCALE"}) {
      const tinygltf::Value& v = attributes.Get(key);
      if (!v.IsNumber()) continue;
      const double number = v.GetNumberAsDouble();
      if (!(number >= 0.0 && number <= 2147483647.0)) continue;
      if (std::optional<uint64_t> n = Count(model_, static_cast<int>(number))) {
        instances = std::max(instances, *n);
        any = true;
      }
    }
    return any ? instances : 1;
  }

  absl::Status Exhausted(const std::string& what, uint64_t total, const char* limit_name,
                         uint64_t limit) const {
    return absl::ResourceExhaustedError(absl::StrCat(what, "; the default scene reaches ", total,
                                                     ", over GltfLoadLimits::", limit_name, " = ",
                                                     limit));
  }

  absl::Status Node(int index) {
    const tinygltf::Node& node = model_.nodes[index];
    if (node.mesh < 0 || static_cast<size_t>(node.mesh) >= model_.meshes.size()) return absl::OkStatus();
    const tinygltf::Mesh& mesh = model_.meshes[node.mesh];
    const uint64_t instances = Instances(node);
    cost_.largest_instancing = std::max(cost_.largest_instancing, instances);
    const uint64_t draws = Mul(instances, mesh.primitives.size());
    cost_.draws = Add(cost_.draws, draws);
    if (limits_ && cost_.draws > limits_->max_draws) {
      return Exhausted(absl::StrCat(NodeName(model_, index), " draws mesh ", node.mesh, " '",
                                    mesh.name, "': ", instances, " instances x ",
                                    mesh.primitives.size(), " primitives = ", draws, " draws"),
                       cost_.draws, "max_draws", limits_->max_draws);
    }
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
      if (absl::Status s = Primitive(index, node.mesh, static_cast<int>(p), instances); !s.ok()) {
        return s;
      }
    }
    return absl::OkStatus();
  }

  absl::Status Primitive(int node, int mesh, int p, uint64_t instances) {
    const tinygltf::Primitive& prim = model_.meshes[mesh].primitives[p];
    if (!IsTriangles(prim.mode)) return absl::OkStatus();  // skipped unread by the builder
    auto position = prim.attributes.find("POSITION");
    if (position == prim.attributes.end()) return absl::OkStatus();
    const std::optional<uint64_t> vertices = Count(model_, position->second);
    if (!vertices) return absl::OkStatus();
    const std::optional<uint64_t> corners =
        prim.indices >= 0 ? Count(model_, prim.indices) : vertices;
    const uint64_t triangles = Triangles(prim.mode, corners.value_or(0));
    const std::string what =
        absl::StrCat(NodeName(model_, node), " mesh ", mesh, " '", model_.meshes[mesh].name,
                     "' primitive ", p);
    const uint64_t max_vertices = limits_ ? limits_->max_triangles * 3 : kMax;

    cost_.drawn_triangles = Add(cost_.drawn_triangles, Mul(instances, triangles));
    if (limits_ && cost_.drawn_triangles > limits_->max_triangles) {
      return Exhausted(absl::StrCat(what, ": ", instances, " instances x ", triangles,
                                    " triangles = ", Mul(instances, triangles), " triangles"),
                       cost_.drawn_triangles, "max_triangles", limits_->max_triangles);
    }
    cost_.drawn_vertices = Add(cost_.drawn_vertices, Mul(instances, *vertices));
    if (limits_ && cost_.drawn_vertices > max_vertices) {
      return Exhausted(absl::StrCat(what, ": ", instances, " instances x ", *vertices,
                                    " vertices = ", Mul(instances, *vertices), " vertices"),
                       cost_.drawn_vertices, "max_triangles x 3 (vertices)", max_vertices);
    }
    // The builder reads each primitive once, however often it is drawn
    // (except per node morph weights, which the morph bound below covers).
    if (!primitives_.insert({mesh, p}).second) return absl::OkStatus();
    distinct_vertices_ = Add(distinct_vertices_, *vertices);
    distinct_indices_ = Add(distinct_indices_, Add(corners.value_or(0), Mul(triangles, 3)));
    for (const auto& [name, accessor] : prim.attributes) {
      cost_.attribute_elements = Add(cost_.attribute_elements, Count(model_, accessor).value_or(0));
    }
    const uint64_t morph = Mul(prim.targets.size(), *vertices);
    cost_.morph_elements = Add(cost_.morph_elements, morph);
    if (limits_ && cost_.morph_elements > max_vertices) {
      return Exhausted(absl::StrCat(what, ": ", prim.targets.size(), " morph targets x ",
                                    *vertices, " vertices = ", morph, " morph target elements"),
                       cost_.morph_elements, "max_triangles x 3 (vertices)", max_vertices);
    }
    if (prim.material >= 0 && static_cast<size_t>(prim.material) < model_.materials.size()) {
      materials_.insert(prim.material);
    }
    return absl::OkStatus();
  }

  // Images of the core texture slots of the materials drawn, each once.
  absl::Status Textures() {
    std::set<int> images;
    auto use = [&](int texture) {
      if (texture < 0 || static_cast<size_t>(texture) >= model_.textures.size()) return;
      const int source = model_.textures[texture].source;
      if (source >= 0 && static_cast<size_t>(source) < model_.images.size()) images.insert(source);
    };
    for (int m : materials_) {
      const tinygltf::Material& material = model_.materials[m];
      use(material.pbrMetallicRoughness.baseColorTexture.index);
      use(material.pbrMetallicRoughness.metallicRoughnessTexture.index);
      use(material.normalTexture.index);
      use(material.occlusionTexture.index);
      use(material.emissiveTexture.index);
    }
    for (int i : images) {
      const tinygltf::Image& image = model_.images[i];
      if (image.image.empty()) continue;
      absl::StatusOr<ImageHeader> header = ImageHeader{};
      if (image.as_is) {
        // Formats the decoder refuses are dropped or refused there, unread.
        header = ProbeImage(image.image, "");
        if (!header.ok()) continue;
      } else {  // already decoded by tinygltf's own loader (not the worker's)
        header->width = image.width;
        header->height = image.height;
        header->channels = image.component;
      }
      if (header->width <= 0 || header->height <= 0) continue;
      const uint64_t decoded = Mul(Mul(header->width, header->height), 4);
      cost_.texture_bytes = Add(cost_.texture_bytes, decoded);
      cost_.texture_peak_bytes = std::max(cost_.texture_peak_bytes, PeakDecodeBytes(*header));
      cost_.texture_peak_sum_bytes = Add(cost_.texture_peak_sum_bytes, PeakDecodeBytes(*header));
      if (image.as_is) cost_.decodable_images.push_back(i);
      if (limits_ && cost_.texture_bytes > limits_->max_texture_bytes) {
        return Exhausted(absl::StrCat("image[", i, "] '", model_.images[i].name, "' is ",
                                      header->width, "x", header->height, " = ", decoded,
                                      " bytes decoded (RGBA8)"),
                         cost_.texture_bytes, "max_texture_bytes", limits_->max_texture_bytes);
      }
    }
    return absl::OkStatus();
  }

  absl::Status Total() {
    uint64_t total = 0;
    for (const tinygltf::Buffer& b : model_.buffers) total = Add(total, b.data.size());
    for (const tinygltf::Image& i : model_.images) total = Add(total, i.image.size());
    total = Add(total, Mul(cost_.drawn_vertices, kSceneVertexBytes));
    total = Add(total, Mul(cost_.drawn_triangles, 3 * sizeof(uint32_t)));
    total = Add(total, Mul(cost_.draws, sizeof(SceneBatch)));
    total = Add(total, Mul(distinct_vertices_, kLocalVertexBytes));
    total = Add(total, Mul(distinct_indices_, sizeof(uint32_t)));
    total = Add(total, Mul(cost_.largest_instancing, kInstanceBytes));
    total = Add(total, cost_.texture_bytes);
    total = Add(total, cost_.texture_peak_bytes);
    cost_.total_bytes = total;
    if (limits_ && total > limits_->max_load_bytes) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "loading needs an estimated ", total, " bytes (", cost_.drawn_vertices,
          " drawn vertices x ", kSceneVertexBytes, " + ", distinct_vertices_,
          " distinct vertices x ", kLocalVertexBytes, " + indices, buffers and ",
          cost_.texture_bytes, " bytes of textures), over GltfLoadLimits::max_load_bytes = ",
          limits_->max_load_bytes));
    }
    return absl::OkStatus();
  }

  const tinygltf::Model& model_;
  const GltfLoadLimits* limits_;
  LoadCost cost_;
  std::set<std::pair<int, int>> primitives_;  // (mesh, primitive) read once
  std::set<int> materials_;
  uint64_t distinct_vertices_ = 0;
  uint64_t distinct_indices_ = 0;  // read plus triangulated
};

}  // namespace

LoadCost ComputeLoadCost(const tinygltf::Model& model) {
  CostWalk walk(model, nullptr);
  (void)walk.Run();
  return walk.cost();
}

absl::StatusOr<LoadCost> CheckLoadBudget(const tinygltf::Model& model, const GltfLoadLimits& limits) {
  CostWalk walk(model, &limits);
  if (absl::Status s = walk.Run(); !s.ok()) return s;
  return walk.cost();
}

}  // namespace impostor::gltf_internal
