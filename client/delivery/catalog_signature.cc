#include "client/delivery/catalog_signature.h"

#include <openssl/evp.h>
#include <openssl/pem.h>

#include <cstdio>
#include <memory>

#include "absl/strings/string_view.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"

namespace impostor::delivery {
namespace {

struct PkeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
struct MdCtxFree {
  void operator()(EVP_MD_CTX* c) const { EVP_MD_CTX_free(c); }
};
using Pkey = std::unique_ptr<EVP_PKEY, PkeyFree>;
using MdCtx = std::unique_ptr<EVP_MD_CTX, MdCtxFree>;

absl::StatusOr<Pkey> ReadKey(const std::filesystem::path& file, bool private_key) {
  std::FILE* f = std::fopen(file.c_str(), "rb");
  if (f == nullptr) return absl::InvalidArgumentError(absl::StrCat(file.string(), ": cannot open the key file"));
  EVP_PKEY* key = private_key ? PEM_read_PrivateKey(f, nullptr, nullptr, nullptr)
                              : PEM_read_PUBKEY(f, nullptr, nullptr, nullptr);
  std::fclose(f);
  if (key == nullptr || EVP_PKEY_id(key) != EVP_PKEY_ED25519) {
    EVP_PKEY_free(key);
    return absl::InvalidArgumentError(absl::StrCat(file.string(), ": not an Ed25519 ",
                                                   private_key ? "private" : "public",
                                                   " key in PEM (openssl genpkey -algorithm ed25519",
                                                   private_key ? "" : "; openssl pkey -pubout", ")"));
  }
  return Pkey(key);
}

std::string RawPublic(EVP_PKEY* key) {
  size_t size = 32;
  std::string raw(size, '\0');
  if (EVP_PKEY_get_raw_public_key(key, reinterpret_cast<unsigned char*>(raw.data()), &size) != 1) return {};
  raw.resize(size);
  return raw;
}

std::string KeyId(const std::string& raw) { return Sha256Hex(raw).substr(0, 16); }

}  // namespace

absl::StatusOr<CatalogSignature> SignCatalog(const std::filesystem::path& private_key_pem_file,
                                             absl::string_view message) {
  absl::StatusOr<Pkey> key = ReadKey(private_key_pem_file, /*private_key=*/true);
  if (!key.ok()) return key.status();
  MdCtx ctx(EVP_MD_CTX_new());
  size_t size = 64;
  std::string sig(size, '\0');
  if (ctx == nullptr || EVP_DigestSignInit(ctx.get(), nullptr, nullptr, nullptr, key->get()) != 1 ||
      EVP_DigestSign(ctx.get(), reinterpret_cast<unsigned char*>(sig.data()), &size,
                     reinterpret_cast<const unsigned char*>(message.data()), message.size()) != 1) {
    return absl::InternalError(absl::StrCat(private_key_pem_file.string(), ": signing failed"));
  }
  sig.resize(size);
  CatalogSignature out;
  out.key_id = KeyId(RawPublic(key->get()));
  out.value = absl::Base64Escape(sig);
  return out;
}

absl::StatusOr<CatalogPublicKey> LoadCatalogPublicKey(const std::filesystem::path& public_key_pem_file) {
  absl::StatusOr<Pkey> key = ReadKey(public_key_pem_file, /*private_key=*/false);
  if (!key.ok()) return key.status();
  CatalogPublicKey out;
  out.raw = RawPublic(key->get());
  out.key_id = KeyId(out.raw);
  return out;
}

absl::Status VerifyCatalog(const CatalogPublicKey& key, const std::optional<CatalogSignature>& signature,
                           absl::string_view message, absl::string_view source) {
  if (!signature.has_value()) {
    return absl::PermissionDeniedError(
        absl::StrCat(source, ": the catalog is not signed, and this client accepts only signed catalogs"));
  }
  if (signature->algorithm != "ed25519") {
    return absl::PermissionDeniedError(
        absl::StrCat(source, ": signature algorithm \"", signature->algorithm.substr(0, 20), "\" (expected ed25519)"));
  }
  if (signature->key_id != key.key_id) {
    return absl::PermissionDeniedError(absl::StrCat(source, ": signed by key ", signature->key_id.substr(0, 16),
                                                    ", but this client trusts key ", key.key_id));
  }
  std::string sig;
  if (!absl::Base64Unescape(signature->value, &sig) || sig.size() != 64) {
    return absl::PermissionDeniedError(absl::StrCat(source, ": the signature is not 64 bytes of base64"));
  }
  Pkey pkey(EVP_PKEY_new_raw_public_key(EVP_PKEY_ED25519, nullptr,
                                        reinterpret_cast<const unsigned char*>(key.raw.data()), key.raw.size()));
  MdCtx ctx(EVP_MD_CTX_new());
  if (pkey == nullptr || ctx == nullptr || EVP_DigestVerifyInit(ctx.get(), nullptr, nullptr, nullptr, pkey.get()) != 1) {
    return absl::InternalError("cannot set up Ed25519 verification");
  }
  if (EVP_DigestVerify(ctx.get(), reinterpret_cast<const unsigned char*>(sig.data()), sig.size(),
                       reinterpret_cast<const unsigned char*>(message.data()), message.size()) != 1) {
    return absl::PermissionDeniedError(
        absl::StrCat(source, ": the catalog's signature does not verify (tampered with, or signed by another key)"));
  }
  return absl::OkStatus();
}

}  // namespace impostor::delivery
