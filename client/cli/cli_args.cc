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
       {Command::kBake, {"--layout", "--frames", "--resolution", "--out", "--server", "--product", "--preset", "--point-budget"}, {"--json", "--quiet"}, true,
        "MODEL"}},
      {"fetch", {Command::kFetch, {"--out", "--server"}, {"--json", "--quiet"}, true, "KEY"}},
      {"status", {Command::kStatus, {"--server"}, {"--json"}, false, "JOB_ID"}},
      {"cancel", {Command::kCancel, {"--server"}, {"--json"}, false, "JOB_ID"}},
      // "cache VERB": the local result cache; no target = no positional.
      {"cache get", {Command::kCacheGet, {"--server", "--cache-dir"}, {"--json", "--quiet"}, false, "KEY"}},
      {"cache ls", {Command::kCacheLs, {"--cache-dir"}, {"--json"}, false, nullptr}},
      {"cache gc", {Command::kCacheGc, {"--cache-dir", "--max-bytes"}, {"--json", "--verify"}, false, nullptr}},
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
  // "cache" takes a verb: the command is the pair.
  std::string command_name = name;
  size_t first_arg = 1;
  if (name == "cache") {
    if (args.size() < 2 || args[1].rfind("-", 0) == 0) return Usage("'cache' needs a subcommand: get, ls or gc");
    command_name = "cache " + args[1];
    first_arg = 2;
  }
  auto it = Commands().find(command_name);
  if (it == Commands().end()) {
    if (name.rfind("-", 0) == 0) return Usage(absl::StrCat("unknown flag ", name, " before the command"));
    return Usage(absl::StrCat("unknown command \"", command_name, "\""));
  }
  const CommandSpec& spec = it->second;
  out.command = spec.command;

  std::vector<std::string> positional;
  bool flags_done = false;
  bool out_given = false;
  for (size_t i = first_arg; i < args.size(); ++i) {
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
      if (flag == "--verify") out.verify = true;
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
    if (flag == "--cache-dir") {
      if (value->empty()) return Usage("--cache-dir: missing value");
      out.cache_dir = *value;
    } else if (flag == "--max-bytes") {
      int64_t n = 0;
      const char* end = value->data() + value->size();
      auto [ptr, ec] = std::from_chars(value->data(), end, n);
      if (value->empty() || ec != std::errc() || ptr != end || n < 0) {
        return Usage(absl::StrCat("--max-bytes: expected a whole number of bytes >= 0, got \"", *value, "\""));
      }
      out.max_bytes = n;
    } else if (flag == "--out") {
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
    } else if (flag == "--product") {
      if (*value != "atlas" && *value != "surfels") {
        return Usage(absl::StrCat("--product: unknown product \"", *value, "\"; expected atlas or surfels"));
      }
      out.product = *value;
    } else if (flag == "--preset") {
      if (value->empty()) return Usage("--preset: missing value");
      out.preset = *value;
    } else if (flag == "--point-budget") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      out.point_budget = *n;
    } else if (flag == "--frames" || flag == "--resolution") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      (flag == "--frames" ? out.frames : out.resolution) = *n;
    }
  }
  if (spec.target_name == nullptr) {
    if (!positional.empty()) {
      return Usage(absl::StrCat("unexpected argument \"", positional[0], "\" for '", command_name, "'"));
    }
    return out;
  }
  if (positional.empty()) return Usage(absl::StrCat("'", command_name, "' needs ", spec.target_name));
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
                [--product atlas|surfels] [--preset NAME] [--point-budget N]
      Uploads MODEL (.gltf or .glb, with the files it refers to; only what the
      server lacks), bakes it, shows progress on stderr, and downloads the
      atlas into DIR (manifest.json, albedo_alpha.png, normal_depth.png,
      orm.png). Prints the paths of the files on stdout.
        --layout      view directions: octahedral (full sphere, default) or
                      hemi-octahedral (upper hemisphere)
        --frames N    frames per atlas axis (server default 12, range 2..64)
        --resolution R atlas side in pixels (server default 2048, range
                      64..8192 and at least 8 * frames)
        --product P   atlas (default) or surfels: a point cloud for foliage at
                      extreme distance (surfels.bin: 12 float32 per point,
                      surfels.ply), read from a capture of --frames and
                      --resolution
        --preset NAME surfels: prop (2048 points, 12 frames, 512 px), building
                      (16384, 16, 1024), vegetation (32768, 24, 2048, the
                      default) or hero (65536, 32, 2048); explicit flags win
        --point-budget N surfels: most points in the cloud (range 1..4194304)
        --quiet       no progress output
  impostor fetch KEY --out DIR [--server HOST:PORT] [--json] [--quiet]
      Downloads the result baked under cache key KEY into DIR. Files already
      in DIR with the right content are kept.
  impostor status JOB_ID [--server HOST:PORT] [--json]
      Shows a job's state.
  impostor cancel JOB_ID [--server HOST:PORT] [--json]
      Cancels a queued or running job.
  impostor cache get KEY [--cache-dir DIR] [--server HOST:PORT] [--json] [--quiet]
      Puts the result KEY in the local cache (downloaded only when not there
      yet, verified, installed atomically) and prints its files' paths.
  impostor cache ls [--cache-dir DIR] [--json]
      Lists the cached results, most recently used first.
  impostor cache gc [--cache-dir DIR] [--max-bytes N] [--verify] [--json]
      Evicts least recently used results down to N bytes (default: the
      cache's 2 GiB cap), removes partial downloads not in use and, with
      --verify, re-hashes every result and drops damaged ones.
      --cache-dir DIR defaults to $IMPOSTOR_CACHE_DIR, else
      $XDG_CACHE_HOME/impostor, else ~/.cache/impostor.
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
  IMPOSTOR_CACHE_DIR  default for --cache-dir
  IMPOSTOR_LOG        spdlog level for diagnostics on stderr (e.g. debug; default off)
)";
}

}  // namespace impostor::cli
