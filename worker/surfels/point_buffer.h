// Writer and reader of the surfel point buffer: 12 little-endian float32
// per point, the layout of Surfel. Format: point_buffer_format.md (next to
// this file). Pure functions; thread-safe.
#ifndef IMPOSTOR_WORKER_SURFELS_POINT_BUFFER_H_
#define IMPOSTOR_WORKER_SURFELS_POINT_BUFFER_H_

#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/surfels/surfel.h"

namespace impostor {

inline constexpr size_t kPointStrideBytes = 48;
// Manifest map format name of the buffer.
inline constexpr char kPointBufferFormat[] = "f32x12_le";

// The buffer's bytes (points.size() * 48).
std::string EncodePointBuffer(const std::vector<Surfel>& points);

// INVALID_ARGUMENT when the size is not a multiple of 48 bytes.
absl::StatusOr<std::vector<Surfel>> DecodePointBuffer(std::string_view bytes);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SURFELS_POINT_BUFFER_H_
