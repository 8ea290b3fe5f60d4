// Loads an uploaded glTF 2.0 asset (.glb, or .gltf with its external
// buffers and images) into a bake-ready Scene: the default scene's triangles
// with node transforms applied, the materials they use and their decoded
// textures.
//
// The input is untrusted. Every failure is a status naming what is wrong;
// nothing outside the entry file's directory is ever read (see
// gltf_sandbox.h), and the limits below bound the memory a hostile file can
// make the worker allocate.
//
// Thread-safety: LoadGltfScene is reentrant; calls share no state.
#ifndef IMPOSTOR_WORKER_SCENE_GLTF_LOADER_H_
#define IMPOSTOR_WORKER_SCENE_GLTF_LOADER_H_

#include <cstdint>
#include <filesystem>
#include <string_view>

#include "absl/status/statusor.h"
#include "worker/scene/scene.h"

namespace impostor {

// Resource limits for one load. Exceeding one is RESOURCE_EXHAUSTED and the
// message names the limit and the offending value.
struct GltfLoadLimits {
  // Triangles in the flattened default scene (a mesh drawn by two nodes
  // counts twice). Default 20,000,000; range 1 .. 2^31 / 3 (indices are
  // 32-bit). Also bounds vertices at 3 per allowed triangle.
  uint64_t max_triangles = 20'000'000;
  // Largest width or height of a decoded texture, pixels. Default 16,384
  // (the usual GPU maxImageDimension2D); range 1 .. 65,535.
  int max_texture_dimension = 16384;
  // Sum of width * height * 4 over all decoded textures; each decode's peak
  // (texture_decode.h PeakDecodeBytes: per format, e.g. 40 bytes per pixel
  // for a 16-bit RGBA PNG) must also fit in what is left. Default 2 GiB; any
  // value >= 0 (0 refuses every textured asset).
  uint64_t max_texture_bytes = uint64_t{2} << 30;
  // Mesh primitives drawn, counting every node and EXT_mesh_gpu_instancing
  // instance (instances x primitives): each is a draw batch in the Scene.
  // Default 1,000,000; range 1 .. 2^31.
  uint64_t max_draws = 1'000'000;
  // Estimated peak heap of the whole load (load_budget.h: buffers, scene
  // geometry, per-primitive copies, decoded textures and the largest
  // decode's peak), checked from the file's declared counts before the
  // scene is built. Default 6 GiB (a 20,000,000-triangle scene with its
  // textures fits); any value >= 1.
  uint64_t max_load_bytes = uint64_t{6} << 30;
  // Deepest node nesting below a scene root (a root is depth 0). Deeper
  // hierarchies are INVALID_ARGUMENT. Default 1,024; range 1 .. 100,000.
  int max_node_depth = 1024;
};

// Loads `entry_file` (a .glb or .gltf; the format is decided by the file's
// magic bytes, not its name) and returns the default scene (model.scene,
// else scene 0, else every root node).
//
// Errors:
//   NOT_FOUND         `entry_file` does not exist or is not a regular file.
//   INVALID_ARGUMENT  malformed container/JSON (tinygltf's message, one line),
//                     an external uri that is absolute, has a scheme or
//                     leaves the entry file's directory, a missing external
//                     file (names the file and the buffer/image using it),
//                     an unsupported entry in extensionsRequired, any
//                     out-of-range index or accessor/bufferView bound (names
//                     mesh, primitive and accessor), non-finite transforms,
//                     node cycles, nodes deeper than max_node_depth, an
//                     undecodable PNG/JPEG image, or no triangles in the
//                     default scene (naming the points/lines meshes when
//                     only those exist).
// Worked around, with a line in Scene::warnings: images in formats the
// loader does not decode (anything but PNG and JPEG: KTX2, WebP, DDS, GIF,
// BMP, ...) are dropped and the material's factors used; points/lines
// primitives are skipped when triangles remain;
// a MASK material whose base colour image has no alpha channel; a texCoord
// set other than 0 or 1 (set 0 used); skinned meshes are baked in their
// bind pose.
//   RESOURCE_EXHAUSTED a GltfLoadLimits limit is exceeded. The counts the
//                     file declares are checked against the limits before
//                     the scene is built (load_budget.h), so a file whose
//                     accessors declare more than the limits allow is
//                     refused without allocating for them.
absl::StatusOr<Scene> LoadGltfScene(const std::filesystem::path& entry_file,
                                    const GltfLoadLimits& limits = {});

// Loads a .glb or .gltf held in memory (format by magic bytes, as above),
// with the same checks and limits as LoadGltfScene but no file system: every
// buffer and image must be embedded (GLB binary chunk or data: uri). `name`
// only labels messages. What the fuzzer drives.
//
// Errors: as LoadGltfScene, except that there is no NOT_FOUND; an external
// (non-data:) uri is INVALID_ARGUMENT naming the buffer/image and the uri.
absl::StatusOr<Scene> LoadGltfSceneFromMemory(std::string_view bytes,
                                              std::string_view name = "memory.gltf",
                                              const GltfLoadLimits& limits = {});

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_GLTF_LOADER_H_
