// Which files make up a glTF model: the entry file (.gltf or .glb) and every
// file its buffers and images refer to by relative URI. Only the JSON is
// read; geometry and images are not parsed. Thread-safe (no shared state).
#ifndef IMPOSTOR_CLIENT_TRANSFER_MESH_FILES_H_
#define IMPOSTOR_CLIENT_TRANSFER_MESH_FILES_H_

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "common/util/percent_decode.h"

namespace impostor::sdk {

struct MeshFile {
  // '/'-separated path relative to the entry's directory, percent-decoded and
  // without "." components; what MeshInput.files[].path carries.
  std::string relative_path;
  // Where the file is on this machine.
  std::filesystem::path local_path;
};

struct MeshFiles {
  std::filesystem::path entry;  // the model file as given
  std::string entry_name;       // its bare file name
  // External files, in first-use order (buffers, then images), each once.
  std::vector<MeshFile> files;
};

struct CollectOptions {
  // Upload files reached through a symbolic link that leads out of the
  // model's folder. Default false: a downloaded asset pack's
  // "tex.png -> ~/.ssh/id_rsa" must not be uploaded (and then readable by
  // anyone who can read blobs). Links that stay inside the folder are
  // followed either way.
  bool follow_symlinks = false;
};

// Reads `model` and lists its files. Errors:
//   NOT_FOUND         the model, or a file it refers to (naming the file and
//                     the buffer/image that uses it);
//   INVALID_ARGUMENT  not .gltf/.glb, a corrupt GLB header, invalid JSON, a
//                     URI that is absolute, has a scheme, contains "..", or a
//                     bad percent escape (naming the URI);
//   PERMISSION_DENIED a file reached through a symbolic link that leads out
//                     of the model's folder, unless options.follow_symlinks
//                     (naming the link, its target and the flag);
//   INTERNAL          a read error.
absl::StatusOr<MeshFiles> CollectMeshFiles(const std::filesystem::path& model,
                                           const CollectOptions& options = {});

// The JSON chunk of a GLB file's bytes (only the header and the first chunk
// need be present). INVALID_ARGUMENT naming what is wrong with the header.
absl::StatusOr<std::string> GlbJsonChunk(std::string_view glb_prefix, std::string_view name);

// Decodes %XX escapes (common/util/percent_decode.h, shared with the worker).
using ::impostor::PercentDecode;

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_MESH_FILES_H_
