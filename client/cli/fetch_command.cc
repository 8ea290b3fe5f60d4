// impostor fetch: download a baked result by cache key.
#include <chrono>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "client/cli/commands.h"
#include "client/cli/connection_options.h"
#include "client/cli/output.h"
#include "impostor/client.h"

namespace impostor::cli {

int RunFetch(const CliArgs& args) {
  if (!args.mirrors.empty()) return RunFetchFromMirrors(args);
  const auto start = std::chrono::steady_clock::now();
  nlohmann::json report = {{"cache_key", args.target},      {"out_dir", args.out},     {"manifest", nullptr},
                           {"files", nlohmann::json::array()}, {"downloaded_bytes", 0}, {"reused_bytes", 0},
                           {"wall_seconds", 0.0},           {"error", nullptr}};
  auto finish = [&](int code, const std::string& error) {
    report["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (code != kExitOk) report["error"] = error;
    if (args.json) PrintJson(report);
    return code == kExitOk ? code : Fail(code, error);
  };

  // Over the farm's HTTP front end alone when one is named (no gRPC
  // channel), else, or when it cannot give the result, over gRPC.
  absl::StatusOr<sdk::FetchResult> fetched =
      sdk::FetchFromFarm(ClientOptionsFor(args, kInteractiveOutageSeconds), args.target, args.out);
  if (!fetched.ok()) {
    // Options the SDK refuses (before any connection) exit 3, as a
    // connection that fails does.
    if (absl::IsInvalidArgument(fetched.status()) && !sdk::GetRpcErrorInfo(fetched.status())) {
      return finish(kExitServer, Describe(fetched.status()));
    }
    return finish(ExitCodeFor(fetched.status()), Describe(fetched.status()));
  }

  report["manifest"] = fetched->manifest_path.string();
  for (const auto& f : fetched->files) report["files"].push_back(f.string());
  report["downloaded_bytes"] = fetched->bytes_downloaded;
  report["reused_bytes"] = fetched->bytes_reused;
  if (!args.json) {
    std::printf("%s\n", fetched->manifest_path.string().c_str());
    for (const auto& f : fetched->files) {
      if (f != fetched->manifest_path) std::printf("%s\n", f.string().c_str());
    }
    std::fflush(stdout);
  }
  if (!args.quiet) {
    std::fprintf(stderr, "fetched %s -> %s: downloaded %s, reused %s, %.1f s\n", args.target.c_str(),
                 args.out.c_str(), HumanBytes(fetched->bytes_downloaded).c_str(),
                 HumanBytes(fetched->bytes_reused).c_str(), fetched->seconds);
  }
  return finish(kExitOk, "");
}

}  // namespace impostor::cli
