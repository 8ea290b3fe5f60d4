// A Scene as bytes, so the isolated loader's child (isolated_load.h) can
// hand the scene it decoded to the worker instead of the worker decoding
// the same file a second time.
//
// The bytes come from a process that ran untrusted input through decoders:
// if a decoder bug gave that child to an attacker, these bytes are the
// attacker's. DecodeScene therefore trusts nothing in them: every count is
// checked against the bytes left before anything is allocated, and the
// result must hold every invariant the loader guarantees and the bake
// relies on (scene_invariants.h). A scene that fails a check is refused
// whole.
//
// The format is private to one worker binary (both ends are the same
// build): native byte order, no versioning beyond a magic that names it.
#ifndef IMPOSTOR_WORKER_SCENE_SCENE_WIRE_H_
#define IMPOSTOR_WORKER_SCENE_SCENE_WIRE_H_

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "worker/scene/scene.h"
#include "worker/scene/texel_arena.h"

namespace impostor {

// Receives the encoded scene piece by piece, in order.
using SceneByteSink = std::function<void(std::string_view bytes)>;

// Writes `scene` to `out` (large arrays in one piece each, so a file
// descriptor sink costs a few writes, not a copy). A texture whose bytes are
// in `arena` (when not null) is written as its place there, the others as
// their bytes.
void EncodeScene(const Scene& scene, const SceneByteSink& out, const TexelArena* arena = nullptr);
// The same, appended to a string.
void EncodeScene(const Scene& scene, std::string* out);

// The scene in `bytes`, checked as above; DATA_LOSS naming the first
// check that failed (truncated, a count past the end, an index out of
// range...). Textures written by their place in an arena are views of
// `texels` (that arena's memfd, mapped), checked to lie inside it; without
// `texels` such a texture is refused.
absl::StatusOr<Scene> DecodeScene(std::span<const uint8_t> bytes, const MappedTexels* texels = nullptr);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_SCENE_WIRE_H_
