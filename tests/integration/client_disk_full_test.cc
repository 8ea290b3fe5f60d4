// A full disk under the client's result cache and under `impostor fetch
// --out`, against a real server: the cache directory lies on a small tmpfs
// that the test mounts (as root; skipped otherwise) and fills with a file of
// its own. A result that does not fit is RESOURCE_EXHAUSTED naming the path
// and the free space (SDK, C API and CLI alike, exit code 4), leaves no
// partial, staged or temporary file and no entry, results already cached are
// still served, and once the filler is removed the same Get works.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/util/disk_space.h"
#include "common/util/sha256.h"
#include "impostor/cache.h"
#include "impostor/impostor_c.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"
#include "tests/integration/tmpfs_mount.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

// Every regular file under `dir` (recursively), as paths relative to it.
std::set<std::string> FilesUnder(const fs::path& dir) {
  std::set<std::string> out;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file()) out.insert(fs::relative(it->path(), dir).string());
  }
  return out;
}

std::unique_ptr<sdk::Cache> OpenCache(const std::string& server, const fs::path& dir) {
  sdk::CacheOptions options;
  options.server = server;
  options.dir = dir;
  options.max_outage_seconds = 0;  // the server never goes away here
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = sdk::Cache::Open(options);
  EXPECT_TRUE(cache.ok()) << cache.status();
  return cache.ok() ? std::move(*cache) : nullptr;
}

void ExpectSameFiles(const sdk::CachedResult& got, const testing::PublishedResult& published) {
  ASSERT_EQ(got.files().size(), published.files.size());
  for (const sdk::CachedFile& f : got.files()) {
    const auto it = published.files.find(f.path.filename().string());
    ASSERT_NE(it, published.files.end()) << f.path;
    EXPECT_TRUE(testing::ReadFileBytes(f.path) == it->second) << f.path << " differs from the published bytes";
  }
}

// Writes a file that leaves about `leave` bytes free on `dir`'s filesystem.
void FillLeaving(const fs::path& filler, int64_t leave) {
  const int64_t free_now = FreeBytes(filler.parent_path());
  ASSERT_GT(free_now, leave);
  std::ofstream out(filler, std::ios::binary);
  out << std::string(static_cast<size_t>(free_now - leave), 'f');
  out.close();
  ASSERT_TRUE(out.good()) << "cannot write the filler " << filler;
  const int64_t left = FreeBytes(filler.parent_path());
  ASSERT_LE(left, leave + 64 * 1024);
  std::printf("client disk full: %lld bytes left free\n", static_cast<long long>(left));
}

TEST(ClientDiskFull, AFullCacheDiskFailsCleanlyKeepsServingAndRecovers) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a tmpfs for the cache directory";
  const fs::path mount_dir = testing::NewTempDir("client_disk_full_mount");
  testing::TmpfsMount tmpfs(mount_dir, "6m");
  if (!tmpfs.mounted()) GTEST_SKIP() << "cannot mount a tmpfs on " << mount_dir << ": " << tmpfs.error();

  testing::ServerProcess server(0);
  const testing::PublishedResult small = testing::PublishResult(server, {8000, 8000, 8000}, 1);
  // Three maps of 600 KiB with about 1 MiB free: the first map's partial
  // completes, the second runs out of space midway. Both must go.
  const int64_t kMap = 600 * 1024;
  const testing::PublishedResult big = testing::PublishResult(server, {kMap, kMap, kMap}, 2);
  const testing::PublishedResult big2 = testing::PublishResult(server, {kMap, kMap, kMap}, 3);

  const fs::path cache_dir = mount_dir / "cache";
  std::unique_ptr<sdk::Cache> cache = OpenCache(server.address(), cache_dir);
  ASSERT_NE(cache, nullptr);
  {
    absl::StatusOr<sdk::CachedResult> got = cache->Get(small.key);
    ASSERT_TRUE(got.ok()) << got.status();
    ExpectSameFiles(*got, small);
  }
  const std::set<std::string> before = FilesUnder(cache_dir);

  const fs::path filler = mount_dir / "filler";
  FillLeaving(filler, 1 << 20);

  // SDK: the clear error, nothing left behind.
  absl::StatusOr<sdk::CachedResult> refused = cache->Get(big.key);
  ASSERT_FALSE(refused.ok()) << "1.8 MiB fit in about 1 MiB";
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kResourceExhausted) << refused.status();
  const std::string message(refused.status().message());
  EXPECT_NE(message.find(cache_dir.string()), std::string::npos) << "names the path: " << message;
  EXPECT_NE(message.find("bytes free on its filesystem"), std::string::npos) << "names the free space: " << message;
  EXPECT_NE(message.find("No space left on device"), std::string::npos) << message;
  std::printf("client disk full: Cache::Get: %s\n", refused.status().ToString().c_str());
  EXPECT_EQ(FilesUnder(cache_dir), before) << "a refused Get left files behind (partial, staged or an entry)";
  EXPECT_TRUE(fs::is_empty(cache_dir / "partial"));
  EXPECT_FALSE(fs::exists(cache_dir / "entries" / big.key));
  // The space went back: the next try has the same room as this one had.
  EXPECT_GE(FreeBytes(mount_dir), (1 << 20) - 64 * 1024);

  // What is cached is still served, by this cache and by a fresh one.
  {
    absl::StatusOr<sdk::CachedResult> hit = cache->Get(small.key);
    ASSERT_TRUE(hit.ok()) << hit.status();
    EXPECT_FALSE(hit->downloaded());
    ExpectSameFiles(*hit, small);
    std::unique_ptr<sdk::Cache> other = OpenCache(server.address(), cache_dir);
    ASSERT_NE(other, nullptr);
    absl::StatusOr<sdk::CachedResult> other_hit = other->Get(small.key);
    ASSERT_TRUE(other_hit.ok()) << other_hit.status();
    EXPECT_FALSE(other_hit->downloaded());
  }

  // The C API gives the same status and message.
  {
    impostor_cache_options options;
    impostor_cache_options_init(&options);
    const std::string dir = cache_dir.string();
    options.server = server.address().c_str();
    options.dir = dir.c_str();
    impostor_cache* c_cache = nullptr;
    ASSERT_EQ(impostor_cache_open(&options, &c_cache), IMPOSTOR_OK) << impostor_last_error();
    impostor_result* result = nullptr;
    const impostor_status status = impostor_cache_get(c_cache, big.key.c_str(), &result);
    EXPECT_EQ(status, IMPOSTOR_RESOURCE_EXHAUSTED) << impostor_status_name(status) << ": " << impostor_last_error();
    EXPECT_EQ(result, nullptr);
    EXPECT_NE(std::string(impostor_last_error()).find("bytes free on its filesystem"), std::string::npos)
        << impostor_last_error();
    impostor_result_release(result);
    impostor_cache_close(c_cache);
  }
  EXPECT_EQ(FilesUnder(cache_dir), before);

  // The CLI: `cache get` and `fetch --out` onto the full disk.
  const fs::path tool = testing::BinaryDir() / "impostor";
  {
    const testing::ToolRun run = testing::RunTool(
        {tool, "cache", "get", big.key, "--server", server.address(), "--cache-dir", cache_dir.string()});
    EXPECT_EQ(run.exit_code, 4) << run.err;
    EXPECT_NE(run.err.find("impostor: RESOURCE_EXHAUSTED: "), std::string::npos) << run.err;
    EXPECT_NE(run.err.find(cache_dir.string()), std::string::npos) << run.err;
    EXPECT_NE(run.err.find("bytes free on its filesystem"), std::string::npos) << run.err;
    EXPECT_EQ(FilesUnder(cache_dir), before);
  }
  const fs::path out_dir = mount_dir / "out";
  {
    const testing::ToolRun run =
        testing::RunTool({tool, "fetch", big2.key, "--server", server.address(), "--out", out_dir.string()});
    EXPECT_EQ(run.exit_code, 4) << run.err;
    EXPECT_NE(run.err.find("impostor: RESOURCE_EXHAUSTED: cannot write " + out_dir.string() + "/"),
              std::string::npos)
        << run.err;
    EXPECT_NE(run.err.find("bytes free on its filesystem"), std::string::npos) << run.err;
    std::printf("client disk full: impostor fetch: %s", run.err.c_str());
    // No temporary file and no manifest.json (it comes last); a map that
    // was renamed into place is whole.
    EXPECT_FALSE(fs::exists(out_dir / "manifest.json"));
    for (const std::string& name : FilesUnder(out_dir)) {
      ASSERT_NE(name.rfind(".", 0), 0u) << "a temporary file was left: " << name;
      const auto it = big2.files.find(name);
      ASSERT_NE(it, big2.files.end()) << name;
      EXPECT_TRUE(testing::ReadFileBytes(out_dir / name) == it->second) << name << " is not whole";
    }
  }

  // Space comes back: the same calls work, no restart, no cleanup by hand.
  fs::remove(filler);
  {
    absl::StatusOr<sdk::CachedResult> got = cache->Get(big.key);
    ASSERT_TRUE(got.ok()) << got.status();
    EXPECT_TRUE(got->downloaded());
    ExpectSameFiles(*got, big);
  }
  {
    const testing::ToolRun run =
        testing::RunTool({tool, "fetch", big2.key, "--server", server.address(), "--out", out_dir.string()});
    EXPECT_EQ(run.exit_code, 0) << run.err;
    for (const auto& [name, bytes] : big2.files) {
      EXPECT_TRUE(testing::ReadFileBytes(out_dir / name) == bytes) << name;
    }
  }
  cache.reset();  // before the unmount
}

}  // namespace
}  // namespace impostor
