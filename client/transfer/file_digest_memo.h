// SHA-256 digests of local files, each file hashed once while it is
// unchanged: a batch often bakes one model under several settings (layouts,
// frame counts, LOD variants), and hashing its files again for every request
// was most of a batch of cached results' client time (13 requests of one
// 3.8 MB model: 49 MB hashed, ~30 ms). A file is hashed again when its size,
// modification time, inode or device differ from when it was hashed.
//
// Thread-safety: none; one memo per call (UploadMeshes).
#ifndef IMPOSTOR_CLIENT_TRANSFER_FILE_DIGEST_MEMO_H_
#define IMPOSTOR_CLIENT_TRANSFER_FILE_DIGEST_MEMO_H_

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"

namespace impostor::sdk {

class FileDigestMemo {
 public:
  // The digest of the file at `path`; errors as DigestFile's (the file
  // named).
  absl::StatusOr<v1::Digest> Get(const std::filesystem::path& path);

  // Bytes hashed so far (a file served from the memo adds none).
  int64_t bytes_hashed() const { return bytes_hashed_; }

 private:
  struct Stamp {
    uint64_t device = 0, inode = 0;
    int64_t size = 0, mtime_ns = 0;
    friend bool operator==(const Stamp&, const Stamp&) = default;
  };
  struct Entry {
    Stamp stamp;
    v1::Digest digest;
  };
  std::map<std::string, Entry> entries_;  // by path as given
  int64_t bytes_hashed_ = 0;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSFER_FILE_DIGEST_MEMO_H_
