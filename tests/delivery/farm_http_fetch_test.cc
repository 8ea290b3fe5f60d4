// A farm result's large files over the farm's HTTP front end
// (ClientOptions::farm_http, client/transfer/farm_http_fetch.h), without a
// GPU: results put into a real impostor-server with --http-listen
// (tests/support/published_result.h), fetched with FetchResultFiles, the
// cache and the CLI. Which road each file took is counted on the wire: the
// ReadBlob RPCs the transport started, and the requests an in-process front
// end that misbehaves on purpose (fault_mirror.h) answered. Every bad answer
// moves the file to gRPC, and nothing unverified is installed.
#include <gtest/gtest.h>
#include <httplib.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <thread>

#include "client/cache/cache_testing.h"
#include "client/transfer/farm_http_fetch.h"
#include "client/transfer/result_fetch.h"
#include "client/transport/farm_http_url.h"
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/cache.h"
#include "impostor/impostor_c.h"
#include "tests/delivery/farm_http_fixture.h"
#include "tests/delivery/fault_mirror.h"
#include "tests/metrics/http_test_client.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

TEST_F(FarmHttpTest, FetchTakesTheLargeFilesFromTheFrontEndAndTheSmallOnesInOneBatch) {
  // Without a front end both large files stream over ReadBlob: the count
  // below is not zero for want of counting.
  EXPECT_EQ(FetchCountingReadBlobs("none"), 2);
  EXPECT_EQ(FetchCountingReadBlobs(http_url_), 0);
  EXPECT_EQ(FetchCountingReadBlobs(http_url_ + "/"), 0) << "a trailing slash on the base URL";
}

TEST_F(FarmHttpTest, AFileReachesItsSinkInPiecesOfAtLeast256KiBFromTheOffsetAsked) {
  absl::StatusOr<std::unique_ptr<sdk::Transport>> transport = sdk::Transport::Connect(Options(http_url_));
  ASSERT_TRUE(transport.ok()) << transport.status();
  const std::string& bytes = result_.files.at("albedo_alpha.png");
  v1::Digest digest;
  digest.set_hash(Sha256Hex(bytes));
  digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  for (const int64_t offset : {int64_t{0}, int64_t{700'001}}) {
    SCOPED_TRACE(offset);
    Sha256 hash;
    hash.Update(std::string_view(bytes).substr(0, static_cast<size_t>(offset)));
    std::string got;
    std::vector<size_t> pieces;
    const absl::Status read = sdk::ReadResultFileOverHttp(**transport, result_.key, "albedo_alpha.png", digest, offset,
                                                          hash, [&](std::string_view data) {
                                                            pieces.push_back(data.size());
                                                            got.append(data);
                                                            return absl::OkStatus();
                                                          },
                                                          nullptr);
    ASSERT_TRUE(read.ok()) << read;
    EXPECT_EQ(got, bytes.substr(static_cast<size_t>(offset)));
    ASSERT_FALSE(pieces.empty());
    // Each piece but the last is 256 KiB and at most one of libcurl's
    // pieces (16 KiB) more; ~6 in all rather than ~90.
    for (size_t i = 0; i + 1 < pieces.size(); ++i) {
      EXPECT_GE(pieces[i], size_t{256} << 10) << "piece " << i;
      EXPECT_LE(pieces[i], (size_t{256} << 10) + (size_t{16} << 10)) << "piece " << i;
    }
    EXPECT_LE(pieces.size(), got.size() / (size_t{256} << 10) + 1);
  }
  // A wrong digest: DATA_LOSS, after the sink saw every byte the hash did.
  digest.set_hash(std::string(64, '0'));
  Sha256 hash;
  size_t seen = 0;
  const absl::Status bad = sdk::ReadResultFileOverHttp(**transport, result_.key, "albedo_alpha.png", digest, 0, hash,
                                                       [&](std::string_view data) {
                                                         seen += data.size();
                                                         return absl::OkStatus();
                                                       },
                                                       nullptr);
  EXPECT_EQ(bad.code(), absl::StatusCode::kDataLoss) << bad;
  EXPECT_EQ(seen, bytes.size());
}

TEST_F(FarmHttpTest, EveryBadFrontEndAnswerMovesTheFileToGrpcAndNothingBadIsInstalled) {
  std::unique_ptr<FaultMirror> front = StartFaultyFrontEnd();
  const std::string base = front->url() + "/v1/farm";
  struct Case {
    Fault albedo, normal;
  };
  for (const Case& c : {Case{Fault::kFlipByte, Fault::kHtml200}, Case{Fault::kTruncate, Fault::kNotFound},
                        Case{Fault::kStall, Fault::kNone}}) {
    SCOPED_TRACE(::testing::Message() << "faults " << static_cast<int>(c.albedo) << ", " << static_cast<int>(c.normal));
    front->SetFault(MirrorFilePath("albedo_alpha.png"), c.albedo);
    front->SetFault(MirrorFilePath("normal_depth.png"), c.normal);
    const int before = front->Requests(MirrorFilePath("normal_depth.png"));
    EXPECT_EQ(FetchCountingReadBlobs(base), c.normal == Fault::kNone ? 1 : 2);
    EXPECT_GT(front->Requests(MirrorFilePath("normal_depth.png")), before) << "the front end was asked first";
  }
  EXPECT_EQ(front->Requests(MirrorFilePath("orm.png")), 0) << "a small file came over HTTP, not in the batch";
  EXPECT_EQ(front->Requests(MirrorFilePath("manifest.json")), 0);
}

// One transport fetching the result again and again (a batch's downloads):
// a front end that fails every file is given up after three in a row; one
// that gives a file now and then is kept.
TEST_F(FarmHttpTest, AFrontEndThatFailsThreeFilesInARowIsGivenUpAndOneThatGivesSomeIsKept) {
  std::unique_ptr<FaultMirror> front = StartFaultyFrontEnd();
  for (const bool albedo_good : {false, true}) {
    SCOPED_TRACE(albedo_good ? "albedo served, normal 404" : "both 404");
    front->SetFault(MirrorFilePath("albedo_alpha.png"), albedo_good ? Fault::kNone : Fault::kNotFound);
    front->SetFault(MirrorFilePath("normal_depth.png"), Fault::kNotFound);
    auto read_blobs = std::make_shared<std::atomic<int>>(0);
    sdk::TransportHooks hooks;
    hooks.on_rpc = [read_blobs](const std::string& method) {
      if (method == kReadBlob) read_blobs->fetch_add(1);
    };
    absl::StatusOr<std::unique_ptr<sdk::Transport>> transport =
        sdk::Transport::Connect(Options(front->url() + "/v1/farm"), hooks);
    ASSERT_TRUE(transport.ok()) << transport.status();
    const int asked_before = front->TotalRequests();
    for (int i = 0; i < 4; ++i) {
      const fs::path out = dir_ / ("again" + std::to_string(++fetches_));
      absl::StatusOr<sdk::FetchResult> fetched = sdk::FetchResultFiles(**transport, result_.key, out, 1);
      ASSERT_TRUE(fetched.ok()) << fetched.status();
      ExpectFilesAre(out);
    }
    if (albedo_good) {
      EXPECT_EQ(front->TotalRequests() - asked_before, 8) << "every large file of the 4 fetches was asked";
      EXPECT_EQ(read_blobs->load(), 4) << "only the 404s came over ReadBlob";
    } else {
      EXPECT_EQ(front->TotalRequests() - asked_before, sdk::kFarmHttpFailuresToGiveUp);
      EXPECT_EQ(read_blobs->load(), 8);
      EXPECT_FALSE(sdk::UsesFarmHttp(**transport));
    }
  }
}

TEST_F(FarmHttpTest, AFrontEndThatIsDownOrRefusesTheTokenLeavesTheFilesToGrpc) {
  // Nothing listens on port 1.
  EXPECT_EQ(FetchCountingReadBlobs("http://127.0.0.1:1"), 2);

  // A front end that wants the farm's token as a bearer header, as the
  // farm's own does with --auth token.
  httplib::Server front;
  std::atomic<int> refused{0};
  front.Get(R"(/api/v1/results/([0-9a-f]{64})/files/([^/]+))", [&](const httplib::Request& req,
                                                                  httplib::Response& res) {
    if (req.get_header_value("Authorization") != "Bearer the-farm-token") {
      refused.fetch_add(1);
      res.status = 401;
      res.set_content("{\"error\":\"unauthenticated\"}", "application/json");
      return;
    }
    auto it = result_.files.find(req.matches[2]);
    if (req.matches[1] != result_.key || it == result_.files.end()) {
      res.status = 404;
      return;
    }
    res.set_content(it->second, "image/png");
  });
  front.set_keep_alive_timeout(1);  // stop() waits for idle connections
  const int port = front.bind_to_any_port("127.0.0.1");
  std::thread serving([&] { front.listen_after_bind(); });
  const std::string base = "http://127.0.0.1:" + std::to_string(port);
  EXPECT_EQ(FetchCountingReadBlobs(base, "the-farm-token"), 0);
  EXPECT_EQ(refused.load(), 0);
  EXPECT_EQ(FetchCountingReadBlobs(base, "another-token"), 2);
  EXPECT_EQ(refused.load(), 2) << "each large file was asked once with the wrong token, then taken over gRPC";
  front.stop();
  serving.join();
}

TEST_F(FarmHttpTest, CacheGetInstallsFromTheFrontEndAndFallsBackOnABadByte) {
  std::unique_ptr<FaultMirror> front = StartFaultyFrontEnd();
  for (const bool flip : {false, true}) {
    SCOPED_TRACE(flip ? "a flipped byte in the front end's albedo" : "a good front end");
    front->SetFault(MirrorFilePath("albedo_alpha.png"), flip ? Fault::kFlipByte : Fault::kNone);
    sdk::CacheOptions o;
    o.server = server_->address();
    o.dir = dir_ / (flip ? "cache-flip" : "cache");
    o.rpc_timeout_seconds = 1;
    o.max_attempts = 2;
    o.max_outage_seconds = 0;
    o.farm_http = front->url() + "/v1/farm";
    auto read_blobs = std::make_shared<std::atomic<int>>(0);
    sdk::CacheTestHooks hooks;
    hooks.transport.on_rpc = [read_blobs](const std::string& method) {
      if (method == kReadBlob) read_blobs->fetch_add(1);
    };
    const int asked_before = front->TotalRequests();
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::CacheFactory::Open(o, hooks);
    ASSERT_TRUE(cache.ok()) << cache.status();
    absl::StatusOr<sdk::CachedResult> got = (*cache)->Get(result_.key);
    ASSERT_TRUE(got.ok()) << got.status();
    for (const sdk::CachedFile& f : got->files()) {
      const std::string bytes = ReadFileBytes(f.path);
      EXPECT_EQ(Sha256Hex(bytes), f.sha256) << f.path;
      EXPECT_EQ(bytes, result_.files.at(f.path.filename().string())) << f.path;
    }
    EXPECT_EQ(read_blobs->load(), flip ? 1 : 0) << "only the file the front end spoiled came over ReadBlob";
    // Over HTTP alone (result_install.h's InstallOverFarmHttp): the
    // listing and every file, each asked once.
    EXPECT_EQ(front->TotalRequests() - asked_before, 1 + static_cast<int>(result_.files.size()));
    EXPECT_EQ(front->Requests(MirrorListingPath()), flip ? 2 : 1);
  }
}

TEST_F(FarmHttpTest, TheCliFetchesOverTheFrontEndAndRefusesABadUrlNamingIt) {
  const fs::path out = dir_ / "cli";
  ToolRun run = RunTool({(BinaryDir() / "impostor").string(), "fetch", result_.key, "--server", server_->address(),
                         "--farm-http", http_url_, "--out", out.string(), "--quiet"},
                        std::chrono::seconds(120));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ExpectFilesAre(out);
  EXPECT_EQ(run.err.find("farm_http_fallback"), std::string::npos) << run.err;

  run = RunTool({(BinaryDir() / "impostor").string(), "fetch", result_.key, "--server", server_->address(),
                 "--farm-http", "ftp://127.0.0.1/x", "--out", (dir_ / "cli-bad").string()},
                std::chrono::seconds(60));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("farm_http"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("is not an http:// or https:// URL"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir_ / "cli-bad" / "manifest.json"));

  run = RunTool({(BinaryDir() / "impostor").string(), "fetch", result_.key, "--server", server_->address(),
                 "--farm-http"},
                std::chrono::seconds(60));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("--farm-http: missing value"), std::string::npos) << run.err;

  // $IMPOSTOR_FARM_HTTP when the flag is not given, named when it is bad.
  run = RunTool({"/usr/bin/env", "IMPOSTOR_FARM_HTTP=http://", (BinaryDir() / "impostor").string(), "fetch",
                 result_.key, "--server", server_->address(), "--out", (dir_ / "cli-env").string()},
                std::chrono::seconds(60));
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.err.find("$IMPOSTOR_FARM_HTTP: \"http://\" names no host"), std::string::npos) << run.err;
}

TEST_F(FarmHttpTest, BadFarmHttpOptionsAreRefusedNamingTheFieldAndTheLimit) {
  struct Bad {
    std::string url, says;
  };
  const std::vector<Bad> bad = {
      {"ftp://farm/", "is not an http:// or https:// URL"},
      {"farm:8080", "is not an http:// or https:// URL"},
      {"http://", "names no host"},
      {"http:///api", "names no host"},
      {"http://farm:8080/x?y=1", "has a query or a fragment"},
      {"http://user:secret@farm:8080", "carries credentials"},
      {"http://farm 8080", "a space, a control or a non-ASCII character"},
      {"http://farm/\x7f", "a space, a control or a non-ASCII character"},
      {"http://farm/" + std::string(2100, 'a'), "over the limit of 2048"},
  };
  for (const Bad& b : bad) {
    absl::StatusOr<std::unique_ptr<sdk::Transport>> t = sdk::Transport::Connect(Options(b.url));
    ASSERT_FALSE(t.ok()) << b.url;
    EXPECT_EQ(t.status().code(), absl::StatusCode::kInvalidArgument) << b.url;
    EXPECT_NE(t.status().message().find("ClientOptions.farm_http: "), std::string::npos) << t.status();
    EXPECT_NE(t.status().message().find(b.says), std::string::npos) << t.status();

    sdk::CacheOptions c;
    c.server = server_->address();
    c.dir = dir_ / "cache-bad";
    c.farm_http = b.url;
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(c);
    ASSERT_FALSE(cache.ok()) << b.url;
    EXPECT_EQ(cache.status().code(), absl::StatusCode::kInvalidArgument) << b.url;
    EXPECT_NE(cache.status().message().find("CacheOptions.farm_http: "), std::string::npos) << cache.status();
  }
  // A TLS farm's token must not cross in clear; https is fine.
  EXPECT_NE(ValidateFarmHttpBase("http://farm:8080", /*tls=*/true).message().find("plaintext"),
            absl::string_view::npos);
  EXPECT_TRUE(ValidateFarmHttpBase("https://farm.example/impostor", /*tls=*/true).ok());
  // "none" turns the environment's front end off.
  EXPECT_EQ(FetchCountingReadBlobs("none"), 2);
}

TEST_F(FarmHttpTest, TheCApiTakesTheFrontEndAndRefusesABadOne) {
  std::unique_ptr<FaultMirror> front = StartFaultyFrontEnd();
  const std::string base = front->url() + "/v1/farm";
  const std::string server = server_->address();
  const std::string dir = (dir_ / "c-cache").string();
  impostor_cache_options o;
  impostor_cache_options_init(&o);
  o.server = server.c_str();
  o.dir = dir.c_str();
  o.rpc_timeout_seconds = 1;
  impostor_cache_options_ext ext;
  impostor_cache_options_ext_init(&ext);
  EXPECT_EQ(ext.farm_http, nullptr) << "init leaves it to $IMPOSTOR_FARM_HTTP";
  ext.farm_http = base.c_str();
  impostor_cache* cache = nullptr;
  ASSERT_EQ(impostor_cache_open_ext(&o, &ext, &cache), IMPOSTOR_OK) << impostor_last_error();
  impostor_result* got = nullptr;
  ASSERT_EQ(impostor_cache_get(cache, result_.key.c_str(), &got), IMPOSTOR_OK) << impostor_last_error();
  EXPECT_EQ(ReadFileBytes(impostor_result_map_path(got, "normal_depth")), result_.files.at("normal_depth.png"));
  impostor_result_release(got);
  impostor_cache_close(cache);
  EXPECT_EQ(front->Requests(MirrorFilePath("albedo_alpha.png")), 1);
  EXPECT_EQ(front->Requests(MirrorFilePath("normal_depth.png")), 1);

  ext.farm_http = "http://farm:8080/?token=x";
  EXPECT_EQ(impostor_cache_open_ext(&o, &ext, &cache), IMPOSTOR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(impostor_last_error()).find("CacheOptions.farm_http: "), std::string::npos)
      << impostor_last_error();
}

// impostor-server --http-advertise: the farm names its front end on every
// GetResult answer, and a client told nothing about it (no farm_http, no
// $IMPOSTOR_FARM_HTTP) takes the large files from there; "none" keeps them
// on gRPC. The advertised front end is the test's own (a FaultMirror
// holding the same result), so which road each file took shows in its
// request counts and in the ReadBlob streams.
TEST_F(FarmHttpTest, AFrontEndTheFarmAdvertisesIsUsedUnlessTurnedOff) {
  ::unsetenv(sdk::kFarmHttpEnvVar);
  std::unique_ptr<FaultMirror> front = StartFaultyFrontEnd();
  const std::string base = front->url() + "/v1/farm";
  ServerProcess advertising(0, {"--http-listen", "127.0.0.1:0", "--http-advertise=" + base + "/"});
  const PublishedResult same = PublishResult(advertising, kMapSizes, 41);
  ASSERT_EQ(same.key, result_.key) << "the same seed makes the same result on both farms";
  ASSERT_EQ(same.files, result_.files);

  EXPECT_EQ(FetchCountingReadBlobs("", "", advertising.address()), 0) << "the large files came over HTTP";
  EXPECT_EQ(front->Requests(MirrorFilePath("albedo_alpha.png")), 1);
  EXPECT_EQ(front->Requests(MirrorFilePath("normal_depth.png")), 1);

  EXPECT_EQ(FetchCountingReadBlobs("none", "", advertising.address()), 2) << "none: both over ReadBlob";
  ::setenv(sdk::kFarmHttpEnvVar, "none", 1);
  EXPECT_EQ(FetchCountingReadBlobs("", "", advertising.address()), 2) << "$IMPOSTOR_FARM_HTTP=none too";
  ::unsetenv(sdk::kFarmHttpEnvVar);
  EXPECT_EQ(front->TotalRequests(), 2) << "nothing more asked of the front end once turned off";

  // A farm that advertises nothing: gRPC, as before.
  EXPECT_EQ(FetchCountingReadBlobs(""), 2);

  // The cache learns it from the same answer.
  sdk::CacheOptions o;
  o.server = advertising.address();
  o.dir = dir_ / "cache";
  o.rpc_timeout_seconds = 1;
  o.max_attempts = 2;
  o.max_outage_seconds = 0;
  auto read_blobs = std::make_shared<std::atomic<int>>(0);
  sdk::CacheTestHooks hooks;
  hooks.transport.on_rpc = [read_blobs](const std::string& method) {
    if (method == kReadBlob) read_blobs->fetch_add(1);
  };
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::CacheFactory::Open(o, hooks);
  ASSERT_TRUE(cache.ok()) << cache.status();
  absl::StatusOr<sdk::CachedResult> got = (*cache)->Get(result_.key);
  ASSERT_TRUE(got.ok()) << got.status();
  for (const sdk::CachedFile& f : got->files()) {
    EXPECT_EQ(ReadFileBytes(f.path), result_.files.at(f.path.filename().string())) << f.path;
  }
  EXPECT_EQ(read_blobs->load(), 0);
  EXPECT_EQ(front->TotalRequests(), 4) << "the cache asked the front end for the two large files";
  cache->reset();
  const fs::path data = advertising.data_dir();
  fs::remove_all(data);
}

TEST(FarmHttpAdvertise, BadValuesStopTheStartNamingTheFlag) {
  const fs::path dir = NewTempDir("farm_http_advertise_flags");
  struct Case {
    std::string what;
    std::vector<std::string> args;
    std::vector<std::string> says;
  };
  const std::vector<Case> cases = {
      {"no --http-listen", {"--http-advertise=http://farm:8080"}, {"--http-advertise", "needs --http-listen"}},
      {"not http", {"--http-listen=127.0.0.1:0", "--http-advertise=ftp://farm"}, {"--http-advertise", "http://"}},
      {"no host", {"--http-listen=127.0.0.1:0", "--http-advertise=https://"}, {"--http-advertise", "names no host"}},
      {"a query", {"--http-listen=127.0.0.1:0", "--http-advertise=http://farm/?token=x"},
       {"--http-advertise", "query"}},
      {"credentials", {"--http-listen=127.0.0.1:0", "--http-advertise=http://user:pw@farm"},
       {"--http-advertise", "credentials"}},
      {"too long", {"--http-listen=127.0.0.1:0", "--http-advertise=http://farm/" + std::string(2100, 'a')},
       {"--http-advertise", "over the limit of 2048"}},
  };
  for (const Case& c : cases) {
    std::vector<std::string> argv = {(BinaryDir() / "impostor-server").string(), "--listen=127.0.0.1:0",
                                     "--data=" + (dir / "data").string()};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const ToolRun run = RunTool(argv, std::chrono::seconds(60));
    EXPECT_EQ(run.exit_code, 2) << c.what << ": " << run.err;
    for (const std::string& text : c.says) {
      EXPECT_NE(run.err.find(text), std::string::npos) << c.what << ": stderr does not say " << text << ":\n"
                                                       << run.err;
    }
    EXPECT_EQ(run.out.find("listening on"), std::string::npos) << c.what;
  }
  fs::remove_all(dir);
}

TEST(FarmHttpUrl, AnAdvertisedFrontEndIsCheckedAsAConfiguredOne) {
  absl::StatusOr<std::string> ok = sdk::AdvertisedFarmHttp("https://farm.example/impostor/", /*tls=*/true);
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(*ok, "https://farm.example/impostor");
  absl::StatusOr<std::string> plain = sdk::AdvertisedFarmHttp("http://farm:8080", /*tls=*/true);
  EXPECT_EQ(plain.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(plain.status().message().find("plaintext"), absl::string_view::npos) << plain.status();
  EXPECT_TRUE(sdk::AdvertisedFarmHttp("http://farm:8080", /*tls=*/false).ok());
  for (const char* bad : {"", "farm:8080", "ftp://farm", "http://farm/?a=b", "http://u@farm", "http://fa rm"}) {
    EXPECT_EQ(sdk::AdvertisedFarmHttp(bad, false).status().code(), absl::StatusCode::kInvalidArgument) << bad;
  }
  EXPECT_TRUE(sdk::FarmHttpTurnedOff("none", nullptr));
  EXPECT_TRUE(sdk::FarmHttpTurnedOff("", "none"));
  EXPECT_FALSE(sdk::FarmHttpTurnedOff("", nullptr));
  EXPECT_FALSE(sdk::FarmHttpTurnedOff("", ""));
  EXPECT_FALSE(sdk::FarmHttpTurnedOff("http://farm", "none")) << "the option wins over the variable";
}

TEST(FarmHttpUrl, ResultFileUrlsEscapeEverythingButUnreservedCharacters) {
  const std::string key(64, 'a');
  EXPECT_EQ(sdk::ResultFileUrl("http://farm:8080", key, "albedo_alpha.png"),
            "http://farm:8080/api/v1/results/" + key + "/files/albedo_alpha.png");
  EXPECT_EQ(sdk::ResultFileUrl("https://farm/impostor/", key, "a b%#?é.png"),
            "https://farm/impostor/api/v1/results/" + key + "/files/a%20b%25%23%3F%C3%A9.png");
}

}  // namespace
}  // namespace impostor::testing
