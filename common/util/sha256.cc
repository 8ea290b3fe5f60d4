#include "common/util/sha256.h"

#include <openssl/evp.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>

#include "absl/strings/str_cat.h"

namespace impostor {

struct Sha256::State {
  EVP_MD_CTX* ctx = nullptr;
};

Sha256::Sha256() : state_(std::make_unique<State>()) {
  state_->ctx = EVP_MD_CTX_new();
  EVP_DigestInit_ex(state_->ctx, EVP_sha256(), nullptr);
}

Sha256::~Sha256() { EVP_MD_CTX_free(state_->ctx); }

void Sha256::Update(const void* data, size_t size) {
  if (size > 0) EVP_DigestUpdate(state_->ctx, data, size);
}

std::string Sha256::FinishHex() {
  std::array<unsigned char, EVP_MAX_MD_SIZE> md{};
  unsigned int len = 0;
  EVP_DigestFinal_ex(state_->ctx, md.data(), &len);
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out(len * 2, '0');
  for (unsigned int i = 0; i < len; ++i) {
    out[2 * i] = kHex[md[i] >> 4];
    out[2 * i + 1] = kHex[md[i] & 0xf];
  }
  return out;
}

std::string Sha256Hex(std::string_view bytes) {
  Sha256 h;
  h.Update(bytes);
  return h.FinishHex();
}

absl::StatusOr<BlobDigest> DigestFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    const std::string msg = absl::StrCat("cannot open ", path.string(), ": ", std::strerror(err));
    return err == ENOENT ? absl::NotFoundError(msg) : absl::InternalError(msg);
  }
  Sha256 h;
  std::array<char, 1 << 16> buf;
  int64_t total = 0;
  while (in) {
    in.read(buf.data(), buf.size());
    const std::streamsize n = in.gcount();
    if (n > 0) {
      h.Update(buf.data(), static_cast<size_t>(n));
      total += n;
    }
  }
  if (in.bad()) return absl::InternalError(absl::StrCat("read error on ", path.string()));
  return BlobDigest{h.FinishHex(), total};
}

bool IsSha256Hex(std::string_view hash) {
  if (hash.size() != 64) return false;
  for (char c : hash) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

absl::Status ValidateDigest(std::string_view field, std::string_view hash, int64_t size_bytes) {
  if (!IsSha256Hex(hash)) {
    return absl::InvalidArgumentError(absl::StrCat(
        std::string(field), ".hash: expected 64 lowercase hex characters (SHA-256), got \"",
        std::string(hash.substr(0, 80)), "\""));
  }
  if (size_bytes < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(field), ".size_bytes: must be >= 0, got ", size_bytes));
  }
  return absl::OkStatus();
}

}  // namespace impostor
