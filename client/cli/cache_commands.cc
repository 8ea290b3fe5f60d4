// impostor cache get / ls / gc: the local result cache (impostor/cache.h)
// for people and scripts, through the same library a game uses.
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "client/cli/commands.h"
#include "client/cli/connection_options.h"
#include "client/cli/output.h"
#include "impostor/cache.h"

namespace impostor::cli {
namespace {

namespace fs = std::filesystem;

// --cache-dir, else $IMPOSTOR_CACHE_DIR, else $XDG_CACHE_HOME/impostor, else
// $HOME/.cache/impostor (the XDG default), else ./.impostor-cache.
fs::path CacheDir(const CliArgs& args) {
  if (!args.cache_dir.empty()) return args.cache_dir;
  auto env = [](const char* name) -> const char* {
    const char* v = std::getenv(name);
    return v != nullptr && v[0] != '\0' ? v : nullptr;
  };
  if (const char* dir = env("IMPOSTOR_CACHE_DIR")) return dir;
  if (const char* xdg = env("XDG_CACHE_HOME")) return fs::path(xdg) / "impostor";
  if (const char* home = env("HOME")) return fs::path(home) / ".cache" / "impostor";
  return ".impostor-cache";
}

// A local INVALID_ARGUMENT (a malformed key) is a usage error; the rest
// map as for the other commands.
int CacheExitCode(const absl::Status& status) {
  if (status.code() == absl::StatusCode::kInvalidArgument && !sdk::GetRpcErrorInfo(status).has_value()) {
    return kExitUsage;
  }
  return ExitCodeFor(status);
}

absl::StatusOr<std::unique_ptr<sdk::Cache>> OpenCache(const CliArgs& args) {
  sdk::CacheOptions options;
  ApplyConnectionOptions(args, kInteractiveOutageSeconds, &options);
  options.dir = CacheDir(args);
  // A command-line run is short: the cap is applied by `gc`, not on open.
  options.max_bytes = int64_t{1} << 62;
  // Partial downloads keep the library's default age (7 days): the
  // directory may be shared with a game whose downloads are under way, and
  // a killed download's partial files are what its next try resumes from.
  return sdk::Cache::Open(options);
}

}  // namespace

std::filesystem::path CacheDirFor(const CliArgs& args) { return CacheDir(args); }

int RunCacheGet(const CliArgs& args) {
  nlohmann::json report = {{"cache_key", args.target}, {"dir", nullptr},         {"manifest", nullptr},
                           {"files", nlohmann::json::array()}, {"downloaded", false}, {"size_bytes", 0},
                           {"error", nullptr}};
  auto fail = [&](int code, const std::string& error) {
    report["error"] = error;
    if (args.json) PrintJson(report);
    return Fail(code, error);
  };
  sdk::CacheOptions defaults;
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = OpenCache(args);
  if (!cache.ok()) return fail(CacheExitCode(cache.status()), Describe(cache.status()));
  absl::StatusOr<sdk::CachedResult> result = (*cache)->Get(args.target);
  if (!result.ok()) return fail(CacheExitCode(result.status()), Describe(result.status()));
  // Hold the usual cap after adding this result (the command opened
  // without one so as not to evict before the Get).
  (void)(*cache)->CollectGarbage(defaults.max_bytes);

  report["dir"] = result->dir().string();
  report["manifest"] = result->manifest_path().string();
  for (const auto& f : result->files()) report["files"].push_back(f.path.string());
  report["downloaded"] = result->downloaded();
  report["size_bytes"] = result->size_bytes();
  if (args.json) {
    PrintJson(report);
  } else {
    for (const auto& f : result->files()) std::printf("%s\n", f.path.string().c_str());
    std::fflush(stdout);
  }
  if (!args.quiet && !args.json) {
    std::fprintf(stderr, "%s: %s, %s in %s\n", args.target.c_str(),
                 result->downloaded() ? "downloaded" : "already cached", HumanBytes(result->size_bytes()).c_str(),
                 result->dir().string().c_str());
  }
  return kExitOk;
}

int RunCacheLs(const CliArgs& args) {
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = OpenCache(args);
  if (!cache.ok()) return Fail(CacheExitCode(cache.status()), Describe(cache.status()));
  const std::vector<sdk::CacheEntryInfo> entries = (*cache)->List();
  int64_t total = 0;
  nlohmann::json list = nlohmann::json::array();
  for (const sdk::CacheEntryInfo& e : entries) {
    total += e.size_bytes;
    list.push_back({{"cache_key", e.key},
                    {"dir", e.dir.string()},
                    {"size_bytes", e.size_bytes},
                    {"last_used_unix_seconds", e.last_used_unix_seconds}});
  }
  if (args.json) {
    PrintJson({{"dir", CacheDir(args).string()}, {"entries", list}, {"total_bytes", total}});
    return kExitOk;
  }
  for (const sdk::CacheEntryInfo& e : entries) {
    std::printf("%s  %10s  %s\n", e.key.c_str(), HumanBytes(e.size_bytes).c_str(), e.dir.string().c_str());
  }
  std::printf("%zu results, %s in %s\n", entries.size(), HumanBytes(total).c_str(), CacheDir(args).string().c_str());
  return kExitOk;
}

int RunCacheGc(const CliArgs& args) {
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = OpenCache(args);
  if (!cache.ok()) return Fail(CacheExitCode(cache.status()), Describe(cache.status()));
  const int64_t cap = args.max_bytes.value_or(sdk::CacheOptions().max_bytes);
  absl::StatusOr<sdk::GarbageReport> gc = (*cache)->CollectGarbage(cap, args.verify);
  if (!gc.ok()) return Fail(CacheExitCode(gc.status()), Describe(gc.status()));
  const sdk::CacheStats stats = (*cache)->Stats();
  if (args.json) {
    PrintJson({{"evicted_entries", gc->evicted_entries},
               {"evicted_bytes", gc->evicted_bytes},
               {"broken_entries", gc->broken_entries},
               {"removed_partials", gc->removed_partials},
               {"removed_partial_bytes", gc->removed_partial_bytes},
               {"entries", stats.entries},
               {"total_bytes", stats.bytes}});
    return kExitOk;
  }
  std::printf("evicted %lld results (%s), dropped %lld damaged, removed %lld partial files; %lld results, %s left\n",
              static_cast<long long>(gc->evicted_entries), HumanBytes(gc->evicted_bytes).c_str(),
              static_cast<long long>(gc->broken_entries), static_cast<long long>(gc->removed_partials),
              static_cast<long long>(stats.entries), HumanBytes(stats.bytes).c_str());
  return kExitOk;
}

}  // namespace impostor::cli
