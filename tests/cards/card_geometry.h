// Synthetic planar meshes for the card tests: quads subdivided into grids of
// triangles, as triangle soups and as glTF files.
#ifndef IMPOSTOR_TESTS_CARDS_CARD_GEOMETRY_H_
#define IMPOSTOR_TESTS_CARDS_CARD_GEOMETRY_H_

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "worker/cards/plane_fitting.h"

namespace impostor::testing {

// A rectangle centre + s * a + t * b, s, t in [-1, 1], split into n x n
// cells of two triangles each (counter-clockwise seen from cross(a, b)).
struct Quad {
  glm::vec3 center{0.0f};
  glm::vec3 a{1.0f, 0.0f, 0.0f};
  glm::vec3 b{0.0f, 1.0f, 0.0f};
  int cells = 4;
};

std::vector<Triangle3> QuadTriangles(const Quad& q);

// Every quad's triangles, in order.
std::vector<Triangle3> Soup(const std::vector<Quad>& quads);

// Writes `triangles` as a .gltf with an embedded buffer, one
// double-sided OPAQUE material of `color` (baseColorFactor, linear), and
// returns its path.
std::filesystem::path WriteSoupGltf(const std::filesystem::path& dir, const std::vector<Triangle3>& triangles,
                                    const glm::vec4& color);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_CARDS_CARD_GEOMETRY_H_
