// Ed25519 signatures of release catalogs (OpenSSL), so that a mirror that
// was tampered with cannot swap a catalog, and through its digests any file:
// the publisher signs the catalog's exact bytes with a private key, and a
// client holding the public key refuses a catalog whose signature is missing
// or wrong. Keys are PEM files as `openssl genpkey -algorithm ed25519` and
// `openssl pkey -pubout` write them. Thread-safe.
#ifndef IMPOSTOR_CLIENT_DELIVERY_CATALOG_SIGNATURE_H_
#define IMPOSTOR_CLIENT_DELIVERY_CATALOG_SIGNATURE_H_

#include <filesystem>
#include <string>
#include <string_view>

#include "absl/strings/string_view.h"
#include "absl/status/statusor.h"
#include "client/delivery/catalog.h"

namespace impostor::delivery {

// Signs `message` with the Ed25519 private key in `private_key_pem_file`.
// INVALID_ARGUMENT naming the file when it is unreadable or not an Ed25519
// private key.
absl::StatusOr<CatalogSignature> SignCatalog(const std::filesystem::path& private_key_pem_file,
                                             absl::string_view message);

// A loaded public key.
struct CatalogPublicKey {
  std::string raw;     // 32 bytes
  std::string key_id;  // 16 hex
};
// INVALID_ARGUMENT naming the file when it is unreadable or not an Ed25519
// public key.
absl::StatusOr<CatalogPublicKey> LoadCatalogPublicKey(const std::filesystem::path& public_key_pem_file);

// OK when `signature` is a valid Ed25519 signature of `message` by `key`;
// else PERMISSION_DENIED naming `source` and what is wrong (missing, another
// key, does not verify).
absl::Status VerifyCatalog(const CatalogPublicKey& key, const std::optional<CatalogSignature>& signature,
                           absl::string_view message, absl::string_view source);

}  // namespace impostor::delivery

#endif  // IMPOSTOR_CLIENT_DELIVERY_CATALOG_SIGNATURE_H_
