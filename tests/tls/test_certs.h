// Certificates for TLS tests, made at test time with the `openssl` command
// (as a studio would make them; README "Securing a farm: TLS"), so no key
// is ever committed and none outlives its test's temporary directory.
//
// Thread-safety: one TestPki per test; its methods from one thread.
#ifndef IMPOSTOR_TESTS_TLS_TEST_CERTS_H_
#define IMPOSTOR_TESTS_TLS_TEST_CERTS_H_

#include <filesystem>
#include <string>

namespace impostor::testing {

// A certificate (or CA) and its key, as PEM files.
struct CertFiles {
  std::filesystem::path cert;
  std::filesystem::path key;
};

// Makes CAs and the certificates they sign in `dir` (created if missing).
// Each method fails the running test (ADD_FAILURE naming the openssl
// command and its output) and returns empty paths when openssl does.
class TestPki {
 public:
  explicit TestPki(std::filesystem::path dir);

  // A self-signed CA "<name>" (P-256 key, CA:TRUE), in <name>.crt/.key.
  CertFiles MakeCa(const std::string& name);
  // A server certificate "<name>" signed by `ca`, for localhost and
  // 127.0.0.1 (subjectAltName) unless `san` says otherwise
  // ("DNS:bake.studio.lan"), valid for `days` (-1: expired yesterday).
  CertFiles MakeServerCert(const std::string& name, const CertFiles& ca,
                           const std::string& san = "DNS:localhost,IP:127.0.0.1", int days = 2);
  // A client certificate "<name>" (extendedKeyUsage clientAuth) signed by
  // `ca`, valid for `days` (-1: expired yesterday).
  CertFiles MakeClientCert(const std::string& name, const CertFiles& ca, int days = 2);

  const std::filesystem::path& dir() const { return dir_; }

 private:
  CertFiles MakeLeaf(const std::string& name, const CertFiles& ca, const std::string& extensions, int days);
  bool Run(const std::string& command);

  std::filesystem::path dir_;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_TLS_TEST_CERTS_H_
