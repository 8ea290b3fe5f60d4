#include "client/cli/cli_args.h"

#include <charconv>
#include <map>
#include <optional>
#include <set>
#include <string_view>

#include "absl/strings/str_cat.h"

namespace impostor::cli {
namespace {

struct CommandSpec {
  Command command;
  std::set<std::string> value_flags;  // take a value
  std::set<std::string> bool_flags;
  bool needs_out;
  const char* target_name;
};

const std::map<std::string, CommandSpec>& Commands() {
  static const auto* commands = new std::map<std::string, CommandSpec>{
      {"bake",
       {Command::kBake, {"--layout", "--frames", "--resolution", "--out", "--server"}, {"--json", "--quiet"}, true,
        "MODEL"}},
      {"fetch", {Command::kFetch, {"--out", "--server"}, {"--json", "--quiet"}, true, "KEY"}},
      {"status", {Command::kStatus, {"--server"}, {"--json"}, false, "JOB_ID"}},
      {"cancel", {Command::kCancel, {"--server"}, {"--json"}, false, "JOB_ID"}},
  };
  return *commands;
}

absl::Status Usage(std::string message) { return absl::InvalidArgumentError(std::move(message)); }

// Whole decimal numbers only: "abc", "-1", "12x", "1e3" and overflow are
// usage errors; the value's range is the server's to judge.
absl::StatusOr<uint32_t> ParseNumber(const std::string& flag, const std::string& value) {
  uint32_t n = 0;
  const char* end = value.data() + value.size();
  auto [ptr, ec] = std::from_chars(value.data(), end, n);
  if (value.empty() || ec != std::errc() || ptr != end) {
    return Usage(absl::StrCat(flag, ": expected a whole number, got \"", value, "\""));
  }
  return n;
}

}  // namespace

absl::StatusOr<CliArgs> ParseCliArgs(const std::vector<std::string>& args, const char* env_server) {
  CliArgs out;
  if (env_server != nullptr && env_server[0] != '\0') out.server = env_server;
  for (const std::string& a : args) {
    if (a == "--") break;
    if (a == "--help" || a == "-h") return out;  // kHelp
  }
  if (args.empty()) return Usage("missing command");
  const std::string& name = args[0];
  if (name == "help") return out;
  if (name == "version" || name == "--version") {
    if (args.size() > 1) return Usage(absl::StrCat("unexpected argument \"", args[1], "\" for 'version'"));
    out.command = Command::kVersion;
    return out;
  }
  auto it = Commands().find(name);
  if (it == Commands().end()) {
    if (name.rfind("-", 0) == 0) return Usage(absl::StrCat("unknown flag ", name, " before the command"));
    return Usage(absl::StrCat("unknown command \"", name, "\""));
  }
  const CommandSpec& spec = it->second;
  out.command = spec.command;

  std::vector<std::string> positional;
  bool flags_done = false;
  bool out_given = false;
  for (size_t i = 1; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (flags_done || arg.size() < 2 || arg[0] != '-') {
      positional.push_back(arg);
      continue;
    }
    if (arg == "--") {
      flags_done = true;
      continue;
    }
    // --flag=value or --flag value.
    std::string flag = arg;
    std::optional<std::string> value;
    if (const size_t eq = arg.find('='); eq != std::string::npos) {
      flag = arg.substr(0, eq);
      value = arg.substr(eq + 1);
    }
    if (spec.bool_flags.contains(flag)) {
      if (value.has_value()) return Usage(absl::StrCat(flag, " takes no value"));
      if (flag == "--json") out.json = true;
      if (flag == "--quiet") out.quiet = true;
      continue;
    }
    if (!spec.value_flags.contains(flag)) {
      return Usage(absl::StrCat("unknown flag ", flag, " for '", name, "'"));
    }
    if (!value.has_value()) {
      // A following flag is not a value: "--out --json" forgot the value.
      if (i + 1 >= args.size() || args[i + 1].rfind("--", 0) == 0) {
        return Usage(absl::StrCat(flag, ": missing value"));
      }
      value = args[++i];
    }
    if (flag == "--out") {
      if (value->empty()) return Usage("--out: missing value");
      out.out = *value;
      out_given = true;
    } else if (flag == "--server") {
      if (value->empty()) return Usage("--server: missing value");
      out.server = *value;
    } else if (flag == "--layout") {
      if (*value != "octahedral" && *value != "hemi-octahedral") {
        return Usage(absl::StrCat("--layout: unknown layout \"", *value,
                                  "\"; expected octahedral or hemi-octahedral"));
      }
      out.layout = *value;
    } else if (flag == "--frames" || flag == "--resolution") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      (flag == "--frames" ? out.frames : out.resolution) = *n;
    }
  }
  if (positional.empty()) return Usage(absl::StrCat("'", name, "' needs ", spec.target_name));
  if (positional.size() > 1) {
    return Usage(absl::StrCat("unexpected argument \"", positional[1], "\" for '", name, "'"));
  }
  out.target = positional[0];
  if (out.target.empty()) return Usage(absl::StrCat("'", name, "': ", spec.target_name, " is empty"));
  if (spec.needs_out && !out_given) return Usage(absl::StrCat("'", name, "' needs --out DIR"));
  return out;
}

std::string UsageText() {
  return R"(impostor - bake glTF models into impostor atlases on an impostor bake farm

Usage:
  impostor bake MODEL --out DIR [--layout octahedral|hemi-octahedral]
                [--frames N] [--resolution R] [--server HOST:PORT] [--json] [--quiet]
      Uploads MODEL (.gltf or .glb, with the files it refers to; only what the
      server lacks), bakes it, shows progress on stderr, and downloads the
      atlas into DIR (manifest.json, albedo_alpha.png, normal_depth.png,
      orm.png). Prints the paths of the files on stdout.
        --layout      view directions: octahedral (full sphere, default) or
                      hemi-octahedral (upper hemisphere)
        --frames N    frames per atlas axis (server default 12, range 2..64)
        --resolution R atlas side in pixels (server default 2048, range
                      64..8192 and at least 8 * frames)
        --quiet       no progress output
  impostor fetch KEY --out DIR [--server HOST:PORT] [--json] [--quiet]
      Downloads the result baked under cache key KEY into DIR. Files already
      in DIR with the right content are kept.
  impostor status JOB_ID [--server HOST:PORT] [--json]
      Shows a job's state.
  impostor cancel JOB_ID [--server HOST:PORT] [--json]
      Cancels a queued or running job.
  impostor help | --help | -h
  impostor version

Common flags:
  --server HOST:PORT  the bake server (default $IMPOSTOR_SERVER, else localhost:50051)
  --json              print one JSON object on stdout instead of text; bake prints
                      {model, cache_key, job_id, cached, out_dir, manifest, files,
                      wall_seconds, uploaded_bytes, error}
  Flags take their value as "--flag VALUE" or "--flag=VALUE"; "--" ends the flags.

Exit codes:
  0  success
  1  the bake failed, was cancelled, or the server refused the request as invalid
  2  usage error (unknown flag, missing value, not a number, ...)
  3  cannot reach the server, or an RPC failed
  4  local I/O error (model not found or unusable, cannot write DIR)
Every failure prints exactly one line "impostor: <reason>" on stderr.

Environment:
  IMPOSTOR_SERVER     default for --server
  IMPOSTOR_LOG        spdlog level for diagnostics on stderr (e.g. debug; default off)
)";
}

}  // namespace impostor::cli
