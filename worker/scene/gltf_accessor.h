// Bounds-checked reading of glTF accessors (including byteStride, every
// component type, the normalized flag, KHR_mesh_quantization integer
// attributes and sparse substitution) into plain arrays. Nothing here trusts
// an index, offset or count from the file. Internal to the glTF loader.
#ifndef IMPOSTOR_WORKER_SCENE_GLTF_ACCESSOR_H_
#define IMPOSTOR_WORKER_SCENE_GLTF_ACCESSOR_H_

#include <tiny_gltf.h>

#include <cstdint>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor::gltf_internal {

// Reads accessor `index`, which must have type `expected_type`
// (TINYGLTF_TYPE_VEC2/3/4), as floats: count * components values.
// Normalized integers map to [0, 1] / [-1, 1] as the glTF spec says;
// non-normalized integers convert to their value. An accessor without a
// bufferView starts as zeros (then sparse values apply).
// INVALID_ARGUMENT (message starts with `what`, e.g. "mesh 0 'hull'
// primitive 1 POSITION") for a bad index, type, component type or any
// out-of-bounds view, offset, stride or sparse entry; RESOURCE_EXHAUSTED if
// count exceeds `max_count`, checked before anything is allocated. Callers
// pass the tightest bound they know (POSITION's count for other attributes,
// GltfLoadLimits::max_draws for instances): the file's declared counts
// were checked as a whole by CheckLoadBudget first.
absl::StatusOr<std::vector<float>> ReadFloatAccessor(const tinygltf::Model& model, int index,
                                                     int expected_type, uint64_t max_count,
                                                     std::string_view what);

// Reads an index accessor (SCALAR, UNSIGNED_BYTE/SHORT/INT, sparse allowed).
// Errors as ReadFloatAccessor. Values are not compared with a vertex count
// here; the caller does that.
absl::StatusOr<std::vector<uint32_t>> ReadIndexAccessor(const tinygltf::Model& model, int index,
                                                        uint64_t max_count, std::string_view what);

// Element count of accessor `index`, or INVALID_ARGUMENT if the index is out
// of range.
absl::StatusOr<uint64_t> AccessorCount(const tinygltf::Model& model, int index,
                                       std::string_view what);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_GLTF_ACCESSOR_H_
