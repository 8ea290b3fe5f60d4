#include "common/net/tls_files.h"

#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

#include <openssl/asn1.h>

#include <cerrno>
#include <chrono>
#include <ctime>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

// PEM files are small; anything larger is not what the flag expects.
constexpr std::uintmax_t kMaxPemBytes = 1 << 20;

struct BioFree {
  void operator()(BIO* b) const { BIO_free(b); }
};
struct X509Free {
  void operator()(X509* x) const { X509_free(x); }
};
struct PkeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
using BioPtr = std::unique_ptr<BIO, BioFree>;
using X509Ptr = std::unique_ptr<X509, X509Free>;
using PkeyPtr = std::unique_ptr<EVP_PKEY, PkeyFree>;

absl::Status Bad(absl::string_view name, const std::string& path, absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat(name, ": ", path, ": ", why));
}

absl::StatusOr<std::string> ReadSmallFile(absl::string_view name, const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return Bad(name, path, "is a directory, expected a PEM file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Bad(name, path, absl::StrCat("cannot read (", std::strerror(errno), ")"));
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxPemBytes) return Bad(name, path, absl::StrCat("is ", size, " bytes; a PEM file is at most 1 MiB"));
  std::stringstream text;
  text << in.rdbuf();
  if (text.str().empty()) return Bad(name, path, "is empty, expected a PEM file");
  return text.str();
}

BioPtr MemoryBio(const std::string& text) {
  return BioPtr(BIO_new_mem_buf(text.data(), static_cast<int>(text.size())));
}

// Never prompts on the terminal for a passphrase (OpenSSL's default).
int NoPassphrase(char*, int, int, void*) { return -1; }

X509Ptr FirstCertificate(const std::string& pem) {
  BioPtr bio = MemoryBio(pem);
  X509Ptr cert(PEM_read_bio_X509(bio.get(), nullptr, NoPassphrase, nullptr));
  ERR_clear_error();
  return cert;
}

PkeyPtr PrivateKey(const std::string& pem) {
  BioPtr bio = MemoryBio(pem);
  PkeyPtr key(PEM_read_bio_PrivateKey(bio.get(), nullptr, NoPassphrase, nullptr));
  ERR_clear_error();
  return key;
}

}  // namespace

absl::StatusOr<std::string> ReadCertificateFile(absl::string_view name, const std::string& path) {
  absl::StatusOr<std::string> text = ReadSmallFile(name, path);
  if (!text.ok()) return text.status();
  if (!FirstCertificate(*text)) {
    return Bad(name, path, "holds no PEM certificate (expected \"-----BEGIN CERTIFICATE-----\")");
  }
  return text;
}

absl::StatusOr<std::string> ReadPrivateKeyFile(absl::string_view name, const std::string& path) {
  absl::StatusOr<std::string> text = ReadSmallFile(name, path);
  if (!text.ok()) return text.status();
  if (!PrivateKey(*text)) {
    if (text->find("ENCRYPTED") != std::string::npos) {
      return Bad(name, path, "is encrypted with a passphrase; services start unattended, so give an unencrypted key "
                             "readable only by the service's user");
    }
    return Bad(name, path, "holds no PEM private key (expected \"-----BEGIN PRIVATE KEY-----\")");
  }
  return text;
}

absl::Status CheckKeyMatchesCertificate(absl::string_view cert_name, const std::string& cert_pem,
                                        absl::string_view key_name, const std::string& key_pem) {
  X509Ptr cert = FirstCertificate(cert_pem);
  PkeyPtr key = PrivateKey(key_pem);
  if (!cert || !key) return absl::InvalidArgumentError(absl::StrCat(cert_name, " or ", key_name, ": not PEM"));
  const int match = X509_check_private_key(cert.get(), key.get());
  ERR_clear_error();
  if (match != 1) {
    return absl::InvalidArgumentError(absl::StrCat(cert_name, " does not match ", key_name,
                                                   ": the certificate was not issued for this private key"));
  }
  return absl::OkStatus();
}

absl::StatusOr<int64_t> CertificateNotAfter(const std::string& cert_pem) {
  X509Ptr cert = FirstCertificate(cert_pem);
  if (!cert) return absl::InvalidArgumentError("no PEM certificate");
  std::tm tm{};
  if (ASN1_TIME_to_tm(X509_get0_notAfter(cert.get()), &tm) != 1) {
    ERR_clear_error();
    return absl::InvalidArgumentError("the certificate's notAfter time is malformed");
  }
  return static_cast<int64_t>(::timegm(&tm));
}

std::string FormatUtc(int64_t unix_seconds) {
  const std::time_t t = static_cast<std::time_t>(unix_seconds);
  std::tm tm{};
  ::gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M:%S UTC", &tm);
  return text;
}

absl::Status CheckNotExpired(absl::string_view name, const std::string& path, const std::string& cert_pem,
                             int64_t now_unix_seconds) {
  absl::StatusOr<int64_t> not_after = CertificateNotAfter(cert_pem);
  if (!not_after.ok()) return Bad(name, path, not_after.status().message());
  if (*not_after < now_unix_seconds) {
    return Bad(name, path, absl::StrCat("expired on ", FormatUtc(*not_after), "; renew it"));
  }
  return absl::OkStatus();
}

static int64_t NowUnixSeconds() {
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

absl::StatusOr<ClientTlsPem> ReadClientTlsFiles(const TlsFilePaths& paths, const TlsFileNames& names) {
  if (!paths.cert.empty() && paths.key.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(names.cert, ": needs ", names.key, " too (mutual TLS)"));
  }
  if (paths.cert.empty() && !paths.key.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(names.key, ": needs ", names.cert, " too (mutual TLS)"));
  }
  if (paths.ca.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(names.cert, " and ", names.key, ": need ", names.ca,
                                                   " (the CA that signed the server's certificate)"));
  }
  ClientTlsPem pem;
  absl::StatusOr<std::string> ca = ReadCertificateFile(names.ca, paths.ca);
  if (!ca.ok()) return ca.status();
  pem.ca = std::move(*ca);
  if (paths.cert.empty()) return pem;
  absl::StatusOr<std::string> cert = ReadCertificateFile(names.cert, paths.cert);
  if (!cert.ok()) return cert.status();
  absl::StatusOr<std::string> key = ReadPrivateKeyFile(names.key, paths.key);
  if (!key.ok()) return key.status();
  if (absl::Status s = CheckKeyMatchesCertificate(names.cert, *cert, names.key, *key); !s.ok()) return s;
  if (absl::Status s = CheckNotExpired(names.cert, paths.cert, *cert, NowUnixSeconds()); !s.ok()) return s;
  pem.cert = std::move(*cert);
  pem.key = std::move(*key);
  return pem;
}

}  // namespace impostor
