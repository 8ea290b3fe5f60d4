// A farm result fetched over the farm's HTTP front end alone
// (client/transfer/farm_http_result_fetch.h, sdk::FetchFromFarm,
// `impostor fetch --farm-http`): the listing the front end serves
// (/api/v1/results/KEY/manifest), a fetch that needs no gRPC server at all,
// every way the front end can fail sending the whole result over gRPC, and
// what is not sent there (a local failure). Without a GPU: results put into a
// real impostor-server (tests/delivery/farm_http_fixture.h).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "client/transfer/farm_http_result_fetch.h"
#include "common/net/farm_http_base.h"
#include "impostor/cache.h"
#include "impostor/client.h"
#include "tests/delivery/farm_http_fixture.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

// A port nothing listens on: a fetch that needs gRPC there fails.
constexpr char kNoGrpcServer[] = "127.0.0.1:1";

sdk::FarmHttpEndpoint FrontEnd(const std::string& base) {
  sdk::FarmHttpEndpoint front_end;
  front_end.base = base;
  front_end.read.stall_seconds = 5;
  front_end.read.max_attempts = 1;
  return front_end;
}

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

class FarmHttpOnlyTest : public FarmHttpTest {
 protected:
  // The result's last use as the farm's results listing reports it.
  int64_t LastUsedMs() {
    HttpTestClient http(HttpPort());
    auto res = http.Get("/api/v1/results");
    EXPECT_TRUE(res && res->status == 200) << (res ? res->status : -1) << " " << (res ? res->body : "");
    if (!res || res->status != 200) return -1;
    const nlohmann::json listed = nlohmann::json::parse(res->body);
    for (const auto& r : listed["results"]) {
      if (r["cache_key"] == result_.key) return r["last_used_ms"].get<int64_t>();
    }
    ADD_FAILURE() << "the result is not listed: " << res->body;
    return -1;
  }
  int HttpPort() const { return std::stoi(http_url_.substr(http_url_.rfind(':') + 1)); }

  // FetchFromFarm into a fresh folder with no gRPC server where options
  // point, unless `server` names one.
  absl::StatusOr<sdk::FetchResult> Fetch(const std::string& farm_http, const std::string& server = kNoGrpcServer,
                                         fs::path* out_dir = nullptr) {
    sdk::ClientOptions o = Options(farm_http);
    o.server = server;
    o.connect_timeout_seconds = 5;
    const fs::path out = dir_ / ("only" + std::to_string(++fetches_));
    if (out_dir != nullptr) *out_dir = out;
    return sdk::FetchFromFarm(o, result_.key, out);
  }
};

TEST_F(FarmHttpOnlyTest, TheListingOverHttpIsGetResultsAnswerWithItsDigest) {
  const std::string listing = ListingBytes();
  ASSERT_FALSE(listing.empty());
  absl::StatusOr<v1::Manifest> got = sdk::GetResultOverHttp(FrontEnd(http_url_), result_.key);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(got->SerializeAsString(), listing);

  HttpTestClient http(HttpPort());
  auto res = http.Get("/api/v1/results/" + result_.key + "/manifest");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->get_header_value("Content-Type"), kResultManifestMediaType);
  EXPECT_EQ(res->get_header_value("Cache-Control"), "no-store");
  EXPECT_EQ(res->get_header_value(kReprDigestHeader), ReprDigestSha256(res->body));
  EXPECT_EQ(res->body, listing);

  // Bad keys: refused before a request, and by the farm naming the field.
  absl::StatusOr<v1::Manifest> bad = sdk::GetResultOverHttp(FrontEnd(http_url_), "../../jobs");
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument) << bad.status();
  EXPECT_NE(bad.status().message().find("cache_key: expected 64 lowercase hex"), std::string::npos) << bad.status();
  res = http.Get("/api/v1/results/not-a-key/manifest");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 400);
  EXPECT_NE(res->body.find("cache_key"), std::string::npos) << res->body;
  // A result that is not there: NOT_FOUND with the farm's own words.
  const std::string absent(64, 'a');
  bad = sdk::GetResultOverHttp(FrontEnd(http_url_), absent);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kNotFound) << bad.status();
  EXPECT_NE(bad.status().message().find("HTTP 404: cache_key: nothing baked under " + absent), std::string::npos)
      << bad.status();
}

TEST_F(FarmHttpOnlyTest, ReadingTheListingIsAUseOfTheResultAsGetResultIs) {
  const int64_t before = LastUsedMs();
  ASSERT_GT(before, 0);
  while (NowMs() <= before) {
  }  // the next millisecond: a use now is later than the last one
  const int64_t asked = NowMs();
  ASSERT_TRUE(sdk::GetResultOverHttp(FrontEnd(http_url_), result_.key).ok());
  EXPECT_GE(LastUsedMs(), asked) << "the listing did not count as a use (the LRU would evict a result in use)";
}

TEST_F(FarmHttpOnlyTest, AFetchOverTheFrontEndNeedsNoGrpcServer) {
  fs::path out;
  absl::StatusOr<sdk::FetchResult> fetched = Fetch(http_url_, kNoGrpcServer, &out);
  ASSERT_TRUE(fetched.ok()) << fetched.status();
  ExpectFilesAre(out);
  EXPECT_EQ(fetched->bytes_downloaded, result_.total_bytes);
  EXPECT_EQ(fetched->manifest_path, out / "manifest.json");
  // A second fetch into the same folder keeps every file (digests match).
  fetched = sdk::FetchFromFarm([&] {
    sdk::ClientOptions o = Options(http_url_);
    o.server = kNoGrpcServer;
    return o;
  }(), result_.key, out);
  ASSERT_TRUE(fetched.ok()) << fetched.status();
  EXPECT_EQ(fetched->bytes_downloaded, 0);
  EXPECT_EQ(fetched->bytes_reused, result_.total_bytes);
  // Without the front end the same options need the gRPC server: the
  // fetches above did not reach one.
  fetched = Fetch("none");
  EXPECT_EQ(fetched.status().code(), absl::StatusCode::kUnavailable) << fetched.status();

  // The CLI: --farm-http, and $IMPOSTOR_FARM_HTTP.
  for (const bool by_env : {false, true}) {
    const fs::path cli_out = dir_ / (by_env ? "cli-env" : "cli");
    std::vector<std::string> argv = {(BinaryDir() / "impostor").string(), "fetch", result_.key, "--server",
                                     kNoGrpcServer, "--out", cli_out.string(), "--quiet"};
    if (by_env) {
      argv.insert(argv.begin(), {"/usr/bin/env", "IMPOSTOR_FARM_HTTP=" + http_url_});
    } else {
      argv.insert(argv.end(), {"--farm-http", http_url_});
    }
    const ToolRun run = RunTool(argv, std::chrono::seconds(60));
    EXPECT_EQ(run.exit_code, 0) << run.err;
    ExpectFilesAre(cli_out);
  }
}

TEST_F(FarmHttpOnlyTest, AListingOrFileTheFrontEndCannotGiveSendsTheWholeResultOverGrpc) {
  std::unique_ptr<FaultMirror> front = StartFaultyFrontEnd();
  const std::string base = front->url() + "/v1/farm";
  // The mirror as it is serves the whole result: the faults below are what
  // makes each case go to gRPC.
  ASSERT_TRUE(Fetch(base).ok());
  struct Case {
    std::string path;
    Fault fault;
  };
  const Case cases[] = {
      {MirrorListingPath(), Fault::kHtml200},  {MirrorListingPath(), Fault::kTruncate},
      {MirrorListingPath(), Fault::kFlipByte}, {MirrorListingPath(), Fault::kStall},
      {MirrorFilePath("albedo_alpha.png"), Fault::kFlipByte},
      {MirrorFilePath("orm.png"), Fault::kTruncate},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(::testing::Message() << c.path << " fault " << static_cast<int>(c.fault));
    front->SetFault(c.path, c.fault);
    const int asked = front->Requests(c.path);
    // With no gRPC server the spoiled answer is an error, never a result.
    absl::StatusOr<sdk::FetchResult> fetched = Fetch(base);
    EXPECT_FALSE(fetched.ok());
    EXPECT_GT(front->Requests(c.path), asked) << "the front end was asked first";
    // With one, the whole result comes over gRPC with the front end left
    // out: no file is asked of it twice in one fetch (a transport still
    // using it would ask a spoiled large file again), and after a bad
    // listing nothing at all.
    const int before = front->TotalRequests();
    int large_before[2];
    for (int i = 0; i < 2; ++i) large_before[i] = front->Requests(MirrorFilePath(kLargeFiles[i]));
    fs::path out;
    fetched = Fetch(base, server_->address(), &out);
    ASSERT_TRUE(fetched.ok()) << fetched.status();
    ExpectFilesAre(out);
    for (int i = 0; i < 2; ++i) {
      EXPECT_LE(front->Requests(MirrorFilePath(kLargeFiles[i])) - large_before[i], 1) << kLargeFiles[i];
    }
    if (c.path == MirrorListingPath()) {
      EXPECT_EQ(front->TotalRequests() - before, 1);
    }
    front->SetFault(c.path, Fault::kNone);
  }
  // A front end that is gone: gRPC.
  front->Stop();
  fs::path out;
  absl::StatusOr<sdk::FetchResult> fetched = Fetch(base, server_->address(), &out);
  ASSERT_TRUE(fetched.ok()) << fetched.status();
  ExpectFilesAre(out);
}

TEST_F(FarmHttpOnlyTest, AFrontEndWithoutTheListingStillGivesTheLargeFiles) {
  // As a farm older than the listing: 404 for it, the files served.
  std::unique_ptr<FaultMirror> front = StartFaultyFrontEnd();
  front->SetFault(MirrorListingPath(), Fault::kNotFound);
  fs::path out;
  absl::StatusOr<sdk::FetchResult> fetched = Fetch(front->url() + "/v1/farm", server_->address(), &out);
  ASSERT_TRUE(fetched.ok()) << fetched.status();
  ExpectFilesAre(out);
  EXPECT_EQ(front->Requests(MirrorListingPath()), 1);
  for (const char* name : kLargeFiles) {
    EXPECT_EQ(front->Requests(MirrorFilePath(name)), 1) << name << ": the large files still came from the front end";
  }
  EXPECT_EQ(front->Requests(MirrorFilePath("orm.png")), 0) << "the small file came in gRPC's batch";
}

TEST_F(FarmHttpOnlyTest, ALocalFailureIsReturnedAndNotTriedAgainOverGrpc) {
  // out_dir is a file: the install cannot create it. Over gRPC (nothing
  // listens) the answer would be UNAVAILABLE.
  const fs::path file = dir_ / "a-file";
  WriteFileBytes(file, "x");
  sdk::ClientOptions o = Options(http_url_);
  o.server = kNoGrpcServer;
  absl::StatusOr<sdk::FetchResult> fetched = sdk::FetchFromFarm(o, result_.key, file);
  EXPECT_EQ(fetched.status().code(), absl::StatusCode::kInternal) << fetched.status();
  EXPECT_NE(fetched.status().message().find(file.string()), std::string::npos) << fetched.status();

  // Options the SDK refuses: INVALID_ARGUMENT naming the field, no request.
  o.farm_http = "ftp://127.0.0.1/x";
  fetched = sdk::FetchFromFarm(o, result_.key, dir_ / "never");
  EXPECT_EQ(fetched.status().code(), absl::StatusCode::kInvalidArgument) << fetched.status();
  EXPECT_NE(fetched.status().message().find("ClientOptions.farm_http"), std::string::npos) << fetched.status();
  EXPECT_FALSE(fs::exists(dir_ / "never"));
}

TEST_F(FarmHttpOnlyTest, CacheGetInstallsOverTheFrontEndAloneAndAsksTheFarmOnlyForWhatItCannotGive) {
  std::unique_ptr<FaultMirror> front = StartFaultyFrontEnd();
  auto open = [&](const std::string& server, const std::string& name) {
    sdk::CacheOptions o;
    o.server = server;
    o.dir = dir_ / name;
    o.connect_timeout_seconds = 5;
    o.rpc_timeout_seconds = 1;
    o.max_attempts = 2;
    o.max_outage_seconds = 0;
    o.farm_http = front->url() + "/v1/farm";
    return sdk::Cache::Open(o);
  };
  auto expect_installed = [&](const sdk::CachedResult& got) {
    EXPECT_EQ(got.files().size(), result_.files.size());
    for (const sdk::CachedFile& f : got.files()) {
      EXPECT_EQ(ReadFileBytes(f.path), result_.files.at(f.path.filename().string())) << f.path;
    }
  };
  {
    // No gRPC server: the front end gives it all.
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = open(kNoGrpcServer, "cache-no-grpc");
    ASSERT_TRUE(cache.ok()) << cache.status();
    absl::StatusOr<sdk::CachedResult> got = (*cache)->Get(result_.key);
    ASSERT_TRUE(got.ok()) << got.status();
    expect_installed(*got);
  }
  // A spoiled listing: the farm over gRPC gives the result.
  front->SetFault(MirrorListingPath(), Fault::kFlipByte);
  {
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = open(kNoGrpcServer, "cache-bad-listing-no-grpc");
    ASSERT_TRUE(cache.ok()) << cache.status();
    absl::StatusOr<sdk::CachedResult> got = (*cache)->Get(result_.key);
    EXPECT_EQ(got.status().code(), absl::StatusCode::kUnavailable) << "a spoiled listing was not taken";
  }
  {
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = open(server_->address(), "cache-bad-listing");
    ASSERT_TRUE(cache.ok()) << cache.status();
    absl::StatusOr<sdk::CachedResult> got = (*cache)->Get(result_.key);
    ASSERT_TRUE(got.ok()) << got.status();
    expect_installed(*got);
  }
  // A small file the front end spoils: that file alone from the farm.
  front->SetFault(MirrorListingPath(), Fault::kNone);
  front->SetFault(MirrorFilePath("orm.png"), Fault::kHtml200);
  {
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = open(kNoGrpcServer, "cache-bad-file-no-grpc");
    ASSERT_TRUE(cache.ok()) << cache.status();
    absl::StatusOr<sdk::CachedResult> got = (*cache)->Get(result_.key);
    EXPECT_FALSE(got.ok());
    EXPECT_NE(got.status().message().find("orm.png"), std::string::npos) << got.status();
  }
  {
    const int albedo_before = front->Requests(MirrorFilePath("albedo_alpha.png"));
    absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = open(server_->address(), "cache-bad-file");
    ASSERT_TRUE(cache.ok()) << cache.status();
    absl::StatusOr<sdk::CachedResult> got = (*cache)->Get(result_.key);
    ASSERT_TRUE(got.ok()) << got.status();
    expect_installed(*got);
    EXPECT_EQ(front->Requests(MirrorFilePath("albedo_alpha.png")) - albedo_before, 1);
  }
}

TEST(FarmHttpListingDigest, IsRfc9530sSha256MemberAndFoundAmongOthers) {
  // SHA-256 of "" is e3b0c442...; its base64 is 47DEQpj8HBSa+/TImW+5JCeuQeRkm5NMpJWZG3hSuFU=.
  EXPECT_EQ(ReprDigestSha256(""), "sha-256=:47DEQpj8HBSa+/TImW+5JCeuQeRkm5NMpJWZG3hSuFU=:");
  EXPECT_EQ(ReprDigestSha256Member("sha-512=:AAAA:, sha-256=:abc=:"), "sha-256=:abc=:");
  EXPECT_EQ(ReprDigestSha256Member("sha-256=:abc=:"), "sha-256=:abc=:");
  EXPECT_EQ(ReprDigestSha256Member("sha-512=:AAAA:"), "");
  EXPECT_EQ(ReprDigestSha256Member(""), "");
}

}  // namespace
}  // namespace impostor::testing
