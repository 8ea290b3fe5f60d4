// What every Scene the loader builds satisfies and every consumer (the GPU
// renderer, the CPU reference, cards, surfels) relies on without checking
// again: a non-empty triangle list whose indices lie inside the vertices,
// batches of whole triangles inside the indices with a valid material,
// material texture references in range (or -1), known alpha modes, and
// textures of width * height * 4 bytes. Checked before rendering
// (render_validation.h) and on a scene that arrives as bytes
// (scene_wire.h). Pure; thread-safe.
#ifndef IMPOSTOR_WORKER_SCENE_SCENE_INVARIANTS_H_
#define IMPOSTOR_WORKER_SCENE_SCENE_INVARIANTS_H_

#include "absl/status/status.h"
#include "worker/scene/scene.h"

namespace impostor {

// OK, or INVALID_ARGUMENT naming the first broken invariant with its
// numbers.
absl::Status CheckSceneInvariants(const Scene& scene);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_SCENE_INVARIANTS_H_
