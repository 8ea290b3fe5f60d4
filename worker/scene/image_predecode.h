// A load's textures decoded side by side before the scene is built, when
// the load's budget has room for every decode at once. Internal to the glTF
// loader.
//
// Why: the material table decodes each image when a material first uses
// it, one after another. DamagedHelmet's five 2048² JPEGs took ~0.45 s of a
// 0.55 s load on the 2-core development machine, and most of a GPU host's
// 0.16 s load (docs/explanation/figures.md, the H200 section), while its
// other cores waited.
//
// What stays the same: the scene (the same texels, the same order of
// textures and materials), and every refusal. A decode fails here only
// for what it would fail for in the material table (bad bytes, a side
// over GltfLoadLimits::max_texture_dimension): the budget checks the table
// makes in use order cannot fail once FitsDecodingAtOnce holds, and the
// table still makes them. Its results are taken in use order, so the first
// image in use order that does not decode is the one named.
#ifndef IMPOSTOR_WORKER_SCENE_IMAGE_PREDECODE_H_
#define IMPOSTOR_WORKER_SCENE_IMAGE_PREDECODE_H_

#include <tiny_gltf.h>

#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/load_budget.h"
#include "worker/scene/texture_decode.h"

namespace impostor::gltf_internal {

// Decoded images by glTF image index.
using PredecodedImages = std::map<int, absl::StatusOr<DecodedImage>>;

// Whether decoding all of `cost`'s images at once stays within `limits`:
// the texels and every decode's peak within max_texture_bytes (so no
// decode in use order could have been refused for the budget), and the
// load's estimate with the peaks of all decodes instead of the largest one
// within max_load_bytes.
bool FitsDecodingAtOnce(const LoadCost& cost, const GltfLoadLimits& limits);

// Decodes `images` on up to 16 threads, the calling thread among them,
// into the texel arena installed on the calling thread (texel_arena.h)
// when there is one. An image a thread could not be started for (the
// address-space limit) is left out: the material table decodes it when it
// is used, as before.
PredecodedImages PredecodeImages(const tinygltf::Model& model, const std::vector<int>& images,
                                 const GltfLoadLimits& limits);

// How messages name image `index`: "image[3] 'bark'" (its name, else its URI).
std::string ImageWhat(const tinygltf::Model& model, int index);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_IMAGE_PREDECODE_H_
