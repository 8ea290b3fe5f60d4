// The input of a LOD chain: the parsed glTF model itself, with its triangle
// primitives read into plain arrays for the simplifier.
//
// Why the tinygltf Model and not the worker's Scene: the Scene is flattened
// for the GPU (node transforms applied, KHR_texture_transform baked into the
// UVs, materials renumbered in first-use order, images decoded to RGBA8), so
// it cannot be written back as the input's materials and textures. A LOD
// level must keep them (and the node hierarchy, TEXCOORD_1, COLOR_0,
// material extensions) untouched: only each primitive's triangles change.
// The Scene is still loaded first (LoadGltfScene) because it is the
// hardened gate for untrusted input; this model is parsed after it passed,
// through the same sandboxed file callbacks.
//
// Thread-safety: plain data; LoadLodSource is reentrant.
#ifndef IMPOSTOR_WORKER_LOD_LOD_SOURCE_H_
#define IMPOSTOR_WORKER_LOD_LOD_SOURCE_H_

#include <tiny_gltf.h>

#include <glm/mat4x4.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {

// One TRIANGLES primitive of a mesh, in the mesh's own space.
struct LodPrimitive {
  int mesh = 0;
  int primitive = 0;                // index in model.meshes[mesh].primitives
  std::vector<uint32_t> indices;    // triangle list (generated when unindexed)
  std::vector<float> positions;     // xyz per vertex
};

struct LodSource {
  // Images keep their encoded bytes (Image::image, as_is) and are not
  // decoded.
  tinygltf::Model model;
  // Every TRIANGLES primitive of the meshes the default scene draws, in mesh
  // then primitive order.
  std::vector<LodPrimitive> primitives;
  // Per mesh: how many times the default scene draws it (0 = unused), and
  // the largest scale factor of those nodes' world matrices (turns an error
  // in mesh space into scene units).
  std::vector<uint32_t> mesh_instances;
  std::vector<float> mesh_scale;
  // Per mesh: the world matrix of the first node drawing it (identity when
  // unused). The simplifier works in this scene space.
  std::vector<glm::mat4> mesh_world;
  // Primitives dropped from every level (points, lines; skins, morph targets
  // and animations are dropped too: the levels are static, like the
  // impostor). One line each.
  std::vector<std::string> warnings;

  // Triangles drawn by the default scene for per-primitive index counts
  // `index_counts` (same order as `primitives`).
  uint64_t DrawnTriangles(const std::vector<size_t>& index_counts) const;
};

// Parses `entry_file` (which LoadGltfScene has accepted) and reads its
// triangle primitives. INVALID_ARGUMENT naming the mesh and accessor for
// unreadable data, or when the default scene draws no triangles.
absl::StatusOr<LodSource> LoadLodSource(const std::filesystem::path& entry_file, const GltfLoadLimits& limits);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_LOD_LOD_SOURCE_H_
