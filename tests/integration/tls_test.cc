// TLS and mutual TLS on a real farm (issue 14, transport): certificates made
// with the openssl command at test time, real server, worker and CLI
// processes. A bake goes through TLS end to end (worker included);
// plaintext, wrong-CA and certificate-less clients are refused with a
// reason; a rotated certificate is served without a restart; bad flags stop
// each program at start, naming the flag.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "impostor/cache.h"
#include "impostor/client.h"
#include "tests/support/server_process.h"
#include "tests/tls/test_certs.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::BinaryDir;
using testing::CertFiles;
using testing::ChannelTls;
using testing::RunTool;
using testing::ServerProcess;
using testing::TestPki;

const fs::path kBox = "props_pbr/Box/glTF-Binary/Box.glb";

std::string Impostor() { return (BinaryDir() / "impostor").string(); }

int CountLines(const std::string& text) {
  int lines = 0;
  for (char c : text) lines += c == '\n';
  return lines;
}

class TlsFarm : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    pki_dir_ = testing::NewTempDir(std::string("pki_") + info->name());
    TestPki pki(pki_dir_);
    ca_ = pki.MakeCa("farm-ca");
    other_ca_ = pki.MakeCa("other-ca");
    server_ = pki.MakeServerCert("server", ca_);
    client_ = pki.MakeClientCert("artist", ca_);
    foreign_client_ = pki.MakeClientCert("intruder", other_ca_);
    ASSERT_FALSE(foreign_client_.cert.empty()) << "openssl could not make the test certificates";
  }

  std::vector<std::string> TlsFlags(bool mutual) const {
    std::vector<std::string> flags = {"--tls-cert=" + server_.cert.string(), "--tls-key=" + server_.key.string()};
    if (mutual) flags.push_back("--tls-client-ca=" + ca_.cert.string());
    return flags;
  }

  // A short connect timeout: every refusal here is a handshake that fails
  // at once, which Connect reports after about a second anyway.
  static sdk::ClientOptions Options(const std::string& server, const std::string& ca = "",
                                    const CertFiles& client = {}) {
    sdk::ClientOptions o;
    o.server = server;
    o.connect_timeout_seconds = 10;
    o.max_outage_seconds = 0;
    o.tls_ca_file = ca;
    o.tls_cert_file = client.cert.string();
    o.tls_key_file = client.key.string();
    return o;
  }

  fs::path pki_dir_;
  CertFiles ca_, other_ca_, server_, client_, foreign_client_;
};

TEST_F(TlsFarm, BakesThroughTlsWithAWorkerOverTls) {
  ServerProcess server(/*local_workers=*/0, TlsFlags(/*mutual=*/false), ChannelTls{.ca_file = ca_.cert.string()});
  auto worker = testing::StartWorker(server.address(), {"--tls-ca=" + ca_.cert.string(), "--max-jobs=1"});
  ASSERT_TRUE(worker->WaitForLog("event=tls mode=tls")) << worker->Stderr();
  // The test certificate is valid for two days: the server says so at start.
  EXPECT_EQ(server.process().CountInLog("cert_expires="), 1) << server.process().Stderr();
  EXPECT_EQ(server.process().CountInLog("event=tls_cert_expiring_soon"), 1) << server.process().Stderr();

  const fs::path out = testing::NewTempDir("tls_bake_out");
  const testing::ToolRun bake =
      RunTool({Impostor(), "bake", (AssetsDir() / kBox).string(), "--frames=3", "--resolution=64", "--quiet",
               "--out=" + out.string(), "--server=" + server.address(), "--tls-ca=" + ca_.cert.string()});
  ASSERT_EQ(bake.exit_code, 0) << bake.err;
  EXPECT_TRUE(fs::is_regular_file(out / "manifest.json"));
  EXPECT_GT(fs::file_size(out / "albedo_alpha.png"), 0u);
  // The one job went through the TLS worker, which then exits as asked.
  EXPECT_EQ(worker->Wait(), 0) << worker->Stderr();
  EXPECT_EQ(worker->CountInLog("event=lease_failed"), 0) << worker->Stderr();
}

TEST_F(TlsFarm, MutualTlsBakesWithLocalWorkersOnTheirPrivateSocket) {
  ServerProcess server(/*local_workers=*/1, TlsFlags(/*mutual=*/true),
                       ChannelTls{.ca_file = ca_.cert.string(),
                                  .cert_file = client_.cert.string(),
                                  .key_file = client_.key.string()});
  // Local workers need no certificate: they dial a socket only the server's
  // user may reach.
  const fs::path run_dir = server.data_dir() / "run";
  EXPECT_EQ(fs::status(run_dir).permissions() & fs::perms::all, fs::perms::owner_all);
  EXPECT_TRUE(fs::is_socket(run_dir / "local-workers.sock"));

  const fs::path out = testing::NewTempDir("mtls_bake_out");
  const testing::ToolRun bake = RunTool(
      {Impostor(), "bake", (AssetsDir() / kBox).string(), "--frames=3", "--resolution=64", "--quiet",
       "--out=" + out.string(), "--server=" + server.address(), "--tls-ca=" + ca_.cert.string(),
       "--tls-cert=" + client_.cert.string(), "--tls-key=" + client_.key.string()});
  ASSERT_EQ(bake.exit_code, 0) << bake.err;
  EXPECT_GT(fs::file_size(out / "albedo_alpha.png"), 0u);
  EXPECT_GE(server.process().CountInLog("server=unix:" + (run_dir / "local-workers.sock").string()), 1)
      << server.process().Stderr();
}

TEST_F(TlsFarm, MutualTlsRefusesClientsWithoutATrustedCertificate) {
  ServerProcess server(/*local_workers=*/0, TlsFlags(/*mutual=*/true),
                       ChannelTls{.ca_file = ca_.cert.string(),
                                  .cert_file = client_.cert.string(),
                                  .key_file = client_.key.string()});
  struct Case {
    const char* name;
    CertFiles client;
    bool accepted;
  };
  for (const Case& c : {Case{"no client certificate", {}, false},
                        Case{"certificate from another CA", foreign_client_, false},
                        Case{"certificate from the farm's CA", client_, true}}) {
    auto client = sdk::Client::Connect(Options(server.address(), ca_.cert.string(), c.client));
    if (c.accepted) {
      ASSERT_TRUE(client.ok()) << c.name << ": " << client.status();
      // A real answer from the server, through mutual TLS.
      auto job = (*client)->GetJob("no-such-job");
      EXPECT_EQ(job.status().code(), absl::StatusCode::kNotFound) << c.name << ": " << job.status();
      continue;
    }
    ASSERT_FALSE(client.ok()) << c.name;
    EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable) << c.name << ": " << client.status();
    EXPECT_NE(client.status().message().find("TLS handshake failed"), std::string::npos)
        << c.name << ": " << client.status();
  }

  // A worker with a certificate from another CA never gets to lease (the
  // forged-result attack of issue 14 stops at the handshake).
  auto intruder = testing::StartWorker(server.address(),
                                       {"--tls-ca=" + ca_.cert.string(), "--tls-cert=" + foreign_client_.cert.string(),
                                        "--tls-key=" + foreign_client_.key.string(), "--max-outage-seconds=1"});
  EXPECT_EQ(intruder->Wait(), 1) << intruder->Stderr();
  EXPECT_GE(intruder->CountInLog("event=lease_failed"), 1) << intruder->Stderr();
  EXPECT_NE(intruder->Stderr().find("unreachable"), std::string::npos) << intruder->Stderr();

  // The CLI says the same in its one line.
  const testing::ToolRun run =
      RunTool({Impostor(), "status", "j1", "--server=" + server.address(), "--tls-ca=" + ca_.cert.string()});
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_NE(run.err.find("TLS handshake failed"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("--tls-cert"), std::string::npos) << run.err;
  EXPECT_EQ(CountLines(run.err), 1) << run.err;
}

TEST_F(TlsFarm, PlaintextAndWrongCaClientsAreRefusedSayingWhy) {
  ServerProcess server(/*local_workers=*/0, TlsFlags(/*mutual=*/false), ChannelTls{.ca_file = ca_.cert.string()});

  // Plaintext SDK client: refused, and told that the server may want TLS.
  auto plaintext = sdk::Client::Connect(Options(server.address()));
  ASSERT_FALSE(plaintext.ok());
  EXPECT_EQ(plaintext.status().code(), absl::StatusCode::kUnavailable) << plaintext.status();
  EXPECT_NE(plaintext.status().message().find("tls_ca_file"), std::string::npos) << plaintext.status();

  // A raw plaintext gRPC call never gets an answer from a service.
  auto raw = grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials());
  auto stub = v1::BakeService::NewStub(raw);
  v1::GetJobRequest request;
  request.set_job_id("j1");
  v1::Job job;
  auto context = testing::ContextWithin(std::chrono::seconds(10));
  EXPECT_EQ(stub->GetJob(context.get(), request, &job).error_code(), grpc::StatusCode::UNAVAILABLE);

  // A client that trusts another CA.
  auto wrong_ca = sdk::Client::Connect(Options(server.address(), other_ca_.cert.string()));
  ASSERT_FALSE(wrong_ca.ok());
  EXPECT_EQ(wrong_ca.status().code(), absl::StatusCode::kUnavailable) << wrong_ca.status();
  EXPECT_NE(wrong_ca.status().message().find("not signed by the CA"), std::string::npos) << wrong_ca.status();
  EXPECT_NE(wrong_ca.status().message().find("issuer CN=farm-ca"), std::string::npos)
      << "names the issuer it found: " << wrong_ca.status();

  // A certificate name that does not match the name asked for.
  sdk::ClientOptions wrong_name = Options(server.address(), ca_.cert.string());
  wrong_name.tls_server_name = "bake.elsewhere.lan";
  auto misnamed = sdk::Client::Connect(wrong_name);
  ASSERT_FALSE(misnamed.ok());
  EXPECT_NE(misnamed.status().message().find("--tls-server-name"), std::string::npos) << misnamed.status();

  // The CLI: exit 3 and one line that names the fix.
  const testing::ToolRun cli_plain = RunTool({Impostor(), "status", "j1", "--server=" + server.address()});
  EXPECT_EQ(cli_plain.exit_code, 3) << cli_plain.err;
  EXPECT_NE(cli_plain.err.find("--tls-ca"), std::string::npos) << cli_plain.err;
  EXPECT_EQ(CountLines(cli_plain.err), 1) << cli_plain.err;
  const testing::ToolRun cli_wrong_ca = RunTool(
      {Impostor(), "status", "j1", "--server=" + server.address(), "--tls-ca=" + other_ca_.cert.string()});
  EXPECT_EQ(cli_wrong_ca.exit_code, 3) << cli_wrong_ca.err;
  EXPECT_NE(cli_wrong_ca.err.find("certificate verify failed"), std::string::npos) << cli_wrong_ca.err;

  // The right CA: real answers, from the SDK and from the cache.
  auto good = sdk::Client::Connect(Options(server.address(), ca_.cert.string()));
  ASSERT_TRUE(good.ok()) << good.status();
  EXPECT_EQ((*good)->GetJob("j1").status().code(), absl::StatusCode::kNotFound);
  const std::string unknown_key(64, '0');
  for (const bool tls : {false, true}) {
    sdk::CacheOptions options;
    options.server = server.address();
    options.dir = testing::NewTempDir(tls ? "tls_cache" : "plain_cache");
    options.max_outage_seconds = 0;
    options.max_attempts = 1;
    if (tls) options.tls_ca_file = ca_.cert.string();
    auto cache = sdk::Cache::Open(options);
    ASSERT_TRUE(cache.ok()) << cache.status();
    auto got = (*cache)->Get(unknown_key);
    EXPECT_EQ(got.status().code(), tls ? absl::StatusCode::kNotFound : absl::StatusCode::kUnavailable)
        << "tls=" << tls << ": " << got.status();
  }
}

TEST_F(TlsFarm, ServerNameOverrideReachesACertificateIssuedForAnotherName) {
  // A certificate for the farm's DNS name only, dialled by IP address (a
  // tunnel, a host without DNS).
  TestPki pki(pki_dir_);
  const CertFiles named = pki.MakeServerCert("bake-studio-lan", ca_, "DNS:bake.studio.lan");
  ASSERT_FALSE(named.cert.empty());
  ServerProcess server(/*local_workers=*/0,
                       {"--tls-cert=" + named.cert.string(), "--tls-key=" + named.key.string()},
                       ChannelTls{.ca_file = ca_.cert.string(), .server_name = "bake.studio.lan"});

  auto without = sdk::Client::Connect(Options(server.address(), ca_.cert.string()));
  ASSERT_FALSE(without.ok());
  EXPECT_NE(without.status().message().find("tls_server_name"), std::string::npos) << without.status();

  sdk::ClientOptions options = Options(server.address(), ca_.cert.string());
  options.tls_server_name = "bake.studio.lan";
  auto with = sdk::Client::Connect(options);
  ASSERT_TRUE(with.ok()) << with.status();
  EXPECT_EQ((*with)->GetJob("j1").status().code(), absl::StatusCode::kNotFound);

  sdk::CacheOptions cache_options;
  cache_options.server = server.address();
  cache_options.dir = testing::NewTempDir("server_name_cache");
  cache_options.max_outage_seconds = 0;
  cache_options.tls_ca_file = ca_.cert.string();
  cache_options.tls_server_name = "bake.studio.lan";
  auto cache = sdk::Cache::Open(cache_options);
  ASSERT_TRUE(cache.ok()) << cache.status();
  EXPECT_EQ((*cache)->Get(std::string(64, '0')).status().code(), absl::StatusCode::kNotFound);
}

TEST_F(TlsFarm, TlsClientOfAPlaintextServerIsToldItDoesNotSpeakTls) {
  ServerProcess server(/*local_workers=*/0);
  // Plaintext on loopback is the quickstart: no warning.
  EXPECT_EQ(server.process().CountInLog("event=plaintext_listener"), 0) << server.process().Stderr();
  auto client = sdk::Client::Connect(Options(server.address(), ca_.cert.string()));
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable) << client.status();
  EXPECT_NE(client.status().message().find("does not speak TLS"), std::string::npos) << client.status();
}

TEST_F(TlsFarm, PlaintextOnTheNetworkIsWarnedAbout) {
  ServerProcess server(/*local_workers=*/0, testing::NewTempDir("plaintext_network_data"), "0.0.0.0:0");
  EXPECT_EQ(server.process().CountInLog("event=plaintext_listener host=0.0.0.0"), 1) << server.process().Stderr();
}

// Replaces `dest` with `source`'s bytes in one rename, as an operator
// renewing a certificate should.
void ReplaceAtomically(const fs::path& source, const fs::path& dest) {
  const fs::path tmp = dest.string() + ".new";
  fs::copy_file(source, tmp, fs::copy_options::overwrite_existing);
  fs::rename(tmp, dest);
}

TEST_F(TlsFarm, RotatedCertificateIsServedWithoutARestart) {
  const fs::path live = testing::NewTempDir("tls_live");
  fs::copy_file(server_.cert, live / "server.crt");
  fs::copy_file(server_.key, live / "server.key");
  ServerProcess server(/*local_workers=*/0,
                       {"--tls-cert=" + (live / "server.crt").string(), "--tls-key=" + (live / "server.key").string(),
                        "--tls-reload-seconds=1"},
                       ChannelTls{.ca_file = ca_.cert.string()});
  const pid_t pid = server.process().pid();
  ASSERT_TRUE(sdk::Client::Connect(Options(server.address(), ca_.cert.string())).ok());

  // A new certificate from a new CA (as after a CA change), key first.
  TestPki pki(pki_dir_);
  const CertFiles new_ca = pki.MakeCa("farm-ca-2027");
  const CertFiles renewed = pki.MakeServerCert("server-2027", new_ca);
  ASSERT_FALSE(renewed.cert.empty());
  ReplaceAtomically(renewed.key, live / "server.key");
  ReplaceAtomically(renewed.cert, live / "server.crt");

  // A client trusting only the new CA gets in once the server has reloaded;
  // each refused try takes about a second (Connect's wait), so this is a
  // retry with a deadline, not a poll.
  const auto deadline = std::chrono::steady_clock::now() + testing::kStartTimeout;
  absl::Status last;
  int tries = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    ++tries;
    auto client = sdk::Client::Connect(Options(server.address(), new_ca.cert.string()));
    last = client.status();
    if (client.ok()) {
      EXPECT_EQ((*client)->GetJob("j1").status().code(), absl::StatusCode::kNotFound);
      break;
    }
    ASSERT_EQ(last.code(), absl::StatusCode::kUnavailable) << last;
  }
  ASSERT_TRUE(last.ok()) << "the renewed certificate was not served within " << testing::kStartTimeout.count()
                         << " s (" << tries << " tries): " << last;
  // Same process, and the old CA no longer vouches for the server.
  EXPECT_EQ(server.process().pid(), pid);
  EXPECT_TRUE(server.process().Running());
  auto old = sdk::Client::Connect(Options(server.address(), ca_.cert.string()));
  ASSERT_FALSE(old.ok());
  EXPECT_NE(old.status().message().find("not signed by the CA"), std::string::npos) << old.status();
}

TEST_F(TlsFarm, AnExpiredCertificateSwappedInIsNamedByTheServerAndByTheClient) {
  const fs::path live = testing::NewTempDir("tls_expired_live");
  fs::copy_file(server_.cert, live / "server.crt");
  fs::copy_file(server_.key, live / "server.key");
  ServerProcess server(/*local_workers=*/0,
                       {"--tls-cert=" + (live / "server.crt").string(), "--tls-key=" + (live / "server.key").string(),
                        "--tls-reload-seconds=1"},
                       ChannelTls{.ca_file = ca_.cert.string()});
  TestPki pki(pki_dir_);
  const CertFiles expired = pki.MakeServerCert("server-expired", ca_, "DNS:localhost,IP:127.0.0.1", /*days=*/-1);
  ASSERT_FALSE(expired.cert.empty());
  ReplaceAtomically(expired.key, live / "server.key");
  ReplaceAtomically(expired.cert, live / "server.crt");

  // The server says so once it has looked (inotify, bounded).
  ASSERT_TRUE(server.process().WaitForLog("event=tls_cert_expired"))
      << server.process().Stderr();
  // gRPC serves it; a client is told it expired, not that the CA is wrong.
  const auto deadline = std::chrono::steady_clock::now() + testing::kStartTimeout;
  absl::Status last;
  while (std::chrono::steady_clock::now() < deadline) {
    last = sdk::Client::Connect(Options(server.address(), ca_.cert.string())).status();
    ASSERT_FALSE(last.ok());
    if (last.message().find("expired on") != std::string::npos) break;
  }
  EXPECT_NE(last.message().find("the server's certificate expired on"), std::string::npos) << last;
  EXPECT_EQ(last.message().find("not signed by the CA"), std::string::npos) << last;

  // A worker reads the same explanation in its log and its exit.
  auto worker = testing::StartWorker(server.address(), {"--tls-ca=" + ca_.cert.string(), "--max-outage-seconds=1"});
  ASSERT_TRUE(worker->WaitForLog("event=lease_failed")) << worker->Stderr();
  EXPECT_NE(worker->Stderr().find("the server's certificate expired on"), std::string::npos) << worker->Stderr();
}

TEST_F(TlsFarm, BadFlagsStopEachProgramAtStartNamingTheFlag) {
  const fs::path data = testing::NewTempDir("tls_bad_flags_data");
  const fs::path not_pem = pki_dir_ / "not_pem.txt";
  std::ofstream(not_pem) << "not a certificate\n";
  const std::string missing = (pki_dir_ / "missing.crt").string();
  const std::string server_bin = (BinaryDir() / "impostor-server").string();
  const std::string worker_bin = (BinaryDir() / "impostor-worker").string();
  const std::string cert = "--tls-cert=" + server_.cert.string();
  const std::string key = "--tls-key=" + server_.key.string();
  struct Case {
    const char* name;
    std::vector<std::string> argv;
    std::string expected;
  };
  const std::vector<std::string> serve = {server_bin, "--listen=127.0.0.1:0", "--data=" + data.string()};
  auto with = [](std::vector<std::string> base, std::vector<std::string> more) {
    base.insert(base.end(), more.begin(), more.end());
    return base;
  };
  const Case cases[] = {
      {"server: key without cert", with(serve, {key}), "--tls-key: needs --tls-cert"},
      {"server: cert without key", with(serve, {cert}), "--tls-cert: needs --tls-key"},
      {"server: unreadable cert", with(serve, {"--tls-cert=" + missing, key}), "--tls-cert: " + missing + ": cannot read"},
      {"server: cert not matching key", with(serve, {cert, "--tls-key=" + client_.key.string()}),
       "--tls-cert does not match --tls-key"},
      {"server: client CA without cert", with(serve, {"--tls-client-ca=" + ca_.cert.string()}),
       "--tls-client-ca: needs --tls-cert"},
      {"server: client CA not PEM", with(serve, {cert, key, "--tls-client-ca=" + not_pem.string()}),
       "--tls-client-ca: " + not_pem.string() + ": holds no PEM certificate"},
      {"server: reload interval 0", with(serve, {cert, key, "--tls-reload-seconds=0"}),
       "--tls-reload-seconds: 0 is out of range 1..3600"},
      {"worker: cert without key", {worker_bin, "--tls-ca=" + ca_.cert.string(), "--tls-cert=" + client_.cert.string()},
       "--tls-cert: needs --tls-key"},
      {"worker: unreadable CA", {worker_bin, "--tls-ca=" + missing}, "--tls-ca: " + missing + ": cannot read"},
      {"worker: server name without CA", {worker_bin, "--tls-server-name=bake.lan"}, "--tls-server-name: needs --tls-ca"},
      {"cli: unreadable CA", {Impostor(), "status", "j1", "--tls-ca=" + missing}, "--tls-ca: " + missing + ": cannot read"},
      {"cli: key of another certificate",
       {Impostor(), "status", "j1", "--tls-ca=" + ca_.cert.string(), "--tls-cert=" + client_.cert.string(),
        "--tls-key=" + foreign_client_.key.string()},
       "--tls-cert does not match --tls-key"},
  };
  for (const Case& c : cases) {
    const testing::ToolRun run = RunTool(c.argv, std::chrono::seconds(60));
    EXPECT_EQ(run.exit_code, 2) << c.name << ": " << run.err;
    EXPECT_NE(run.err.find(c.expected), std::string::npos) << c.name << ": expected \"" << c.expected << "\" in:\n"
                                                           << run.err;
  }
}

}  // namespace
}  // namespace impostor
