// Keeps an untrusted glTF file inside its own directory, before and while
// tinygltf reads it:
//  * CheckJsonNesting refuses JSON nested deeper than tinygltf's recursive
//    value conversion can take without exhausting the stack;
//  * PrecheckJson refuses unsupported extensionsRequired and resolves every
//    buffer/image uri up front, so that an
//    absolute path, a scheme, a `..` escape, a symlink leading out or a
//    missing file is reported naming the uri and the buffer/image using it;
//  * SandboxedFsCallbacks is what tinygltf reads files through: it refuses
//    any path outside the root (defence in depth should the pre-check miss a
//    spelling), never expands `~`/`$VAR` (tinygltf's default uses wordexp)
//    and never writes.
// Internal to the glTF loader.
#ifndef IMPOSTOR_WORKER_SCENE_GLTF_SANDBOX_H_
#define IMPOSTOR_WORKER_SCENE_GLTF_SANDBOX_H_

#include <tiny_gltf.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor::gltf_internal {

// A directory the loader may read from; everything else is off limits.
class Sandbox {
 public:
  // `root` is made absolute and canonical (symlinks resolved).
  explicit Sandbox(const std::filesystem::path& root);

  const std::filesystem::path& root() const { return root_; }

  // True if `path` (absolute, or relative to the working directory), with
  // every symlink resolved, names something strictly below root().
  bool Contains(const std::filesystem::path& path) const;

  // Callbacks for tinygltf::TinyGLTF::SetFsCallbacks. `this` must outlive
  // the load.
  tinygltf::FsCallbacks FsCallbacks() const;

 private:
  std::filesystem::path root_;
};

// Callbacks for a load from memory: no file exists and none can be read or
// written, so an external uri that slips past PrecheckJson still fails.
tinygltf::FsCallbacks NoFileSystemCallbacks();

// OK if no JSON array/object is nested deeper than `max_depth` (strings are
// skipped correctly). INVALID_ARGUMENT naming the depth otherwise.
absl::Status CheckJsonNesting(std::string_view json, int max_depth);

// The JSON chunk of a GLB container, or nullopt when the header or chunk
// table is malformed (tinygltf then reports the precise problem).
std::optional<std::string_view> GlbJsonChunk(std::span<const uint8_t> glb);

// Checks the glTF JSON `json` before tinygltf parses it:
//  * every entry of extensionsRequired must be in `supported_required`
//    (checked first: tinygltf itself fails on e.g. Draco-only accessors with
//    a less helpful message), else INVALID_ARGUMENT
//    "extensionsRequired: NAME is not supported";
//  * every `buffers[i].uri` and `images[i].uri` that is not a data: uri must
//    be relative, scheme-less, resolve inside the sandbox and name an
//    existing file, else INVALID_ARGUMENT naming buffer/image index, name
//    and uri. With no sandbox (a load from memory) every such uri is
//    INVALID_ARGUMENT: there are no files to read.
//  * a skin without `joints` is INVALID_ARGUMENT naming the skin (tinygltf
//    refuses it without a message).
// JSON this function cannot parse is left to tinygltf (OK is returned).
absl::Status PrecheckJson(const Sandbox* sandbox, std::string_view json,
                          const std::set<std::string>& supported_required);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_GLTF_SANDBOX_H_
