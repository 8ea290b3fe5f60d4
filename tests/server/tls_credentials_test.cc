// The server's TLS flags (server/auth/tls_credentials.h): every combination that
// cannot work is refused before the server starts, naming the flag at fault;
// the ones that can work produce credentials.
#include "server/auth/tls_credentials.h"
#include "server/auth/loopback_host.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/tls/test_certs.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::CertFiles;
using testing::TestPki;

class ServerTlsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("impostor_server_tls_" + std::to_string(::getpid())));
    fs::remove_all(*dir_);
    TestPki pki(*dir_);
    ca_ = new CertFiles(pki.MakeCa("ca"));
    server_ = new CertFiles(pki.MakeServerCert("server", *ca_));
    other_ = new CertFiles(pki.MakeServerCert("other", *ca_));
    expired_ = new CertFiles(pki.MakeServerCert("expired", *ca_, "DNS:localhost", /*days=*/-1));
    std::ofstream(*dir_ / "not_pem.txt") << "hello\n";
    std::ofstream(*dir_ / "empty.pem");
    // A key under a passphrase: a service cannot type it at start.
    const std::string encrypted = (*dir_ / "encrypted.key").string();
    ASSERT_EQ(std::system(("openssl pkey -in '" + server_->key.string() + "' -aes256 -passout pass:secret -out '" +
                           encrypted + "' 2>/dev/null")
                              .c_str()),
              0);
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete ca_;
    delete server_;
    delete other_;
    delete expired_;
    delete dir_;
  }
  static fs::path* dir_;
  static CertFiles* ca_;
  static CertFiles* server_;
  static CertFiles* other_;
  static CertFiles* expired_;
};
fs::path* ServerTlsTest::dir_ = nullptr;
CertFiles* ServerTlsTest::ca_ = nullptr;
CertFiles* ServerTlsTest::server_ = nullptr;
CertFiles* ServerTlsTest::other_ = nullptr;
CertFiles* ServerTlsTest::expired_ = nullptr;

TEST_F(ServerTlsTest, RefusesWhatCannotWorkNamingTheFlag) {
  const std::string cert = server_->cert.string();
  const std::string key = server_->key.string();
  const std::string missing = (*dir_ / "missing.pem").string();
  struct Case {
    const char* name;
    ServerTlsOptions options;
    std::string expected;  // substring of the message
  };
  const Case cases[] = {
      {"key without cert", {.key_file = key}, "--tls-key: needs --tls-cert"},
      {"cert without key", {.cert_file = cert}, "--tls-cert: needs --tls-key"},
      {"client CA without cert", {.client_ca_file = ca_->cert.string()}, "--tls-client-ca: needs --tls-cert"},
      {"missing cert", {.cert_file = missing, .key_file = key}, "--tls-cert: " + missing + ": cannot read"},
      {"missing key", {.cert_file = cert, .key_file = missing}, "--tls-key: " + missing + ": cannot read"},
      {"cert is a directory", {.cert_file = dir_->string(), .key_file = key}, "is a directory"},
      {"cert is empty", {.cert_file = (*dir_ / "empty.pem").string(), .key_file = key}, "--tls-cert: " + (*dir_ / "empty.pem").string() + ": is empty"},
      {"cert not PEM", {.cert_file = (*dir_ / "not_pem.txt").string(), .key_file = key}, "--tls-cert: " + (*dir_ / "not_pem.txt").string() + ": holds no PEM certificate"},
      {"key is a certificate", {.cert_file = cert, .key_file = cert}, "--tls-key: " + cert + ": holds no PEM private key"},
      {"encrypted key", {.cert_file = cert, .key_file = (*dir_ / "encrypted.key").string()}, "--tls-key: " + (*dir_ / "encrypted.key").string() + ": is encrypted with a passphrase"},
      {"expired certificate", {.cert_file = expired_->cert.string(), .key_file = expired_->key.string()},
       "--tls-cert: " + expired_->cert.string() + ": expired on "},
      {"key of another certificate", {.cert_file = cert, .key_file = other_->key.string()}, "--tls-cert does not match --tls-key"},
      {"client CA missing", {.cert_file = cert, .key_file = key, .client_ca_file = missing}, "--tls-client-ca: " + missing + ": cannot read"},
      {"client CA not PEM", {.cert_file = cert, .key_file = key, .client_ca_file = (*dir_ / "not_pem.txt").string()}, "--tls-client-ca: "},
      {"reload 0 s", {.cert_file = cert, .key_file = key, .reload_seconds = 0}, "--tls-reload-seconds: 0 is out of range 1..3600"},
      {"reload over an hour", {.reload_seconds = 3601}, "--tls-reload-seconds: 3601 is out of range 1..3600"},
  };
  for (const Case& c : cases) {
    const absl::Status status = ValidateServerTls(c.options);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << c.name << ": " << status;
    EXPECT_NE(status.message().find(c.expected), std::string::npos)
        << c.name << ": expected \"" << c.expected << "\" in: " << status.message();
    EXPECT_FALSE(MakeServerCredentials(c.options).ok()) << c.name;
  }
}

TEST_F(ServerTlsTest, AcceptsPlaintextTlsAndMutualTls) {
  struct Case {
    const char* name;
    ServerTlsOptions options;
  };
  const Case cases[] = {
      {"plaintext", {}},
      {"tls", {.cert_file = server_->cert.string(), .key_file = server_->key.string()}},
      {"mutual tls",
       {.cert_file = server_->cert.string(), .key_file = server_->key.string(), .client_ca_file = ca_->cert.string()}},
      {"reload every hour",
       {.cert_file = server_->cert.string(), .key_file = server_->key.string(), .reload_seconds = 3600}},
  };
  for (const Case& c : cases) {
    EXPECT_TRUE(ValidateServerTls(c.options).ok()) << c.name << ": " << ValidateServerTls(c.options);
    auto credentials = MakeServerCredentials(c.options);
    ASSERT_TRUE(credentials.ok()) << c.name << ": " << credentials.status();
    EXPECT_NE(*credentials, nullptr) << c.name;
    EXPECT_EQ(c.options.enabled(), std::string(c.name) != "plaintext") << c.name;
  }
}

TEST(ServerTlsListen, LoopbackHosts) {
  for (const char* host : {"localhost", "127.0.0.1", "127.1.2.3", "::1", "[::1]", "unix:/run/impostor.sock"}) {
    EXPECT_TRUE(IsLoopbackHost(host)) << host;
  }
  for (const char* host : {"0.0.0.0", "[::]", "", "10.0.0.5", "bake.studio.lan", "128.0.0.1", "localhost.evil", "127.evil.lan"}) {
    EXPECT_FALSE(IsLoopbackHost(host)) << host;
  }
}

TEST_F(ServerTlsTest, LocalWorkerSocketLivesInAPrivateDirectory) {
  const fs::path data = *dir_ / "data";
  fs::create_directories(data / "run");
  fs::permissions(data / "run", fs::perms::all);  // as if left open before
  absl::StatusOr<std::string> socket = PrepareLocalWorkerSocket(data);
  ASSERT_TRUE(socket.ok()) << socket.status();
  EXPECT_EQ(*socket, (data / "run" / "local-workers.sock").string());
  EXPECT_EQ(fs::status(data / "run").permissions() & fs::perms::all, fs::perms::owner_all);

  // A data directory so deep that the socket's path cannot be bound.
  const fs::path deep = *dir_ / std::string(100, 'd');
  absl::StatusOr<std::string> too_long = PrepareLocalWorkerSocket(deep);
  ASSERT_FALSE(too_long.ok());
  EXPECT_EQ(too_long.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(too_long.status().message().find("--data: "), std::string::npos) << too_long.status();
  EXPECT_NE(too_long.status().message().find("(107 bytes)"), std::string::npos) << too_long.status();
}

}  // namespace
}  // namespace impostor
