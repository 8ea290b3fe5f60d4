// Flattens the default scene of a parsed (untrusted) tinygltf::Model into a
// Scene: node hierarchy, primitives, generated normals/tangents, materials.
// Internal to the glTF loader; see gltf_loader.h for the contract.
#ifndef IMPOSTOR_WORKER_SCENE_GLTF_SCENE_BUILDER_H_
#define IMPOSTOR_WORKER_SCENE_GLTF_SCENE_BUILDER_H_

#include <tiny_gltf.h>

#include "absl/status/statusor.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/image_predecode.h"
#include "worker/scene/scene.h"

namespace impostor::gltf_internal {

// Builds the Scene of `model`'s default scene. Errors as LoadGltfScene.
// Images in `predecoded` (may be null) are taken from it instead of being
// decoded when first used (image_predecode.h).
absl::StatusOr<Scene> BuildScene(const tinygltf::Model& model, const GltfLoadLimits& limits,
                                 PredecodedImages* predecoded = nullptr);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_GLTF_SCENE_BUILDER_H_
