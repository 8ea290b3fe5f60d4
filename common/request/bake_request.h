// Validation and normalisation of bake requests, and the cache key.
// Shared by the server (which decides), the client (which may pre-check) and
// tests. Pure functions; thread-safe.
#ifndef IMPOSTOR_COMMON_REQUEST_BAKE_REQUEST_H_
#define IMPOSTOR_COMMON_REQUEST_BAKE_REQUEST_H_

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/atlas/atlas_layout.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// The baker's version; part of every cache key.
std::string_view BakerVersion();

// Limits on BakeParameters (see types.proto).
inline constexpr uint32_t kDefaultFrames = 12;
inline constexpr uint32_t kDefaultResolution = 2048;
inline constexpr uint32_t kMinResolution = 64;
inline constexpr uint32_t kMaxResolution = 16384;
inline constexpr uint32_t kMinTilePixels = 8;
inline constexpr int kMaxInputFiles = 4096;
// PRODUCT_SURFELS: the point budget's range. 4 Mi points (192 MiB of
// buffer) is far beyond what a distant LOD needs; more is a mistake.
inline constexpr uint32_t kMinPointBudget = 1;
inline constexpr uint32_t kMaxPointBudget = 4u << 20;

// A named set of surfel capture defaults (the engine documentation's table
// of recommended budgets).
struct SurfelPreset {
  const char* name;
  uint32_t point_budget;
  uint32_t frames;
  uint32_t resolution;
};
inline constexpr SurfelPreset kSurfelPresets[] = {
    {"prop", 2048, 12, 512},
    {"building", 16384, 16, 1024},
    {"vegetation", 32768, 24, 2048},
    {"hero", 65536, 32, 2048},
};
// The preset used when a surfel request names none.
inline constexpr char kDefaultSurfelPreset[] = "vegetation";
inline constexpr size_t kMaxPathBytes = 1024;

// Fills every default in and checks every range. INVALID_ARGUMENT naming the
// field and its limit, e.g. "parameters.frames: 80 is out of range 2..64".
// The output's product is never UNSPECIFIED. For PRODUCT_SURFELS the preset
// is resolved into point_budget, frames and resolution (explicit fields
// win) and cleared; preset and point_budget with PRODUCT_ATLAS are refused.
absl::StatusOr<v1::BakeParameters> NormalizeParameters(const v1::BakeParameters& in);

// INVALID_ARGUMENT unless `path` is a safe relative path (see InputFile.path).
absl::Status ValidateRelativePath(std::string_view field, std::string_view path);

// Checks digests, paths (safe, and disjoint on disk: input_paths.h), counts
// and the entry's extension (.glb or .gltf). INVALID_ARGUMENT naming the
// offending field (both fields for a collision).
absl::Status ValidateMeshInput(const v1::MeshInput& mesh);

// SHA-256 hex over the entry's content, every external file's path and
// content, the normalised parameters and the baker's version. Inputs must be
// validated and normalised first. Independent of the entry's file name and of
// the order of `mesh.files`.
std::string ComputeCacheKey(const v1::MeshInput& mesh, const v1::BakeParameters& normalized);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_REQUEST_BAKE_REQUEST_H_
