#include "client/transfer/file_digest_memo.h"

#include <sys/stat.h>

#include "common/util/sha256.h"

namespace impostor::sdk {

absl::StatusOr<v1::Digest> FileDigestMemo::Get(const std::filesystem::path& path) {
  // The stamp is taken before hashing: a file changed during the hash gets a
  // new stamp and is hashed again next time.
  struct stat st {};
  const bool stamped = ::stat(path.c_str(), &st) == 0;
  const Stamp stamp{static_cast<uint64_t>(st.st_dev), static_cast<uint64_t>(st.st_ino), static_cast<int64_t>(st.st_size),
                    static_cast<int64_t>(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec};
  if (stamped) {
    const auto it = entries_.find(path.string());
    if (it != entries_.end() && it->second.stamp == stamp) return it->second.digest;
  }
  absl::StatusOr<BlobDigest> digest = DigestFile(path);
  if (!digest.ok()) return digest.status();
  bytes_hashed_ += digest->size_bytes;
  v1::Digest out;
  out.set_hash(digest->hash);
  out.set_size_bytes(digest->size_bytes);
  if (stamped && stamp.size == digest->size_bytes) entries_[path.string()] = {stamp, out};
  return out;
}

}  // namespace impostor::sdk
