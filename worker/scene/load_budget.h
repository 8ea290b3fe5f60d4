// The load budget: what building the bake Scene from a parsed glTF will
// cost, computed from the counts the file declares (accessor counts,
// instance counts, morph targets, image headers) before the builder reads
// or allocates anything per element, and checked against GltfLoadLimits.
//
// This is what keeps a few hundred bytes of JSON from making the worker
// allocate gigabytes: an accessor without a bufferView is legal and reads as
// zeros, so its `count` is the only thing bounding what a reader would
// allocate (issue 23: a 400-byte file declaring 60,000,000 instances drove
// the worker past 11 GB).
//
// The walk mirrors gltf_scene_builder.cc: the default scene's nodes (each
// at most once, so cycles and shared children cannot multiply it), their
// EXT_mesh_gpu_instancing instances, each mesh primitive per instance, and
// the images of the core texture slots of the materials those primitives
// use. Internal to the glTF loader; pure and thread-safe.
#ifndef IMPOSTOR_WORKER_SCENE_LOAD_BUDGET_H_
#define IMPOSTOR_WORKER_SCENE_LOAD_BUDGET_H_

#include <tiny_gltf.h>

#include <cstdint>

#include "absl/status/status.h"
#include <vector>

#include "absl/status/statusor.h"
#include "worker/scene/gltf_loader.h"

namespace impostor::gltf_internal {

// What the default scene declares, summed as the builder will meet it.
struct LoadCost {
  uint64_t draws = 0;               // instances x primitives (points/lines included)
  uint64_t drawn_vertices = 0;      // instances x POSITION count, triangle primitives
  uint64_t drawn_triangles = 0;     // instances x triangles (strips/fans: n - 2)
  uint64_t largest_instancing = 0;  // largest EXT_mesh_gpu_instancing count of one node
  uint64_t morph_elements = 0;      // morph targets x vertices, per distinct primitive
  uint64_t attribute_elements = 0;  // every attribute's count, per distinct primitive
  uint64_t texture_bytes = 0;       // distinct images' width x height x 4 (decoded RGBA8)
  uint64_t texture_peak_bytes = 0;  // largest single decode's peak (PeakDecodeBytes)
  uint64_t texture_peak_sum_bytes = 0;  // every decode's peak, summed: all of them at once
  std::vector<int> decodable_images;    // the images counted above (a PNG or JPEG header), ascending
  uint64_t total_bytes = 0;         // estimate of the heap the whole load holds at its peak
};

// Computes the cost. Indices, accessors, images and nodes that do not exist
// are skipped (the builder names them later); only the image headers are
// read, never their pixels.
LoadCost ComputeLoadCost(const tinygltf::Model& model);

// ComputeLoadCost, then every bound in `limits`. RESOURCE_EXHAUSTED naming
// the count, what it multiplies to and the limit, e.g. "node 0 'grass'
// EXT_mesh_gpu_instancing declares 60000000 instances x 1 primitives =
// 60000000 draws, over GltfLoadLimits::max_draws = 1000000".
// Returns the cost when every bound holds.
absl::StatusOr<LoadCost> CheckLoadBudget(const tinygltf::Model& model, const GltfLoadLimits& limits);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_LOAD_BUDGET_H_
