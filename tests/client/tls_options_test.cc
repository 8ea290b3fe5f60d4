// The clients' TLS settings (README "Securing a farm: TLS"): the CLI flags,
// ClientOptions, CacheOptions and the C API refuse what cannot work, naming
// the flag or field, before anything connects.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "client/cli/cli_args.h"
#include "common/net/tls_channel.h"
#include "impostor/cache.h"
#include "impostor/client.h"
#include "impostor/impostor_c.h"
#include "tests/tls/test_certs.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::CertFiles;
using testing::TestPki;

TEST(TlsCliArgs, RefusesFlagsThatCannotWorkTogether) {
  struct Case {
    std::vector<std::string> args;
    std::string expected;
  };
  const Case cases[] = {
      {{"status", "j1", "--tls-cert", "c.pem"}, "--tls-cert: needs --tls-key too"},
      {{"status", "j1", "--tls-key", "k.pem"}, "--tls-key: needs --tls-cert too"},
      {{"status", "j1", "--tls-cert", "c.pem", "--tls-key", "k.pem"}, "need --tls-ca"},
      {{"status", "j1", "--tls-server-name", "bake.lan"}, "--tls-server-name: needs --tls-ca"},
      {{"fetch", std::string(64, 'a'), "--out", "o", "--tls-ca"}, "--tls-ca: missing value"},
      {{"fetch", std::string(64, 'a'), "--out", "o", "--tls-ca", "--json"}, "--tls-ca: missing value"},
      {{"fetch", std::string(64, 'a'), "--out", "o", "--tls-ca="}, "--tls-ca: missing value"},
      // cache ls never talks to the server.
      {{"cache", "ls", "--tls-ca", "ca.pem"}, "unknown flag --tls-ca"},
  };
  for (const Case& c : cases) {
    absl::StatusOr<cli::CliArgs> parsed = cli::ParseCliArgs(c.args, nullptr);
    ASSERT_FALSE(parsed.ok()) << c.args[0] << " " << c.expected;
    EXPECT_NE(parsed.status().message().find(c.expected), std::string::npos)
        << "expected \"" << c.expected << "\" in: " << parsed.status().message();
  }
}

TEST(TlsCliArgs, EveryCommandThatTalksToTheServerTakesTheFlags) {
  const std::vector<std::string> tls = {"--tls-ca", "ca.pem", "--tls-cert=c.pem", "--tls-key", "k.pem",
                                        "--tls-server-name", "bake.lan"};
  const std::vector<std::vector<std::string>> commands = {
      {"bake", "m.glb", "--out", "o"}, {"bake-batch", "s.json", "--out", "o"}, {"fetch", std::string(64, 'a'), "--out", "o"},
      {"quality", std::string(64, 'a')},                {"status", "j"},                        {"cancel", "j"},
      {"cache", "get", "k"}};
  for (std::vector<std::string> args : commands) {
    const std::string name = args[0];
    args.insert(args.end(), tls.begin(), tls.end());
    absl::StatusOr<cli::CliArgs> parsed = cli::ParseCliArgs(args, nullptr);
    ASSERT_TRUE(parsed.ok()) << name << ": " << parsed.status();
    EXPECT_EQ(parsed->tls_ca, "ca.pem") << name;
    EXPECT_EQ(parsed->tls_cert, "c.pem") << name;
    EXPECT_EQ(parsed->tls_key, "k.pem") << name;
    EXPECT_EQ(parsed->tls_server_name, "bake.lan") << name;
  }
  absl::StatusOr<cli::CliArgs> plain = cli::ParseCliArgs({"status", "j"}, nullptr);
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->tls_ca, "");
}

class TlsClientOptionsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("impostor_client_tls_" + std::to_string(::getpid())));
    fs::remove_all(*dir_);
    TestPki pki(*dir_);
    ca_ = new CertFiles(pki.MakeCa("ca"));
    client_ = new CertFiles(pki.MakeClientCert("client", *ca_));
    other_ = new CertFiles(pki.MakeClientCert("other", *ca_));
    expired_ = new CertFiles(pki.MakeClientCert("expired", *ca_, /*days=*/-1));
    std::ofstream(*dir_ / "not_pem.txt") << "hello\n";
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete ca_;
    delete client_;
    delete other_;
    delete expired_;
    delete dir_;
  }

  // One bad setting per case; `field` is "tls_ca_file" etc. and `expected`
  // what the message says after the field's owner ("ClientOptions.").
  struct Case {
    const char* name;
    std::string ca, cert, key, server_name;
    std::string expected;
  };
  static std::vector<Case> BadCases() {
    const std::string missing = (*dir_ / "missing.pem").string();
    const std::string not_pem = (*dir_ / "not_pem.txt").string();
    return {
        {"CA missing", missing, "", "", "", "tls_ca_file: " + missing + ": cannot read"},
        {"CA not PEM", not_pem, "", "", "", "tls_ca_file: " + not_pem + ": holds no PEM certificate"},
        {"cert without key", ca_->cert.string(), client_->cert.string(), "", "", "tls_cert_file: needs"},
        {"key without cert", ca_->cert.string(), "", client_->key.string(), "", "tls_key_file: needs"},
        {"cert and key without CA", "", client_->cert.string(), client_->key.string(), "", "tls_ca_file"},
        {"server name without CA", "", "", "", "bake.lan", "tls_server_name: needs"},
        {"key of another certificate", ca_->cert.string(), client_->cert.string(), other_->key.string(), "",
         "tls_cert_file does not match"},
        {"expired client certificate", ca_->cert.string(), expired_->cert.string(), expired_->key.string(), "",
         "tls_cert_file: " + expired_->cert.string() + ": expired on "},
        {"cert missing", ca_->cert.string(), missing, client_->key.string(), "", "tls_cert_file: " + missing},
    };
  }

  static fs::path* dir_;
  static CertFiles* ca_;
  static CertFiles* client_;
  static CertFiles* other_;
  static CertFiles* expired_;
};
fs::path* TlsClientOptionsTest::dir_ = nullptr;
CertFiles* TlsClientOptionsTest::ca_ = nullptr;
CertFiles* TlsClientOptionsTest::client_ = nullptr;
CertFiles* TlsClientOptionsTest::other_ = nullptr;
CertFiles* TlsClientOptionsTest::expired_ = nullptr;

TEST_F(TlsClientOptionsTest, ClientConnectRefusesBadSettingsNamingTheField) {
  for (const Case& c : BadCases()) {
    sdk::ClientOptions options;
    // Nothing listens there: the settings must be refused before dialling.
    options.server = "127.0.0.1:1";
    options.tls_ca_file = c.ca;
    options.tls_cert_file = c.cert;
    options.tls_key_file = c.key;
    options.tls_server_name = c.server_name;
    auto client = sdk::Client::Connect(options);
    ASSERT_FALSE(client.ok()) << c.name;
    EXPECT_EQ(client.status().code(), absl::StatusCode::kInvalidArgument) << c.name << ": " << client.status();
    EXPECT_NE(client.status().message().find("ClientOptions." + c.expected), std::string::npos)
        << c.name << ": " << client.status().message();
  }
}

TEST_F(TlsClientOptionsTest, CacheOpenRefusesBadSettingsNamingTheField) {
  for (const Case& c : BadCases()) {
    sdk::CacheOptions options;
    options.dir = *dir_ / "cache";
    options.tls_ca_file = c.ca;
    options.tls_cert_file = c.cert;
    options.tls_key_file = c.key;
    options.tls_server_name = c.server_name;
    auto cache = sdk::Cache::Open(options);
    ASSERT_FALSE(cache.ok()) << c.name;
    EXPECT_EQ(cache.status().code(), absl::StatusCode::kInvalidArgument) << c.name << ": " << cache.status();
    EXPECT_NE(cache.status().message().find("CacheOptions." + c.expected), std::string::npos)
        << c.name << ": " << cache.status().message();
  }
}

TEST_F(TlsClientOptionsTest, CApiRefusesBadSettingsNamingTheField) {
  const std::string cache_dir = (*dir_ / "c_cache").string();
  for (const Case& c : BadCases()) {
    impostor_cache_options o;
    impostor_cache_options_init(&o);
    EXPECT_EQ(o.tls_ca_file, nullptr);
    EXPECT_EQ(o.tls_server_name, nullptr);
    o.dir = cache_dir.c_str();
    o.tls_ca_file = c.ca.empty() ? nullptr : c.ca.c_str();
    o.tls_cert_file = c.cert.empty() ? nullptr : c.cert.c_str();
    o.tls_key_file = c.key.empty() ? nullptr : c.key.c_str();
    o.tls_server_name = c.server_name.empty() ? nullptr : c.server_name.c_str();
    impostor_cache* cache = nullptr;
    EXPECT_EQ(impostor_cache_open(&o, &cache), IMPOSTOR_INVALID_ARGUMENT) << c.name;
    EXPECT_EQ(cache, nullptr) << c.name;
    EXPECT_NE(std::string(impostor_last_error()).find(c.expected), std::string::npos)
        << c.name << ": " << impostor_last_error();
    impostor_cache_close(cache);
  }
}

TEST_F(TlsClientOptionsTest, GoodSettingsOpenACacheWithoutContactingTheServer) {
  struct Good {
    const char* name;
    std::string ca, cert, key, server_name;
  };
  for (const Good& g : {Good{"plaintext", "", "", "", ""}, Good{"tls", ca_->cert.string(), "", "", ""},
                        Good{"mutual tls", ca_->cert.string(), client_->cert.string(), client_->key.string(), ""},
                        Good{"server name", ca_->cert.string(), "", "", "bake.lan"}}) {
    sdk::CacheOptions options;
    options.server = "127.0.0.1:1";
    options.dir = *dir_ / "good_cache";
    options.tls_ca_file = g.ca;
    options.tls_cert_file = g.cert;
    options.tls_key_file = g.key;
    options.tls_server_name = g.server_name;
    auto cache = sdk::Cache::Open(options);
    EXPECT_TRUE(cache.ok()) << g.name << ": " << cache.status();
    // The channel credentials the SDK builds from the same settings.
    grpc::ChannelArguments args;
    auto credentials = MakeChannelCredentials({.files = {.ca = g.ca, .cert = g.cert, .key = g.key},
                                               .server_name = g.server_name},
                                              {.files = {.ca = "ca", .cert = "cert", .key = "key"},
                                               .server_name = "name"},
                                              &args);
    EXPECT_TRUE(credentials.ok()) << g.name << ": " << credentials.status();
  }
}

}  // namespace
}  // namespace impostor
