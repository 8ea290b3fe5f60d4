// Small helpers every bake pipeline (atlas, surfels) uses to write its
// outputs. Pure functions; thread-safe.
#ifndef IMPOSTOR_WORKER_BAKE_BAKE_OUTPUTS_H_
#define IMPOSTOR_WORKER_BAKE_BAKE_OUTPUTS_H_

#include <filesystem>
#include <string_view>

#include "absl/status/statusor.h"
#include "common/atlas_layout.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// The shared mapping's layout for a request's (normalised) layout.
LayoutKind ToLayoutKind(v1::Layout layout);

// Writes `bytes` to `path` (replacing it) and returns their digest.
// INTERNAL naming the path when the write fails.
absl::StatusOr<v1::Digest> WriteFileWithDigest(const std::filesystem::path& path, std::string_view bytes);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_BAKE_OUTPUTS_H_
