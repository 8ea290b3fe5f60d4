#include "server/commands/purge_command.h"

#include <cstdio>
#include <filesystem>
#include <optional>

#include "absl/strings/str_cat.h"
#include "server/store/token_store.h"

namespace impostor {
namespace {

constexpr char kUsage[] = "usage: impostor-server purge --worker NAME --data DIR\n";

int UsageError(const std::string& message) {
  std::fprintf(stderr, "impostor-server purge: %s\n%s", message.c_str(), kUsage);
  return 2;
}

}  // namespace

absl::StatusOr<std::vector<std::string>> PurgeResultsBakedBy(JobStore& jobs, const std::string& worker) {
  auto results = jobs.ResultsByLastUse();
  if (!results.ok()) return results.status();
  std::vector<std::string> purged;
  for (const JobStore::StoredResult& r : *results) {
    if (r.manifest.baked_by() != worker) continue;
    if (auto s = jobs.DeleteResult(r.manifest.cache_key()); !s.ok()) return s;
    purged.push_back(r.manifest.cache_key());
  }
  return purged;
}

int RunPurgeCommand(const std::vector<std::string>& args) {
  std::string worker, data;
  for (size_t i = 0; i < args.size(); ++i) {
    std::string flag = args[i];
    std::optional<std::string> value;
    if (const size_t eq = flag.find('='); eq != std::string::npos) {
      value = flag.substr(eq + 1);
      flag.resize(eq);
    }
    if (flag == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (flag != "--worker" && flag != "--data") return UsageError(absl::StrCat("unknown argument \"", flag, "\""));
    if (!value) {
      if (i + 1 >= args.size()) return UsageError(absl::StrCat(flag, ": missing value"));
      value = args[++i];
    }
    (flag == "--worker" ? worker : data) = *value;
  }
  if (worker.empty()) return UsageError("--worker: required (the worker token's name, as `token list` shows)");
  if (auto s = ValidateTokenName(worker); !s.ok()) {
    return UsageError(absl::StrCat("--worker", std::string(s.message()).substr(std::string("--name").size())));
  }
  if (data.empty()) return UsageError("--data: required (the server's data directory)");
  std::error_code ec;
  if (!std::filesystem::exists(std::filesystem::path(data) / "jobs.sqlite3", ec)) {
    return UsageError(absl::StrCat("--data: ", data, " holds no job database (give the server's --data)"));
  }
  auto jobs = JobStore::Open(std::filesystem::path(data) / "jobs.sqlite3");
  if (!jobs.ok()) {
    std::fprintf(stderr, "impostor-server purge: %s\n", std::string(jobs.status().message()).c_str());
    return 1;
  }
  auto purged = PurgeResultsBakedBy(**jobs, worker);
  if (!purged.ok()) {
    std::fprintf(stderr, "impostor-server purge: %s\n", std::string(purged.status().message()).c_str());
    return 1;
  }
  for (const std::string& key : *purged) std::printf("%s\n", key.c_str());
  std::fprintf(stderr, "impostor-server purge: dropped %zu result(s) baked by '%s'; their keys bake again\n",
               purged->size(), worker.c_str());
  return 0;
}

}  // namespace impostor
