// SHA-256 digests (OpenSSL EVP) of byte ranges, streams and files, and the
// validation of digest strings received from the network.
#ifndef IMPOSTOR_COMMON_UTIL_SHA256_H_
#define IMPOSTOR_COMMON_UTIL_SHA256_H_

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor {

// A digest as plain data: lowercase hex SHA-256 and length in bytes.
struct BlobDigest {
  std::string hash;
  int64_t size_bytes = 0;
  friend bool operator==(const BlobDigest&, const BlobDigest&) = default;
  std::string ToString() const { return hash + "/" + std::to_string(size_bytes); }
};

// Incremental SHA-256. Not thread-safe; one per stream.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void Update(const void* data, size_t size);
  void Update(std::string_view bytes) { Update(bytes.data(), bytes.size()); }
  // Lowercase hex of the digest of everything updated so far; ends the hash.
  std::string FinishHex();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

std::string Sha256Hex(std::string_view bytes);

// Digest of a file's bytes. NOT_FOUND / INTERNAL with the path on I/O errors.
absl::StatusOr<BlobDigest> DigestFile(const std::filesystem::path& path);

// INVALID_ARGUMENT naming `field` unless hash is 64 lowercase hex characters
// and size_bytes >= 0.
absl::Status ValidateDigest(std::string_view field, std::string_view hash, int64_t size_bytes);
bool IsSha256Hex(std::string_view hash);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_UTIL_SHA256_H_
