#include "tests/cards/card_geometry.h"

#include <cstring>
#include <fstream>

#include <glm/geometric.hpp>

#include "absl/strings/str_cat.h"
#include "tests/scene/test_assets.h"

namespace impostor::testing {

std::vector<Triangle3> QuadTriangles(const Quad& q) {
  std::vector<Triangle3> out;
  auto at = [&](int i, int j) {
    const float s = -1.0f + 2.0f * i / q.cells, t = -1.0f + 2.0f * j / q.cells;
    return q.center + s * q.a + t * q.b;
  };
  for (int j = 0; j < q.cells; ++j) {
    for (int i = 0; i < q.cells; ++i) {
      out.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      out.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  return out;
}

std::vector<Triangle3> Soup(const std::vector<Quad>& quads) {
  std::vector<Triangle3> out;
  for (const Quad& q : quads) {
    const auto t = QuadTriangles(q);
    out.insert(out.end(), t.begin(), t.end());
  }
  return out;
}

std::filesystem::path WriteSoupGltf(const std::filesystem::path& dir, const std::vector<Triangle3>& triangles,
                                    const glm::vec4& color) {
  std::vector<uint8_t> bytes;
  std::vector<float> positions, normals;
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const Triangle3& t : triangles) {
    const glm::vec3 n = glm::normalize(glm::cross(t[1] - t[0], t[2] - t[0]));
    for (const glm::vec3& p : t) {
      positions.insert(positions.end(), {p.x, p.y, p.z});
      normals.insert(normals.end(), {n.x, n.y, n.z});
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  bytes.resize((positions.size() + normals.size()) * sizeof(float));
  std::memcpy(bytes.data(), positions.data(), positions.size() * sizeof(float));
  std::memcpy(bytes.data() + positions.size() * sizeof(float), normals.data(), normals.size() * sizeof(float));
  const size_t count = triangles.size() * 3;
  const size_t half = positions.size() * sizeof(float);
  const std::string json = absl::StrCat(
      R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)",
      R"("meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1},"material":0}]}],)",
      R"("materials":[{"doubleSided":true,"pbrMetallicRoughness":{"baseColorFactor":[)", color.r, ",", color.g,
      ",", color.b, ",", color.a, R"(],"metallicFactor":0,"roughnessFactor":1}}],)",
      R"("accessors":[{"bufferView":0,"componentType":5126,"count":)", count, R"(,"type":"VEC3","min":[)", lo.x,
      ",", lo.y, ",", lo.z, "],\"max\":[", hi.x, ",", hi.y, ",", hi.z, "]},",
      R"({"bufferView":1,"componentType":5126,"count":)", count, R"(,"type":"VEC3"}],)",
      R"("bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":)", half, R"(},{"buffer":0,"byteOffset":)", half,
      R"(,"byteLength":)", half, "}],",
      R"("buffers":[{"byteLength":)", bytes.size(), R"(,"uri":"data:application/octet-stream;base64,)",
      Base64(bytes), "\"}]}");
  const std::filesystem::path path = dir / "soup.gltf";
  WriteFile(path, json);
  return path;
}

}  // namespace impostor::testing
