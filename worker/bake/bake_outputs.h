// Small helpers every bake pipeline (atlas, surfels, cards, LOD chain)
// uses to frame the mesh and write its outputs. Thread-safe.
#ifndef IMPOSTOR_WORKER_BAKE_BAKE_OUTPUTS_H_
#define IMPOSTOR_WORKER_BAKE_BAKE_OUTPUTS_H_

#include <filesystem>
#include <string_view>

#include "absl/status/statusor.h"
#include "common/atlas/atlas_layout.h"
#include "common/atlas/frame_camera.h"
#include "worker/bake/atlas_bake.h"
#include "worker/scene/scene.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// The shared mapping's layout for a request's (normalised) layout.
LayoutKind ToLayoutKind(v1::Layout layout);

// Writes `bytes` to `path` (replacing it) and returns their digest.
// INTERNAL naming the path when the write fails.
absl::StatusOr<v1::Digest> WriteFileWithDigest(const std::filesystem::path& path, std::string_view bytes);

// Writes `manifest` as dir/manifest.json and returns it with its
// manifest_json digest set. INTERNAL when the file cannot be written.
absl::StatusOr<AtlasBakeOutput> WriteManifest(const std::filesystem::path& dir, v1::Manifest manifest);

// The sphere the bake cameras frame: the minimal enclosing sphere of the
// scene's vertices. INVALID_ARGUMENT for a mesh without extent (radius 0
// or not finite).
absl::StatusOr<BoundingSphere> FramingSphere(const Scene& scene);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_BAKE_OUTPUTS_H_
