// impostor publish, impostor catalog ls and impostor fetch --mirror: the
// release side of the CLI (issue 40), through the same libraries a game
// and a CI job use (client/delivery, the result cache).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "client/cli/commands.h"
#include "client/cli/connection_options.h"
#include "client/cli/output.h"
#include "client/delivery/catalog.h"
#include "client/delivery/publisher.h"
#include "client/delivery/release_paths.h"
#include "client/base/local_io_error.h"
#include "client/transport/rpc_error.h"
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/cache.h"

namespace impostor::cli {
namespace {

namespace fs = std::filesystem;

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Exit codes for failures that are not an RPC's: what the mirrors or the
// catalog said, or local trouble.
int ReleaseExitCode(const absl::Status& status) {
  if (sdk::GetRpcErrorInfo(status).has_value()) return ExitCodeFor(status);
  switch (status.code()) {
    case absl::StatusCode::kInvalidArgument: return kExitUsage;
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kPermissionDenied:
    case absl::StatusCode::kFailedPrecondition: return kExitBakeFailed;
    case absl::StatusCode::kUnavailable:
    case absl::StatusCode::kDeadlineExceeded:
    case absl::StatusCode::kDataLoss: return kExitServer;
    default: return kExitLocalIo;
  }
}

absl::StatusOr<std::unique_ptr<sdk::Cache>> OpenReleaseCache(const CliArgs& args) {
  sdk::CacheOptions options;
  ApplyConnectionOptions(args, kInteractiveOutageSeconds, &options);
  // Mirrors first, the farm last, and only when asked for.
  if (!args.server_given) options.server.clear();
  options.mirrors = args.mirrors;
  options.channel = args.channel;
  options.catalog_public_key_file = args.catalog_key;
  options.dir = CacheDirFor(args);
  options.max_bytes = int64_t{1} << 62;  // as cache get: the cap is gc's
  // A command line wants the channel as it is now.
  options.catalog_refresh_seconds = 0;
  return sdk::Cache::Open(options);
}

absl::StatusOr<std::string> ReadInput(const std::string& path) {
  if (path == "-") {
    std::stringstream text;
    text << std::cin.rdbuf();
    return text.str();
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open the report"));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Copies (or hard-links) `from` to `to`, replacing it.
absl::Status Place(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::remove(to, ec);
  fs::create_hard_link(from, to, ec);
  if (!ec) return absl::OkStatus();
  ec.clear();
  fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
  if (ec) return sdk::LocalIoError("cannot write", to, ec.value());
  return absl::OkStatus();
}

}  // namespace

int RunPublish(const CliArgs& args) {
  const auto start = std::chrono::steady_clock::now();
  nlohmann::json report = {{"channel", args.channel}, {"out_dir", args.out}, {"catalog_sha256", nullptr},
                           {"error", nullptr}};
  auto fail = [&](int code, const std::string& error) {
    report["error"] = error;
    report["exit_code"] = code;
    report["wall_seconds"] = SecondsSince(start);
    if (args.json) PrintJson(report);
    return Fail(code, error);
  };
  if (absl::Status s = delivery::ValidateChannelName(args.channel, "--channel"); !s.ok()) {
    return fail(kExitUsage, std::string(s.message()));
  }
  absl::StatusOr<std::vector<delivery::PublishEntry>> entries = delivery::EntriesFromArguments(args.targets);
  if (!entries.ok()) return fail(kExitUsage, std::string(entries.status().message()));
  if (!args.from_report.empty()) {
    absl::StatusOr<std::string> text = ReadInput(args.from_report);
    if (!text.ok()) return fail(kExitLocalIo, std::string(text.status().message()));
    absl::StatusOr<std::vector<delivery::PublishEntry>> more =
        delivery::EntriesFromBatchReport(*text, args.from_report == "-" ? "stdin" : args.from_report);
    if (!more.ok()) {
      return fail(absl::IsFailedPrecondition(more.status()) ? kExitBakeFailed : kExitUsage,
                  std::string(more.status().message()));
    }
    entries->insert(entries->end(), more->begin(), more->end());
  }
  absl::StatusOr<std::unique_ptr<sdk::Transport>> transport =
      sdk::Transport::Connect(ClientOptionsFor(args, kInteractiveOutageSeconds));
  if (!transport.ok()) return fail(kExitServer, Describe(transport.status()));
  delivery::PublishOptions options;
  options.out = args.out;
  options.channel = args.channel;
  options.include_quality_views = args.include_quality_views;
  options.sign_key_file = args.sign_key;
  absl::StatusOr<delivery::PublishReport> published = delivery::Publish(**transport, *entries, options);
  if (!published.ok()) {
    const absl::Status& s = published.status();
    int code = ReleaseExitCode(s);
    if (absl::IsNotFound(s) && !sdk::GetRpcErrorInfo(s).has_value()) code = kExitBakeFailed;
    return fail(code, Describe(s));
  }
  report["catalog_sha256"] = published->catalog_sha256;
  report["catalog_path"] = published->catalog_path;
  report["channel_path"] = published->channel_path;
  report["assets"] = published->assets;
  report["blobs_written"] = published->blobs_written;
  report["blobs_present"] = published->blobs_present;
  report["bytes_written"] = published->bytes_written;
  report["catalog_reused"] = published->catalog_reused;
  report["channel_changed"] = published->channel_changed;
  report["wall_seconds"] = SecondsSince(start);
  report["exit_code"] = kExitOk;
  if (args.json) {
    PrintJson(report);
  } else {
    std::printf("%s\n", (fs::path(args.out) / published->channel_path).string().c_str());
    std::fflush(stdout);
  }
  if (!args.quiet && !args.json) {
    std::fprintf(stderr,
                 "published %d assets to channel %s: catalog %s%s, %d blobs written (%s), %d already there, %.1f s\n",
                 published->assets, args.channel.c_str(), published->catalog_sha256.substr(0, 12).c_str(),
                 published->catalog_reused ? " (unchanged)" : "", published->blobs_written,
                 HumanBytes(published->bytes_written).c_str(), published->blobs_present, SecondsSince(start));
  }
  return kExitOk;
}

int RunCatalogLs(const CliArgs& args) {
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = OpenReleaseCache(args);
  if (!cache.ok()) return Fail(ReleaseExitCode(cache.status()), Describe(cache.status()));
  absl::StatusOr<std::string> text = (*cache)->CatalogJson(/*force_refresh=*/true);
  if (!text.ok()) return Fail(ReleaseExitCode(text.status()), Describe(text.status()));
  if (args.json) {
    std::printf("%s\n", text->c_str());
    std::fflush(stdout);
    return kExitOk;
  }
  absl::StatusOr<delivery::Catalog> catalog = delivery::ParseCatalog(*text, "catalog");
  if (!catalog.ok()) return Fail(kExitServer, Describe(catalog.status()));
  int64_t total = 0;
  for (const auto& [name, asset] : catalog->assets) {
    int64_t bytes = 0;
    for (const auto& f : asset.files) bytes += f.size_bytes;
    total += bytes;
    std::printf("%s  %s  %s  %s  %zu files  %s\n", name.c_str(), asset.cache_key.c_str(), asset.product.c_str(),
                asset.layout.c_str(), asset.files.size(), HumanBytes(bytes).c_str());
  }
  std::printf("%zu assets, %s; channel %s, catalog %s (created %s, baker %s)\n", catalog->assets.size(),
              HumanBytes(total).c_str(), args.channel.c_str(), Sha256Hex(*text).substr(0, 12).c_str(),
              catalog->created_at.c_str(), catalog->baker_version.c_str());
  std::fflush(stdout);
  return kExitOk;
}

int RunFetchFromMirrors(const CliArgs& args) {
  const auto start = std::chrono::steady_clock::now();
  nlohmann::json report = {{"name", args.target},          {"cache_key", nullptr}, {"out_dir", args.out},
                           {"manifest", nullptr},          {"files", nlohmann::json::array()},
                           {"downloaded", false},          {"size_bytes", 0},      {"error", nullptr}};
  auto finish = [&](int code, const std::string& error) {
    report["wall_seconds"] = SecondsSince(start);
    if (code != kExitOk) report["error"] = error;
    report["exit_code"] = code;
    if (args.json) PrintJson(report);
    return code == kExitOk ? code : Fail(code, error);
  };
  if (!IsSha256Hex(args.target)) {
    if (absl::Status s = delivery::ValidateAssetName(args.target); !s.ok()) {
      return finish(kExitUsage, std::string(s.message()));
    }
  }
  absl::StatusOr<std::unique_ptr<sdk::Cache>> cache = OpenReleaseCache(args);
  if (!cache.ok()) return finish(ReleaseExitCode(cache.status()), Describe(cache.status()));
  absl::StatusOr<sdk::CachedResult> result = (*cache)->Get(args.target);
  if (!result.ok()) return finish(ReleaseExitCode(result.status()), Describe(result.status()));
  std::error_code ec;
  fs::create_directories(args.out, ec);
  if (ec) return finish(kExitLocalIo, Describe(sdk::LocalIoError("cannot create", args.out, ec.value())));
  for (const sdk::CachedFile& f : result->files()) {
    const fs::path to = fs::path(args.out) / f.path.filename();
    if (absl::Status s = Place(f.path, to); !s.ok()) return finish(kExitLocalIo, Describe(s));
    report["files"].push_back(to.string());
    if (f.semantic == "manifest") report["manifest"] = to.string();
  }
  report["cache_key"] = result->key();
  report["downloaded"] = result->downloaded();
  report["size_bytes"] = result->size_bytes();
  if (!args.json) {
    for (const auto& f : report["files"]) std::printf("%s\n", f.get<std::string>().c_str());
    std::fflush(stdout);
  }
  if (!args.quiet && !args.json) {
    std::fprintf(stderr, "fetched %s (%s) -> %s: %s, %s, %.1f s\n", args.target.c_str(),
                 result->key().substr(0, 12).c_str(), args.out.c_str(),
                 result->downloaded() ? "downloaded" : "from the cache", HumanBytes(result->size_bytes()).c_str(),
                 SecondsSince(start));
  }
  return finish(kExitOk, "");
}

}  // namespace impostor::cli
