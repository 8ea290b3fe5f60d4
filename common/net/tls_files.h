// Checks of the PEM files that the TLS flags and options name, made before
// gRPC sees them. gRPC reads (or watches) them later and only logs a file it
// cannot use, so without these checks a typo in a path or a certificate that
// does not belong to its key would surface as every handshake failing, far
// from the flag at fault. Each check names the flag or field (`name`) and
// the path; none echoes the file's contents. Pure apart from reading the
// files; thread-safe.
#ifndef IMPOSTOR_COMMON_NET_TLS_FILES_H_
#define IMPOSTOR_COMMON_NET_TLS_FILES_H_

#include <cstdint>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace impostor {

// The contents of `path` when it is readable and holds at least one PEM
// certificate ("-----BEGIN CERTIFICATE-----" that OpenSSL parses).
// INVALID_ARGUMENT "<name>: <path>: <why>" otherwise.
absl::StatusOr<std::string> ReadCertificateFile(absl::string_view name, const std::string& path);

// The contents of `path` when it is readable and holds a PEM private key
// (not encrypted with a passphrase: services start unattended).
// INVALID_ARGUMENT "<name>: <path>: <why>" otherwise.
absl::StatusOr<std::string> ReadPrivateKeyFile(absl::string_view name, const std::string& path);

// OK when the first certificate of `cert_pem` carries the public half of
// `key_pem`; INVALID_ARGUMENT naming both otherwise ("<cert_name> does not
// match <key_name>: ..."). Both must have passed the reads above.
absl::Status CheckKeyMatchesCertificate(absl::string_view cert_name, const std::string& cert_pem,
                                        absl::string_view key_name, const std::string& key_pem);

// When the first certificate of `cert_pem` stops being valid, seconds since
// the Unix epoch. INVALID_ARGUMENT when it holds no certificate.
absl::StatusOr<int64_t> CertificateNotAfter(const std::string& cert_pem);

// OK unless the first certificate of `cert_pem` has expired by
// `now_unix_seconds`: then INVALID_ARGUMENT "<name>: <path>: expired on
// 2026-11-22 14:26:11 UTC; renew it" (a certificate that can never be
// accepted is refused where it is configured, not in every handshake).
absl::Status CheckNotExpired(absl::string_view name, const std::string& path, const std::string& cert_pem,
                             int64_t now_unix_seconds);

// "2026-11-22 14:26:11 UTC".
std::string FormatUtc(int64_t unix_seconds);

// The files one side of a TLS connection needs, as the flags name them.
// An empty path means "not given".
struct TlsFilePaths {
  std::string ca;    // CA bundle to trust (PEM)
  std::string cert;  // own certificate chain (PEM), leaf first
  std::string key;   // own private key (PEM)
};

// How the fields of TlsFilePaths are called where they came from, for
// messages: {"--tls-ca", "--tls-cert", "--tls-key"} on a command line,
// {"ClientOptions.tls_ca_file", ...} in the SDK.
struct TlsFileNames {
  absl::string_view ca;
  absl::string_view cert;
  absl::string_view key;
};

// The PEM contents of a client's TLS files, checked.
struct ClientTlsPem {
  std::string ca;
  std::string cert;  // empty unless mutual TLS
  std::string key;   // empty unless mutual TLS
};

// Checks a client's TLS settings and reads its files:
//  - cert and key come together (mutual TLS) and need a CA: a client that
//    presents a certificate to a server it does not verify makes no sense;
//  - every file given is readable PEM of the right kind;
//  - the key matches the certificate, which has not expired.
// INVALID_ARGUMENT naming the field at fault. Callers skip this (plaintext)
// when `paths` is all empty.
absl::StatusOr<ClientTlsPem> ReadClientTlsFiles(const TlsFilePaths& paths, const TlsFileNames& names);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_TLS_FILES_H_
