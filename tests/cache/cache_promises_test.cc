// The game-client cache's README promises not covered elsewhere, against a
// real impostor-server: `cache gc --verify`, the cache-directory fallback
// order, pins held against another process, a corrupt download through
// Cache::Get, and the C API's async get, lookup and prefetch.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "client/cache/cache_testing.h"
#include "impostor/cache.h"
#include "impostor/impostor_c.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Impostor() { return (BinaryDir() / "impostor").string(); }

json LastJsonLine(const std::string& out) {
  const size_t at = out.rfind("\n{", out.size() >= 2 ? out.size() - 2 : 0);
  return json::parse(out.substr(at == std::string::npos ? 0 : at + 1), nullptr, /*allow_exceptions=*/false);
}

void FlipAByte(const fs::path& f, std::streamoff at = 100) {
  fs::permissions(f, fs::perms::owner_write, fs::perm_options::add);
  std::fstream io(f, std::ios::in | std::ios::out | std::ios::binary);
  io.seekg(at);
  char c = 0;
  io.get(c);
  io.seekp(at);
  io.put(static_cast<char>(c ^ 0x20));
}

TEST(CacheCliPromises, GcVerifyDropsDamagedEntriesThatAMetadataCheckMisses) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, {64 << 10, 32 << 10, 16 << 10}, 60);
  const fs::path dir = NewTempDir("cache_gc_verify");
  const std::vector<std::string> where = {"--cache-dir", dir.string(), "--server", server.address()};
  auto cli = [&](std::vector<std::string> args) {
    args.insert(args.begin(), Impostor());
    args.insert(args.end(), where.begin(), where.end() - (args[2] == "get" ? 0 : 2));
    return RunTool(args);
  };
  ToolRun get = cli({"cache", "get", published.key, "--json"});
  ASSERT_EQ(get.exit_code, 0) << get.err;
  const fs::path albedo = dir / "entries" / published.key / "albedo_alpha.png";
  ASSERT_TRUE(fs::exists(albedo));
  FlipAByte(albedo);  // same size, same file: only hashing sees it

  const ToolRun quick = cli({"cache", "gc", "--json"});
  ASSERT_EQ(quick.exit_code, 0) << quick.err;
  EXPECT_EQ(LastJsonLine(quick.out).value("broken_entries", -1), 0) << quick.out;
  const ToolRun verify = cli({"cache", "gc", "--verify", "--json"});
  ASSERT_EQ(verify.exit_code, 0) << verify.err;
  EXPECT_EQ(LastJsonLine(verify.out).value("broken_entries", -1), 1) << verify.out;
  EXPECT_EQ(LastJsonLine(verify.out).value("entries", -1), 0) << verify.out;
  EXPECT_FALSE(fs::exists(albedo));

  get = cli({"cache", "get", published.key, "--json"});
  ASSERT_EQ(get.exit_code, 0) << get.err;
  EXPECT_EQ(LastJsonLine(get.out).value("downloaded", false), true) << get.out;
  EXPECT_EQ(ReadFileBytes(albedo), published.files.at("albedo_alpha.png"));
}

TEST(CacheCliPromises, TheCacheDirectoryFallsBackInTheDocumentedOrder) {
  const fs::path root = NewTempDir("cache_dir_order");
  const std::string flag = (root / "flag").string(), env = (root / "env").string(), xdg = (root / "xdg").string(),
                    home = (root / "home").string();
  const struct {
    const char* name;
    std::vector<std::string> args;
    std::vector<std::string> env;
    fs::path expected;
  } cases[] = {
      {"--cache-dir beats everything", {"--cache-dir", flag},
       {"IMPOSTOR_CACHE_DIR=" + env, "XDG_CACHE_HOME=" + xdg, "HOME=" + home}, flag},
      {"$IMPOSTOR_CACHE_DIR next", {}, {"IMPOSTOR_CACHE_DIR=" + env, "XDG_CACHE_HOME=" + xdg, "HOME=" + home}, env},
      {"then $XDG_CACHE_HOME/impostor", {}, {"IMPOSTOR_CACHE_DIR=", "XDG_CACHE_HOME=" + xdg, "HOME=" + home},
       fs::path(xdg) / "impostor"},
      {"then ~/.cache/impostor", {}, {"IMPOSTOR_CACHE_DIR=", "XDG_CACHE_HOME=", "HOME=" + home},
       fs::path(home) / ".cache/impostor"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> argv = {Impostor(), "cache", "ls", "--json"};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const ToolRun run = RunTool(argv, kExitTimeout, c.env);
    ASSERT_EQ(run.exit_code, 0) << c.name << ": " << run.err;
    const json listing = LastJsonLine(run.out);
    EXPECT_EQ(fs::path(listing.value("dir", "")), c.expected) << c.name << ": " << run.out;
  }
}

TEST(CachePins, AResultInUseSurvivesGarbageCollectionByAnotherProcess) {
  ServerProcess server(0);
  const PublishedResult held = PublishResult(server, {64 << 10, 32 << 10, 16 << 10}, 61);
  const PublishedResult released = PublishResult(server, {64 << 10, 32 << 10, 16 << 10}, 62);
  const fs::path dir = NewTempDir("cache_cross_process_pin");
  sdk::CacheOptions options;
  options.server = server.address();
  options.dir = dir;
  auto cache = sdk::Cache::Open(options);
  ASSERT_TRUE(cache.ok()) << cache.status();
  auto in_use = (*cache)->Get(held.key);
  ASSERT_TRUE(in_use.ok()) << in_use.status();
  ASSERT_TRUE((*cache)->Get(released.key).ok());  // released at once

  // Another process (the CLI) collects everything it may.
  const ToolRun gc = RunTool({Impostor(), "cache", "gc", "--max-bytes", "0", "--json", "--cache-dir", dir.string()});
  ASSERT_EQ(gc.exit_code, 0) << gc.err;
  EXPECT_EQ(LastJsonLine(gc.out).value("evicted_entries", -1), 1) << gc.out;
  EXPECT_TRUE(fs::exists(in_use->dir())) << "evicted by another process while in use";
  EXPECT_EQ(ReadFileBytes(in_use->map("albedo_alpha")->path), held.files.at("albedo_alpha.png"));
  EXPECT_FALSE(fs::exists(dir / "entries" / released.key));

  // Released, it goes at the next collection.
  const fs::path held_dir = in_use->dir();
  *in_use = sdk::CachedResult();
  const ToolRun again = RunTool({Impostor(), "cache", "gc", "--max-bytes", "0", "--json", "--cache-dir", dir.string()});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(LastJsonLine(again.out).value("evicted_entries", -1), 1) << again.out;
  EXPECT_FALSE(fs::exists(held_dir));
}

// A download cut off midway leaves a partial file; if those bytes are wrong
// when the download resumes, the digest check catches it, nothing bad is
// installed, and the blob is fetched again from zero. (A blob that went bad
// in the server's own store never leaves it: the server answers DATA_LOSS
// or drops the result, tests/integration/store_rpc_test.cc.)
TEST(CacheGetPromises, ACorruptPartialDownloadIsNeverInstalledAndIsFetchedAgain) {
  ServerProcess server(0);
  const PublishedResult published = PublishResult(server, {16 << 20, 32 << 10, 16 << 10}, 63);
  const std::string& big = published.files.at("albedo_alpha.png");
  const std::string big_hash = DigestOf(big).hash();
  const fs::path dir = NewTempDir("cache_corrupt_partial");
  sdk::CacheOptions options;
  options.server = server.address();
  options.dir = dir;
  options.max_attempts = 1;
  {
    std::atomic<bool> killed{false};
    sdk::CacheTestHooks hooks;
    hooks.download.on_blob_bytes = [&](const std::string& hash, int64_t received) {
      if (hash == big_hash && received >= (1 << 20) && !killed.exchange(true)) server.Kill();
    };
    auto cache = sdk::CacheFactory::Open(options, hooks);
    ASSERT_TRUE(cache.ok()) << cache.status();
    ASSERT_FALSE((*cache)->Get(published.key).ok());
    ASSERT_TRUE(killed.load());
  }
  std::vector<fs::path> partials;
  for (const auto& entry : fs::directory_iterator(dir / "partial")) partials.push_back(entry.path());
  ASSERT_EQ(partials.size(), 1u);
  const int64_t kept = static_cast<int64_t>(fs::file_size(partials[0]));
  ASSERT_GT(kept, 1000);
  ASSERT_LT(kept, static_cast<int64_t>(big.size()));
  FlipAByte(partials[0], 500);

  server.Restart();
  std::vector<int64_t> starts;
  sdk::CacheTestHooks hooks;
  hooks.download.on_blob_start = [&](const std::string& hash, int64_t offset) {
    if (hash == big_hash) starts.push_back(offset);
  };
  auto cache = sdk::CacheFactory::Open(options, hooks);
  ASSERT_TRUE(cache.ok()) << cache.status();
  auto got = (*cache)->Get(published.key);
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_TRUE(ReadFileBytes(got->map("albedo_alpha")->path) == big) << "corrupt bytes were installed";
  ASSERT_EQ(starts.size(), 2u) << "resumed, found wrong, fetched again";
  EXPECT_EQ(starts[0], kept) << "the first try resumes after the bytes on disk";
  EXPECT_EQ(starts[1], 0) << "the second starts from zero";
}

struct AsyncOutcome {
  std::promise<std::pair<impostor_status, std::string>> done;
};

void OnGet(impostor_status status, impostor_result* result, void* user_data) {
  auto* outcome = static_cast<AsyncOutcome*>(user_data);
  std::string dir = result != nullptr ? impostor_result_dir(result) : impostor_last_error();
  if (result != nullptr) impostor_result_release(result);
  outcome->done.set_value({status, dir});
}

TEST(CApi, GetAsyncLookupAndPrefetch) {
  ServerProcess server(0);
  const PublishedResult a = PublishResult(server, {32 << 10, 16 << 10, 8 << 10}, 64);
  const PublishedResult b = PublishResult(server, {32 << 10, 16 << 10, 8 << 10}, 65);
  const fs::path dir = NewTempDir("c_api");
  const std::string address = server.address(), dir_text = dir.string();
  impostor_cache_options options;
  impostor_cache_options_init(&options);
  options.server = address.c_str();
  options.dir = dir_text.c_str();
  impostor_cache* cache = nullptr;
  ASSERT_EQ(impostor_cache_open(&options, &cache), IMPOSTOR_OK) << impostor_last_error();

  // Async: the callback runs once, with the result or the reason.
  AsyncOutcome ok, bad;
  impostor_cache_get_async(cache, a.key.c_str(), OnGet, &ok);
  impostor_cache_get_async(cache, "not-a-key", OnGet, &bad);
  auto ok_future = ok.done.get_future();
  auto bad_future = bad.done.get_future();
  ASSERT_EQ(ok_future.wait_for(kWatchTimeout), std::future_status::ready);
  ASSERT_EQ(bad_future.wait_for(kWatchTimeout), std::future_status::ready);
  const auto [ok_status, ok_dir] = ok_future.get();
  EXPECT_EQ(ok_status, IMPOSTOR_OK) << ok_dir;
  EXPECT_EQ(fs::path(ok_dir), dir / "entries" / a.key);
  const auto [bad_status, bad_reason] = bad_future.get();
  EXPECT_EQ(bad_status, IMPOSTOR_INVALID_ARGUMENT) << bad_reason;

  // Lookup: a model nobody baked is not found, but its key is computed.
  char key[65] = {0};
  int found = -1;
  const std::string box = (AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb").string();
  ASSERT_EQ(impostor_cache_lookup(cache, box.c_str(), "octahedral", 3, 64, key, &found), IMPOSTOR_OK)
      << impostor_last_error();
  EXPECT_EQ(found, 0);
  EXPECT_EQ(std::string(key).size(), 64u);
  EXPECT_EQ(impostor_cache_lookup(cache, "/nonexistent.glb", nullptr, 0, 0, key, &found), IMPOSTOR_NOT_FOUND);
  // Every setting through the settings struct: the same key as the short
  // form for the same settings, another for a ring-top of 8 views than for
  // the default ring of 24, and the C++ SDK's key for it.
  impostor_bake_settings settings;
  impostor_bake_settings_init(&settings);
  settings.layout = "octahedral";
  settings.frames = 3;
  settings.resolution = 64;
  char same[65] = {0};
  ASSERT_EQ(impostor_cache_lookup_settings(cache, box.c_str(), &settings, same, &found), IMPOSTOR_OK)
      << impostor_last_error();
  EXPECT_STREQ(same, key);
  impostor_bake_settings_init(&settings);
  settings.layout = "ring-top";
  char ring8[65] = {0}, ring24[65] = {0};
  settings.ring_views = 8;
  ASSERT_EQ(impostor_cache_lookup_settings(cache, box.c_str(), &settings, ring8, &found), IMPOSTOR_OK)
      << impostor_last_error();
  settings.ring_views = 0;
  ASSERT_EQ(impostor_cache_lookup_settings(cache, box.c_str(), &settings, ring24, &found), IMPOSTOR_OK)
      << impostor_last_error();
  EXPECT_STRNE(ring8, ring24);
  sdk::BakeSettings cpp;
  cpp.layout = "ring-top";
  cpp.ring_views = 8;
  sdk::CacheOptions cpp_options;
  cpp_options.server = server.address();
  cpp_options.dir = dir / "cpp";
  auto cpp_key = sdk::CacheFactory::Open(cpp_options, {});
  ASSERT_TRUE(cpp_key.ok()) << cpp_key.status();
  auto looked = (*cpp_key)->Lookup(box, cpp);
  ASSERT_TRUE(looked.ok()) << looked.status();
  EXPECT_EQ(looked->cache_key, ring8);
  // Bad settings: a size from no known header, a layout the server refuses.
  settings.size = 8;
  EXPECT_EQ(impostor_cache_lookup_settings(cache, box.c_str(), &settings, key, &found), IMPOSTOR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(impostor_last_error()).find("impostor_bake_settings_init"), std::string::npos);
  impostor_bake_settings_init(&settings);
  settings.layout = "cube";
  EXPECT_EQ(impostor_cache_lookup_settings(cache, box.c_str(), &settings, key, &found), IMPOSTOR_INVALID_ARGUMENT);
  EXPECT_EQ(impostor_cache_lookup_settings(cache, box.c_str(), nullptr, key, &found), IMPOSTOR_INVALID_ARGUMENT);

  // Prefetch: b lands on disk in the background; then, with the server
  // gone, it is answered from disk.
  const char* keys[] = {b.key.c_str()};
  impostor_cache_prefetch(cache, keys, 1);
  EXPECT_TRUE(WaitForDirectory(dir / "entries", [&] { return fs::exists(dir / "entries" / b.key); }))
      << "prefetch never installed " << b.key;
  server.Kill();
  impostor_result* result = nullptr;
  ASSERT_EQ(impostor_cache_get(cache, b.key.c_str(), &result), IMPOSTOR_OK) << impostor_last_error();
  EXPECT_EQ(impostor_result_downloaded(result), 0);
  EXPECT_STREQ(impostor_result_product(result), "atlas");
  EXPECT_STREQ(impostor_result_layout(result), "octahedral");
  EXPECT_EQ(impostor_result_frames(result), 3u);
  EXPECT_EQ(impostor_result_resolution(result), 64u);
  EXPECT_EQ(impostor_result_view_count(result), 9u);
  EXPECT_EQ(ReadFileBytes(impostor_result_map_path(result, "albedo_alpha")), b.files.at("albedo_alpha.png"));
  impostor_result_release(result);
  impostor_cache_close(cache);
}

}  // namespace
}  // namespace impostor::testing
