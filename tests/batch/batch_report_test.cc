// The batch's JSON lines and live summary line.
#include "client/cli/batch_report.h"

#include <cstdio>
#include <string>

#include <gtest/gtest.h>

namespace impostor::cli {
namespace {

TEST(AssetJson, HasEveryDocumentedKey) {
  AssetOutcome o;
  o.asset = "props/crate.glb";
  o.name = "crate";
  o.out_dir = "out/crate";
  o.status = AssetStatus::kSucceeded;
  o.cached = true;
  o.cache_key = std::string(64, 'a');
  o.job_id = "job-1";
  o.files = {"out/crate/albedo_alpha.png", "out/crate/manifest.json"};
  o.wall_seconds = 1.5;
  o.priority = -50;
  o.quality = {{"silhouette_iou_mean", 0.97}};
  const nlohmann::json j = AssetJson(o);
  for (const char* key : {"type", "asset", "name", "status", "cached", "cache_key", "job_id", "out_dir", "files",
                          "wall_seconds", "priority", "quality", "error", "error_code", "error_reason"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["type"], "asset");
  EXPECT_EQ(j["status"], "succeeded");
  EXPECT_EQ(j["quality"]["silhouette_iou_mean"], 0.97);
  EXPECT_TRUE(j["error"].is_null());

  AssetOutcome failed;
  failed.asset = "broken.glb";
  failed.status = AssetStatus::kFailed;
  failed.error = "INVALID_ARGUMENT: bad magic";
  failed.error_code = 3;
  const nlohmann::json f = AssetJson(failed);
  EXPECT_EQ(f["status"], "failed");
  EXPECT_TRUE(f["cache_key"].is_null()) << "never submitted: no key";
  EXPECT_TRUE(f["quality"].is_null());
  EXPECT_EQ(f["error"], "INVALID_ARGUMENT: bad magic");
  EXPECT_EQ(f["error_code"], 3);
  EXPECT_TRUE(f["error_reason"].is_null()) << "no reason given";
  failed.error_reason = "TOKEN_BAKES_PER_HOUR";
  EXPECT_EQ(AssetJson(failed)["error_reason"], "TOKEN_BAKES_PER_HOUR");
}

TEST(SummaryJson, CountsAndExitCode) {
  BatchCounts c{.total = 10, .baked = 4, .cached = 3, .failed = 2, .skipped = 1};
  const nlohmann::json j = SummaryJson(c, 12.5, 1);
  EXPECT_EQ(j["type"], "summary");
  EXPECT_EQ(j["total"], 10);
  EXPECT_EQ(j["succeeded"], 7);
  EXPECT_EQ(j["baked"], 4);
  EXPECT_EQ(j["cached"], 3);
  EXPECT_EQ(j["failed"], 2);
  EXPECT_EQ(j["skipped"], 1);
  EXPECT_EQ(j["exit_code"], 1);
  EXPECT_TRUE(j["error"].is_null());
  EXPECT_EQ(SummaryJson(c, 1, 3, "UNAVAILABLE: Connect (server x:1): connection refused")["error"],
            "UNAVAILABLE: Connect (server x:1): connection refused");
}

TEST(SummaryLine, ShowsEveryCountAndABar) {
  BatchCounts c{.total = 20, .queued = 5, .running = 2, .baked = 6, .cached = 3, .failed = 1};
  EXPECT_EQ(SummaryLine(c, 20), "[##########----------] 10/20  queued 5  running 2  done 6  cached 3  failed 1");
  c.skipped = 10;
  c.queued = c.running = 0;
  EXPECT_EQ(SummaryLine(c, 20),
            "[####################] 20/20  queued 0  running 0  done 6  cached 3  failed 1  skipped 10");
}

TEST(SummaryLine, CountsAssetsHeldBackByAQuotaWhileThereAreAny) {
  BatchCounts c{.total = 8, .held = 6, .queued = 2};
  EXPECT_EQ(SummaryLine(c, 8), "[--------] 0/8  queued 2  running 0  done 0  cached 0  failed 0  held 6");
  c.held = 0;
  EXPECT_EQ(SummaryLine(c, 8), "[--------] 0/8  queued 2  running 0  done 0  cached 0  failed 0");
}

TEST(BatchProgressLine, OutsideATerminalPrintsOnlyWhenSomethingFinished) {
  char* buffer = nullptr;
  size_t size = 0;
  std::FILE* out = open_memstream(&buffer, &size);
  {
    BatchProgressLine line(out, /*is_tty=*/false);
    BatchCounts c{.total = 3, .queued = 3};
    line.Update(c);  // first: printed
    c.queued = 2;
    c.running = 1;
    line.Update(c);  // nothing finished: not printed
    c.running = 0;
    c.baked = 3;
    c.queued = 0;
    line.Finish(c);
  }
  std::fclose(out);
  const std::string text(buffer, size);
  std::free(buffer);
  EXPECT_EQ(text,
            "[------------------------] 0/3  queued 3  running 0  done 0  cached 0  failed 0\n"
            "[########################] 3/3  queued 0  running 0  done 3  cached 0  failed 0\n");
}

}  // namespace
}  // namespace impostor::cli
