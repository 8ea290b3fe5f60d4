// The worker's bake pipeline for LOD chains (PRODUCT_LOD_CHAIN), by stage:
//   load (LoadGltfScene as the input gate, then the glTF model itself,
//   worker/lod/lod_source) -> simplify (each level at its ratio,
//   worker/lod/lod_simplify) -> write (lod<N>.glb per level plus the input's
//   images once, worker/lod/lod_glb_writer) -> impostor (BakeAtlas with the
//   request's layout/frames/resolution, its manifest kept as impostor.json)
//   -> thresholds (worker/lod/lod_thresholds) -> manifest.json.
// Every file lands flat in request.output_dir and is listed in the
// manifest's `maps` (semantics "lod_mesh", "lod_texture",
// "impostor_manifest" and the atlas maps'), so the worker loop, the server
// and the SDK move them like any other result file.
//
// Thread-safety: one bake per AtlasRenderer at a time.
#ifndef IMPOSTOR_WORKER_BAKE_LOD_BAKE_H_
#define IMPOSTOR_WORKER_BAKE_LOD_BAKE_H_

#include <atomic>

#include "absl/status/statusor.h"
#include "worker/bake/atlas_bake.h"
#include "worker/gpu/atlas_renderer.h"

namespace impostor {

// File name of the impostor level's atlas manifest in the result directory.
inline constexpr char kLodImpostorManifestFile[] = "impostor.json";

// Runs the pipeline for normalised parameters with product
// PRODUCT_LOD_CHAIN. INVALID_ARGUMENT for a mesh that cannot be baked (the
// loader's message, e.g. no triangles); CANCELLED when `cancelled` turns
// true between levels or stages; INTERNAL when a file cannot be written;
// BakeAtlas's errors for the impostor level.
absl::StatusOr<AtlasBakeOutput> BakeLodChain(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                             const BakeProgress& progress, const std::atomic<bool>& cancelled);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_LOD_BAKE_H_
