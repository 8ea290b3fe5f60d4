#include "tests/support/procedural_tree.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include <tiny_gltf.h>

#include "absl/strings/str_cat.h"

namespace impostor::testing {
namespace {

constexpr float kPi = 3.14159265358979f;
constexpr int kSides = 6;  // of every branch's cross-section

struct Vec3 {
  float x = 0, y = 0, z = 0;
};
Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
float Dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 Cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Vec3 Normalize(Vec3 a) { return a * (1.0f / std::sqrt(Dot(a, a))); }

// Two unit vectors perpendicular to unit `d` and to each other.
void Basis(Vec3 d, Vec3* u, Vec3* v) {
  const Vec3 helper = std::fabs(d.y) < 0.9f ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  *u = Normalize(Cross(helper, d));
  *v = Cross(d, *u);
}

// splitmix64: the same sequence everywhere.
class Random {
 public:
  explicit Random(uint64_t seed) : state_(seed) {}
  // Uniform in [lo, hi).
  float Between(float lo, float hi) {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return lo + (hi - lo) * static_cast<float>(z >> 40) / static_cast<float>(1ull << 24);
  }

 private:
  uint64_t state_;
};

struct Primitive {
  std::vector<Vec3> positions, normals;
  std::vector<uint32_t> indices;
};

// A tapered open cylinder from `base` along unit `dir`.
void AddBranch(Vec3 base, Vec3 dir, float length, float r0, float r1, Primitive* bark) {
  Vec3 u, v;
  Basis(dir, &u, &v);
  const uint32_t first = static_cast<uint32_t>(bark->positions.size());
  for (int i = 0; i < kSides; ++i) {
    const float a = 2 * kPi * static_cast<float>(i) / kSides;
    const Vec3 radial = u * std::cos(a) + v * std::sin(a);
    bark->positions.push_back(base + radial * r0);
    bark->positions.push_back(base + dir * length + radial * r1);
    bark->normals.push_back(radial);
    bark->normals.push_back(radial);
  }
  for (uint32_t i = 0; i < kSides; ++i) {
    const uint32_t a0 = first + 2 * i, a1 = a0 + 1;
    const uint32_t b0 = first + 2 * ((i + 1) % kSides), b1 = b0 + 1;
    bark->indices.insert(bark->indices.end(), {a0, b0, b1, a0, b1, a1});
  }
}

// A leaf: a quad from `at`, leaning away from the twig's direction.
void AddLeaf(Vec3 at, Vec3 twig, Random& random, Primitive* leaves) {
  Vec3 u, v;
  Basis(twig, &u, &v);
  const float azimuth = random.Between(0, 2 * kPi);
  const float lean = random.Between(0.7f, 1.2f);  // radians from the twig
  const Vec3 out = u * std::cos(azimuth) + v * std::sin(azimuth);
  const Vec3 axis = Normalize(twig * std::cos(lean) + out * std::sin(lean));
  Vec3 side, unused;
  Basis(axis, &side, &unused);
  const float length = random.Between(0.03f, 0.045f), width = length * 0.45f;
  const Vec3 normal = Normalize(Cross(axis, side));
  const uint32_t first = static_cast<uint32_t>(leaves->positions.size());
  for (const Vec3 p : {at - side * (width / 2), at + side * (width / 2), at + axis * length + side * (width / 2),
                       at + axis * length - side * (width / 2)}) {
    leaves->positions.push_back(p);
    leaves->normals.push_back(normal);
  }
  leaves->indices.insert(leaves->indices.end(), {first, first + 1, first + 2, first, first + 2, first + 3});
}

struct Grower {
  const ProceduralTreeOptions& options;
  Random random;
  Primitive bark, leaves;
  float thinnest = 1;

  // One branch of `level` (0 = the trunk) and everything it carries.
  void Grow(Vec3 base, Vec3 dir, float length, float r0, int level) {
    const float r1 = r0 * 0.6f;
    AddBranch(base, dir, length, r0, r1, &bark);
    if (level == options.branch_levels) {
      thinnest = std::min(thinnest, r1);
      for (int i = 0; i < options.leaves_per_twig; ++i) {
        AddLeaf(base + dir * (length * random.Between(0.3f, 1.0f)), dir, random, &leaves);
      }
      return;
    }
    Vec3 u, v;
    Basis(dir, &u, &v);
    for (int i = 0; i < options.children; ++i) {
      // Child 0 is the leader, carrying on near the tip; the others spread
      // along the upper half at a golden-angle turn from each other.
      const bool leader = i == 0;
      const float t = leader ? 1.0f : random.Between(0.45f, 0.95f);
      const float tilt = leader ? random.Between(0.08f, 0.25f) : random.Between(0.55f, 0.95f);
      const float azimuth = 2.39996f * static_cast<float>(i) + random.Between(0, 0.6f);
      const Vec3 out = u * std::cos(azimuth) + v * std::sin(azimuth);
      const Vec3 child = Normalize(dir * std::cos(tilt) + out * std::sin(tilt) + Vec3{0, 0.15f, 0});
      const float child_r0 = r0 * 0.5f;  // each level halves the radius
      Grow(base + dir * (length * t), child, length * random.Between(0.55f, 0.7f), child_r0, level + 1);
    }
  }
};

// Appends `bytes` to the buffer and returns the view's index.
int AddView(tinygltf::Model* model, const void* bytes, size_t size, int target) {
  tinygltf::Buffer& buffer = model->buffers[0];
  const size_t offset = buffer.data.size();
  buffer.data.resize(offset + size);
  std::memcpy(buffer.data.data() + offset, bytes, size);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = offset;
  view.byteLength = size;
  view.target = target;
  model->bufferViews.push_back(view);
  return static_cast<int>(model->bufferViews.size()) - 1;
}

int AddVec3Accessor(tinygltf::Model* model, const std::vector<Vec3>& values, bool with_bounds) {
  tinygltf::Accessor a;
  a.bufferView = AddView(model, values.data(), values.size() * sizeof(Vec3), TINYGLTF_TARGET_ARRAY_BUFFER);
  a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  a.type = TINYGLTF_TYPE_VEC3;
  a.count = values.size();
  if (with_bounds) {
    a.minValues = {1e30, 1e30, 1e30};
    a.maxValues = {-1e30, -1e30, -1e30};
    for (const Vec3& p : values) {
      const std::array<float, 3> c{p.x, p.y, p.z};
      for (int k = 0; k < 3; ++k) {
        a.minValues[k] = std::min<double>(a.minValues[k], c[k]);
        a.maxValues[k] = std::max<double>(a.maxValues[k], c[k]);
      }
    }
  }
  model->accessors.push_back(a);
  return static_cast<int>(model->accessors.size()) - 1;
}

int AddIndexAccessor(tinygltf::Model* model, const std::vector<uint32_t>& indices) {
  tinygltf::Accessor a;
  a.bufferView =
      AddView(model, indices.data(), indices.size() * sizeof(uint32_t), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  a.type = TINYGLTF_TYPE_SCALAR;
  a.count = indices.size();
  model->accessors.push_back(a);
  return static_cast<int>(model->accessors.size()) - 1;
}

tinygltf::Material Material(const char* name, std::vector<double> colour, bool double_sided) {
  tinygltf::Material m;
  m.name = name;
  m.pbrMetallicRoughness.baseColorFactor = std::move(colour);
  m.pbrMetallicRoughness.metallicFactor = 0;
  m.pbrMetallicRoughness.roughnessFactor = 0.9;
  m.doubleSided = double_sided;
  return m;
}

absl::Status CheckRange(const char* name, long value, long lo, long hi) {
  if (value < lo || value > hi) {
    return absl::InvalidArgumentError(
        absl::StrCat("ProceduralTreeOptions.", name, " is ", value, ", outside ", lo, "..", hi));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<ProceduralTree> MakeProceduralTree(const ProceduralTreeOptions& options) {
  for (absl::Status s : {CheckRange("branch_levels", options.branch_levels, 1, 5),
                         CheckRange("children", options.children, 2, 5),
                         CheckRange("leaves_per_twig", options.leaves_per_twig, 0, 16)}) {
    if (!s.ok()) return s;
  }
  if (!(options.trunk_radius > 0.001f && options.trunk_radius < 0.2f)) {
    return absl::InvalidArgumentError(
        absl::StrCat("ProceduralTreeOptions.trunk_radius is ", options.trunk_radius, ", outside (0.001, 0.2)"));
  }
  Grower grower{options, Random(options.seed), {}, {}, 1};
  grower.Grow({0, 0, 0}, {0, 1, 0}, 0.42f, options.trunk_radius, 0);

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "impostor tests/support/procedural_tree";
  model.buffers.emplace_back();
  model.materials.push_back(Material("bark", {0.33, 0.22, 0.13, 1}, false));
  model.materials.push_back(Material("leaf", {0.18, 0.45, 0.12, 1}, true));
  tinygltf::Mesh mesh;
  mesh.name = "tree";
  int material = 0;
  for (const Primitive* p : {&grower.bark, &grower.leaves}) {
    const int index = material++;
    if (p->indices.empty()) continue;
    tinygltf::Primitive prim;
    prim.attributes["POSITION"] = AddVec3Accessor(&model, p->positions, true);
    prim.attributes["NORMAL"] = AddVec3Accessor(&model, p->normals, false);
    prim.indices = AddIndexAccessor(&model, p->indices);
    prim.material = index;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    mesh.primitives.push_back(prim);
  }
  model.meshes.push_back(mesh);
  tinygltf::Node node;
  node.name = "tree";
  node.mesh = 0;
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes = {0};
  model.scenes.push_back(scene);
  model.defaultScene = 0;

  ProceduralTree out;
  out.branch_triangles = static_cast<uint32_t>(grower.bark.indices.size() / 3);
  out.leaf_triangles = static_cast<uint32_t>(grower.leaves.indices.size() / 3);
  out.thinnest_radius = grower.thinnest;
  Vec3 lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
  for (const Primitive* p : {&grower.bark, &grower.leaves}) {
    for (const Vec3& q : p->positions) {
      lo = {std::min(lo.x, q.x), std::min(lo.y, q.y), std::min(lo.z, q.z)};
      hi = {std::max(hi.x, q.x), std::max(hi.y, q.y), std::max(hi.z, q.z)};
    }
  }
  const Vec3 centre = (lo + hi) * 0.5f;
  for (const Primitive* p : {&grower.bark, &grower.leaves}) {
    for (const Vec3& q : p->positions) {
      out.bounding_radius = std::max(out.bounding_radius, std::sqrt(Dot(q - centre, q - centre)));
    }
  }
  std::ostringstream glb;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, glb, /*prettyPrint=*/false, /*writeBinary=*/true)) {
    return absl::InternalError("tinygltf could not serialise the procedural tree");
  }
  out.glb = glb.str();
  return out;
}

absl::StatusOr<ProceduralTree> WriteProceduralTree(const std::filesystem::path& path,
                                                   const ProceduralTreeOptions& options) {
  absl::StatusOr<ProceduralTree> tree = MakeProceduralTree(options);
  if (!tree.ok()) return tree.status();
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(tree->glb.data(), static_cast<std::streamsize>(tree->glb.size()));
  file.close();
  if (!file) return absl::InternalError(absl::StrCat("cannot write ", path.string()));
  return tree;
}

}  // namespace impostor::testing
