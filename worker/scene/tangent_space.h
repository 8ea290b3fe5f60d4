// Generated vertex normals and tangents for primitives that lack them.
// Pure functions on plain arrays; internal to the glTF loader.
#ifndef IMPOSTOR_WORKER_SCENE_TANGENT_SPACE_H_
#define IMPOSTOR_WORKER_SCENE_TANGENT_SPACE_H_

#include <cstdint>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>
#include <span>
#include <vector>

namespace impostor::gltf_internal {

// Smooth per-vertex normals: the sum of the (unnormalised, hence area
// weighted) face normals of every triangle using the vertex, normalised.
// Vertices no triangle uses, or whose faces cancel out, get +Y.
// `triangles` holds 3 indices per triangle, each < positions.size().
std::vector<glm::vec3> ComputeSmoothNormals(std::span<const glm::vec3> positions,
                                            std::span<const uint32_t> triangles);

// Per-vertex tangents from the UV parametrisation: each triangle's dP/du and
// dP/dv are accumulated (area weighted) at its vertices, the tangent is made
// orthogonal to the normal (Gram-Schmidt) and w = +-1 says whether
// (normal x tangent) points along dP/dv. This is NOT MikkTSpace: normal maps
// baked against MikkTSpace tangents can show small shading differences on
// curved or mirrored UV islands. Vertices with degenerate UVs get an
// arbitrary unit tangent orthogonal to the normal (w = 1).
std::vector<glm::vec4> ComputeTangents(std::span<const glm::vec3> positions,
                                       std::span<const glm::vec3> normals,
                                       std::span<const glm::vec2> uvs,
                                       std::span<const uint32_t> triangles);

// Some unit vector orthogonal to unit `n` (deterministic).
glm::vec3 AnyOrthogonal(glm::vec3 n);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_TANGENT_SPACE_H_
