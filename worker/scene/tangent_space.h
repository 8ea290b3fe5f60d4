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

// Per-vertex tangents from the UV parametrisation, built the way
// MikkTSpace builds them: each triangle's dP/du and dP/dv are projected into
// the tangent plane of each of its vertices, normalised and accumulated
// weighted by the triangle's angle at that vertex; the sum is made
// orthogonal to the normal (Gram-Schmidt) and w = +-1 says whether
// (normal x tangent) points along the accumulated dP/dv.
// Differences from MikkTSpace proper: vertices are not split -- MikkTSpace
// gives a vertex shared by triangles of opposite UV handedness (mirrored
// islands) or by UV seams separate tangents, here they are averaged into one
// (the index buffer is kept as is); degenerate-triangle handling and the
// final float rounding differ. Normal maps baked against MikkTSpace match
// on smooth, unmirrored islands and can differ slightly at mirror seams.
// Vertices with degenerate UVs get an arbitrary unit tangent orthogonal to
// the normal (w = 1).
std::vector<glm::vec4> ComputeTangents(std::span<const glm::vec3> positions,
                                       std::span<const glm::vec3> normals,
                                       std::span<const glm::vec2> uvs,
                                       std::span<const uint32_t> triangles);

// Some unit vector orthogonal to unit `n` (deterministic).
glm::vec3 AnyOrthogonal(glm::vec3 n);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_TANGENT_SPACE_H_
