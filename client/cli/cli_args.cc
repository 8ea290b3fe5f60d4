#include "client/cli/cli_args.h"

#include <algorithm>
#include <charconv>
#include <map>
#include <optional>
#include <set>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "common/net/keepalive.h"
#include "common/net/server_list.h"

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
       {Command::kBake, {"--max-outage-seconds", "--priority", "--require-tag", "--client-id", "--layout", "--ring", "--supersampling", "--frames", "--resolution", "--out", "--server", "--product", "--preset", "--point-budget", "--lod-ratios", "--lod-pixel-error", "--max-planes", "--tolerance", "--min-iou", "--min-psnr", "--quality-views", "--texture-format", "--albedo-codec"}, {"--json", "--quiet", "--keep-going", "--emissive", "--array", "--follow-symlinks"}, true,
        "MODEL"}},
      {"bake-batch",
       {Command::kBakeBatch, {"--max-outage-seconds", "--out", "--server", "--priority", "--client-id"}, {"--json", "--quiet", "--keep-going", "--follow-symlinks"},
        true, "SPEC"}},
      {"fetch", {Command::kFetch, {"--max-outage-seconds", "--out", "--server", "--mirror", "--channel", "--cache-dir", "--catalog-key"}, {"--json", "--quiet"}, true, "KEY"}},
      {"publish", {Command::kPublish, {"--max-outage-seconds", "--out", "--server", "--channel", "--from-report", "--sign-key"}, {"--json", "--quiet", "--include-quality-views"}, true, "KEY or NAME=KEY"}},
      {"catalog ls", {Command::kCatalogLs, {"--mirror", "--channel", "--cache-dir", "--catalog-key"}, {"--json"}, false, nullptr}},
      // --out is optional: quality_command.cc picks ./quality-KEY12.
      {"quality", {Command::kQuality, {"--max-outage-seconds", "--out", "--server"}, {"--json", "--quiet", "--all-views"}, false, "KEY"}},
      {"status", {Command::kStatus, {"--max-outage-seconds", "--server"}, {"--json"}, false, "JOB_ID"}},
      {"cancel", {Command::kCancel, {"--max-outage-seconds", "--server"}, {"--json"}, false, "JOB_ID"}},
      // "cache VERB": the local result cache; no target = no positional.
      {"cache get", {Command::kCacheGet, {"--max-outage-seconds", "--server", "--cache-dir"}, {"--json", "--quiet"}, false, "KEY"}},
      {"cache ls", {Command::kCacheLs, {"--cache-dir"}, {"--json"}, false, nullptr}},
      {"cache gc", {Command::kCacheGc, {"--cache-dir", "--max-bytes"}, {"--json", "--verify"}, false, nullptr}},
      // "admin VERB": administration, admin tokens only (issue 14).
      {"admin purge", {Command::kAdminPurge, {"--max-outage-seconds", "--server", "--worker"}, {"--json"}, false, nullptr}},
  };
  return *commands;
}

absl::Status Usage(std::string message) { return absl::InvalidArgumentError(std::move(message)); }

// Whole decimal numbers only: "abc", "-1", "12x", "1e3" and overflow are
// usage errors; the value's range is the server's to judge (its message
// names the range), but no count is negative.
absl::StatusOr<uint32_t> ParseNumber(const std::string& flag, const std::string& value) {
  uint32_t n = 0;
  const char* end = value.data() + value.size();
  auto [ptr, ec] = std::from_chars(value.data(), end, n);
  if (value.empty() || ec != std::errc() || ptr != end) {
    return Usage(absl::StrCat(flag, ": expected a whole number, 0 or more, got \"", value, "\""));
  }
  return n;
}

}  // namespace

absl::StatusOr<CliArgs> ParseCliArgs(const std::vector<std::string>& args, const char* env_server) {
  CliArgs out;
  if (env_server != nullptr && env_server[0] != '\0') {
    out.server = env_server;
    out.server_given = true;
  }
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
  if (name == "catalog") {
    if (args.size() < 2 || args[1].rfind("-", 0) == 0) return Usage("'catalog' needs a subcommand: ls");
    command_name = "catalog " + args[1];
    first_arg = 2;
  }
  if (name == "admin") {
    if (args.size() < 2 || args[1].rfind("-", 0) == 0) return Usage("'admin' needs a subcommand: purge");
    command_name = "admin " + args[1];
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
  bool layout_given = false;
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
      if (flag == "--keep-going") out.keep_going = true;
      if (flag == "--emissive") out.emissive = true;
      if (flag == "--array") out.texture_array = true;
      if (flag == "--follow-symlinks") out.follow_symlinks = true;
      if (flag == "--all-views") out.all_views = true;
      if (flag == "--include-quality-views") out.include_quality_views = true;
      continue;
    }
    // Transport security: every command that takes --server takes these.
    if (spec.value_flags.contains("--server") && (flag == "--tls-ca" || flag == "--tls-cert" ||
                                                  flag == "--tls-key" || flag == "--tls-server-name")) {
      if (!value.has_value()) {
        if (i + 1 >= args.size() || args[i + 1].rfind("--", 0) == 0) {
          return Usage(absl::StrCat(flag, ": missing value"));
        }
        value = args[++i];
      }
      if (value->empty()) return Usage(absl::StrCat(flag, ": missing value"));
      (flag == "--tls-ca"     ? out.tls_ca
       : flag == "--tls-cert" ? out.tls_cert
       : flag == "--tls-key"  ? out.tls_key
                              : out.tls_server_name) = *value;
      continue;
    }
    // Identity (issue 14): --token-file on every command that talks to the
    // server (those that take --server).
    if (flag == "--token-file" && spec.value_flags.contains("--server")) {
      if (!value.has_value() && i + 1 < args.size() && args[i + 1].rfind("--", 0) != 0) value = args[++i];
      if (!value.has_value() || value->empty()) return Usage("--token-file: missing value");
      out.token_file = *value;
      continue;
    }
    // The farm's HTTP front end (issue 45): every command that talks to the
    // server; the SDK checks the URL (ClientOptions::farm_http).
    if (flag == "--farm-http" && spec.value_flags.contains("--server")) {
      if (!value.has_value() && i + 1 < args.size() && args[i + 1].rfind("--", 0) != 0) value = args[++i];
      if (!value.has_value() || value->empty()) return Usage("--farm-http: missing value");
      out.farm_http = *value;
      continue;
    }
    // Keepalive (issue 15): every command that talks to the server.
    if (flag == "--keepalive-seconds" && spec.value_flags.contains("--server")) {
      if (!value.has_value() && i + 1 < args.size() && args[i + 1].rfind("--", 0) != 0) value = args[++i];
      if (!value.has_value() || value->empty()) return Usage("--keepalive-seconds: missing value");
      int seconds = 0;
      const char* end = value->data() + value->size();
      auto [ptr, ec] = std::from_chars(value->data(), end, seconds);
      if (ec != std::errc() || ptr != end || seconds < kMinKeepaliveSeconds || seconds > kMaxKeepaliveSeconds) {
        return Usage(absl::StrCat("--keepalive-seconds: expected a whole number of seconds in ", kMinKeepaliveSeconds,
                                  "..", kMaxKeepaliveSeconds, ", got \"", *value, "\""));
      }
      out.keepalive_seconds = seconds;
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
    if (flag == "--require-tag") {
      out.required_tags.push_back(*value);
      continue;
    }
    if (flag == "--priority") {
      int32_t n = 0;
      const char* end = value->data() + value->size();
      auto [ptr, ec] = std::from_chars(value->data(), end, n);
      if (value->empty() || ec != std::errc() || ptr != end || n < -100 || n > 100) {
        return Usage(absl::StrCat("--priority: expected a whole number in -100..100, got \"", *value, "\""));
      }
      out.priority = n;
      continue;
    }
    if (flag == "--max-outage-seconds") {
      double seconds = 0;
      const char* end = value->data() + value->size();
      auto [ptr, ec] = std::from_chars(value->data(), end, seconds);
      if (value->empty() || ec != std::errc() || ptr != end || !(seconds >= 0 && seconds <= 86400)) {
        return Usage(absl::StrCat("--max-outage-seconds: expected a number of seconds in 0..86400, got \"", *value,
                                  "\""));
      }
      out.max_outage_seconds = seconds;
      continue;
    }
    if (flag == "--client-id") {
      if (value->empty()) return Usage("--client-id: missing value");
      out.client_id = *value;
      continue;
    }
    if (flag == "--worker") {
      if (value->empty()) return Usage("--worker: missing value");
      out.worker = *value;
      continue;
    }
    if (flag == "--mirror") {
      size_t start = 0;
      while (start <= value->size()) {
        const size_t end = std::min(value->find(',', start), value->size());
        const std::string url = value->substr(start, end - start);
        if (url.rfind("http://", 0) != 0 && url.rfind("https://", 0) != 0) {
          return Usage(absl::StrCat("--mirror: \"", url.substr(0, 80),
                                    "\" is not an http:// or https:// base URL (the folder that holds v1/)"));
        }
        out.mirrors.push_back(url);
        start = end + 1;
      }
      continue;
    }
    if (flag == "--channel" || flag == "--catalog-key" || flag == "--from-report" || flag == "--sign-key") {
      if (value->empty()) return Usage(absl::StrCat(flag, ": missing value"));
      (flag == "--channel"       ? out.channel
       : flag == "--catalog-key" ? out.catalog_key
       : flag == "--from-report" ? out.from_report
                                 : out.sign_key) = *value;
      continue;
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
      // One address or a comma list of replicas (issue 15).
      if (auto targets = ParseServerList(*value, "--server"); !targets.ok()) return targets.status();
      out.server = *value;
      out.server_given = true;
    } else if (flag == "--layout") {
      if (*value != "octahedral" && *value != "hemi-octahedral" && *value != "azimuth-elevation" &&
          *value != "ring-top" && *value != "billboard") {
        return Usage(absl::StrCat("--layout: unknown layout \"", *value,
                                  "\"; expected octahedral, hemi-octahedral, azimuth-elevation, ring-top or billboard"));
      }
      out.layout = *value;
      layout_given = true;
    } else if (flag == "--ring") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      out.ring_views = *n;
    } else if (flag == "--supersampling") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      out.supersampling = *n;
    } else if (flag == "--product") {
      if (*value != "atlas" && *value != "surfels" && *value != "lod-chain" && *value != "cards") {
        return Usage(
            absl::StrCat("--product: unknown product \"", *value, "\"; expected atlas, surfels, lod-chain or cards"));
      }
      out.product = *value;
    } else if (flag == "--preset") {
      if (value->empty()) return Usage("--preset: missing value");
      out.preset = *value;
    } else if (flag == "--texture-format") {
      if (*value != "png" && *value != "ktx2") {
        return Usage(absl::StrCat("--texture-format: unknown format \"", *value, "\"; expected png or ktx2"));
      }
      out.texture_format = *value;
    } else if (flag == "--albedo-codec") {
      if (*value != "uastc" && *value != "uastc-rdo") {
        return Usage(absl::StrCat("--albedo-codec: unknown codec \"", *value, "\"; expected uastc or uastc-rdo"));
      }
      out.albedo_codec = *value;
    } else if (flag == "--lod-ratios") {
      // "0.5,0.1": plain decimal numbers; their rules are the server's.
      out.lod_ratios.clear();
      size_t start = 0;
      while (start <= value->size()) {
        const size_t end = std::min(value->find(',', start), value->size());
        const std::string item = value->substr(start, end - start);
        float r = 0;
        auto [ptr, ec] = std::from_chars(item.data(), item.data() + item.size(), r);
        if (item.empty() || ec != std::errc() || ptr != item.data() + item.size()) {
          return Usage(absl::StrCat("--lod-ratios: expected comma-separated numbers like 0.5,0.1, got \"", *value, "\""));
        }
        out.lod_ratios.push_back(r);
        start = end + 1;
      }
    } else if (flag == "--lod-pixel-error") {
      // The batch key's range (the server's), checked here so that a value
      // out of it is a usage error naming the flag, as in a batch spec.
      float e = 0;
      auto [ptr, ec] = std::from_chars(value->data(), value->data() + value->size(), e);
      if (value->empty() || ec != std::errc() || ptr != value->data() + value->size()) {
        return Usage(absl::StrCat("--lod-pixel-error: expected a number like 1, got \"", *value, "\""));
      }
      if (!(e >= kLodPixelErrorMin && e <= kLodPixelErrorMax)) {
        return Usage(absl::StrCat("--lod-pixel-error: ", *value, " is out of range ", kLodPixelErrorMin, "..",
                                  kLodPixelErrorMax));
      }
      out.lod_pixel_error = e;
    } else if (flag == "--max-planes") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      out.max_planes = *n;
    } else if (flag == "--tolerance") {
      float e = 0;
      auto [ptr, ec] = std::from_chars(value->data(), value->data() + value->size(), e);
      if (value->empty() || ec != std::errc() || ptr != value->data() + value->size()) {
        return Usage(absl::StrCat("--tolerance: expected a number like 0.05, got \"", *value, "\""));
      }
      out.tolerance = e;
    } else if (flag == "--point-budget") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      out.point_budget = *n;
    } else if (flag == "--frames" && *value == "auto") {
      out.frames_auto = true;
      out.frames = 0;
    } else if (flag == "--min-iou" || flag == "--min-psnr") {
      float x = 0;
      auto [ptr, ec] = std::from_chars(value->data(), value->data() + value->size(), x);
      if (value->empty() || ec != std::errc() || ptr != value->data() + value->size()) {
        return Usage(absl::StrCat(flag, ": expected a number like ", flag == "--min-iou" ? "0.95" : "30",
                                  ", got \"", *value, "\""));
      }
      (flag == "--min-iou" ? out.min_iou : out.min_psnr_db) = x;
    } else if (flag == "--quality-views") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      out.quality_views = *n;
    } else if (flag == "--frames" || flag == "--resolution") {
      absl::StatusOr<uint32_t> n = ParseNumber(flag, *value);
      if (!n.ok()) return n.status();
      (flag == "--frames" ? out.frames : out.resolution) = *n;
    }
  }
  // TLS flags that cannot work together.
  if (out.tls_cert.empty() != out.tls_key.empty()) {
    return Usage(out.tls_cert.empty() ? "--tls-key: needs --tls-cert too (mutual TLS)"
                                      : "--tls-cert: needs --tls-key too (mutual TLS)");
  }
  if (out.tls_ca.empty() && !out.tls_cert.empty()) {
    return Usage("--tls-cert and --tls-key: need --tls-ca (the CA that signed the server's certificate)");
  }
  if (out.tls_ca.empty() && !out.tls_server_name.empty()) return Usage("--tls-server-name: needs --tls-ca");
  if (out.command == Command::kAdminPurge && out.worker.empty()) {
    return Usage("--worker: required (the worker token's name, as `impostor-server token list` shows)");
  }
  // A LOD chain's impostor defaults to the hemisphere (the server's choice).
  if (out.product == "lod-chain" && !layout_given) out.layout.clear();
  if ((out.command == Command::kCatalogLs || out.command == Command::kPublish) && out.channel.empty()) {
    return Usage("--channel: required (the release channel, e.g. nightly)");
  }
  if (out.command == Command::kCatalogLs && out.mirrors.empty()) {
    return Usage("--mirror: required (the base URL of a published release)");
  }
  if (out.command == Command::kFetch && out.mirrors.empty() != out.channel.empty()) {
    return Usage(out.mirrors.empty() ? "--channel: needs --mirror" : "--mirror: needs --channel (the release channel)");
  }
  if (out.command == Command::kPublish) {
    if (positional.empty() && out.from_report.empty()) {
      return Usage("'publish' needs cache keys, NAME=KEY pairs or --from-report FILE");
    }
    if (!out_given) return Usage("'publish' needs --out DIR (the release root)");
    out.targets = positional;
    if (!positional.empty()) out.target = positional[0];
    return out;
  }
  if (spec.target_name == nullptr) {
    if (!positional.empty()) {
      return Usage(absl::StrCat("unexpected argument \"", positional[0], "\" for '", command_name, "'"));
    }
    return out;
  }
  if (positional.empty()) return Usage(absl::StrCat("'", command_name, "' needs ", spec.target_name));
  // bake takes several models: a batch (batch_command.cc).
  if (positional.size() > 1 && spec.command != Command::kBake) {
    return Usage(absl::StrCat("unexpected argument \"", positional[1], "\" for '", name, "'"));
  }
  for (const std::string& p : positional) {
    if (p.empty()) return Usage(absl::StrCat("'", name, "': ", spec.target_name, " is empty"));
  }
  out.targets = positional;
  out.target = positional[0];
  if (out.target.empty()) return Usage(absl::StrCat("'", name, "': ", spec.target_name, " is empty"));
  // A KEY that cannot be one is a usage error here, not a server's answer.
  if ((spec.command == Command::kFetch || spec.command == Command::kQuality) && !IsSha256Hex(out.target) &&
      !(spec.command == Command::kFetch && !out.mirrors.empty())) {
    return Usage(absl::StrCat("cache key \"", out.target.substr(0, 80),
                              "\": expected 64 lowercase hex characters (as `impostor bake --json` prints it)"));
  }
  if (spec.needs_out && !out_given) return Usage(absl::StrCat("'", name, "' needs --out DIR"));
  return out;
}

std::string UsageText() {
  return R"(impostor - bake glTF models into impostor atlases on an impostor bake farm

Usage:
  impostor bake MODEL --out DIR [--layout L] [--ring K]
                [--frames N] [--resolution R] [--server HOST:PORT] [--json] [--quiet]
                [--product atlas|surfels|lod-chain|cards] [--preset NAME] [--point-budget N]
                [--lod-ratios R1,R2,...] [--lod-pixel-error E] [--max-planes N] [--tolerance E]
      Uploads MODEL (.gltf or .glb, with the files it refers to; only what the
      server lacks), bakes it, shows progress on stderr, and downloads the
      atlas into DIR (manifest.json, albedo_alpha.png, normal_depth.png,
      orm.png, contact_sheet.png, and the quality pass's
      quality_worst_view.png, view_NN_mesh.png, view_NN_impostor.png and
      views.json). Prints the paths of the files on stdout.
        --layout      view directions: octahedral (full sphere, default),
                      hemi-octahedral (upper hemisphere), azimuth-elevation
                      (N azimuth columns x N elevation rows, N odd so a row
                      sits at 0 degrees), ring-top (--ring K horizontal views,
                      default 24, plus one from above) or billboard (the
                      traditional 3x3: 8 side views + 1 top view)
        --ring K      ring-top: horizontal views (default 24, range 3..64)
        --supersampling S  render S x S samples per texel and filter them
                      down for clean alpha edges (default 2, range 1..4;
                      resolution x S at most 16384)
        --frames N    frames per atlas axis (server default 12, range 2..64,
                      octahedral 3..64; azimuth-elevation: odd, default 11;
                      ring-top and billboard derive it)
        --resolution R atlas side in pixels (server default 2048, range
                      64..16384 and at least 8 * frames)
        --product P   atlas (default), surfels, lod-chain or cards (below).
                      surfels: a point cloud for foliage at
                      extreme distance (surfels.bin: 12 float32 per point,
                      surfels.ply), read from a capture of --frames and
                      --resolution
        --preset NAME surfels: prop (2048 points, 12 frames, 512 px), building
                      (16384, 16, 1024), vegetation (32768, 24, 2048, the
                      default) or hero (65536, 32, 2048); explicit flags win
        --point-budget N surfels: most points in the cloud (range 1..4194304)
        --product lod-chain [--lod-ratios 0.5,0.1] [--lod-pixel-error E]: the
                      mesh at LOD0, simplified levels at those triangle
                      ratios (default 0.5,0.1) as lod<N>.glb sharing the
                      input's textures, and an atlas impostor as the last
                      level (layout default hemi-octahedral); manifest.json
                      lists the levels and their switch thresholds (see
                      impostor/lod.h), set so that each switch costs at most
                      E pixels of screen-space error (default 1, range
                      0.1..16)
        --product cards [--max-planes N] [--tolerance E]: a card cluster
                      ("billboard cloud"): at most N textured quads (default
                      8, range 1..64) fitted to the mesh within E x the
                      bounding-sphere radius (default 0.05, range
                      0.0001..1), as cards.glb (standard glTF 2.0, any
                      viewer loads it) plus the card atlas maps;
                      --resolution is the card atlas side (default 1024);
                      --frames is refused and --layout ignored
        --follow-symlinks upload files reached through a symbolic link that
                      leads out of the model's folder (refused by default)
        --array       atlas: write each map as a texture array (layer i =
                      view i, stacked top to bottom in one tile-wide PNG)
                      instead of an atlas
        --texture-format png|ktx2  atlas: map file format (default png);
                      ktx2 = Basis Universal UASTC with a per-tile mip chain,
                      resolution rounded down so tiles are multiples of 4 px
        --albedo-codec uastc|uastc-rdo  ktx2: the albedo map's codec
        --emissive    atlas: also bake emissive.png (emissive texture x
                      factor x KHR_materials_emissive_strength, sRGB, A =
                      coverage), listed in the manifest's maps
        --frames auto atlas: the server bakes the layout's ladder (those that
                      fit --resolution): octahedral 8..24 frames, azimuth-
                      elevation 7..21, ring-top --ring 8..48 (leave --ring
                      out), billboard its one 3x3; it keeps the smallest
                      whose measured quality meets --min-iou / --min-psnr
                      (one is needed); the manifest lists the counts tried
        --min-iou X   quality gate: the bake fails (exit 1, FAILED_PRECONDITION
                      giving measured values and thresholds) when the mean
                      silhouette IoU over held-out views is below X (0..1);
                      the result is still downloaded into DIR for inspection
        --min-psnr Y  the same for the mean albedo PSNR, dB (0..100)
        --quality-views N held-out views of the quality pass (default 16,
                      range 0..256, 0 = none); the summary of the manifest's
                      quality block is printed after the bake
        --quiet       no progress output
        --priority N  scheduling priority, -100..100 (default 0; 50 for a
                      person waiting, -50 for nightly batches)
        --require-tag TAG  only a worker started with this tag (impostor-worker
                      --tags) may bake it; repeat for several (e.g. gpu)
        --client-id NAME  names this client to the server (fairness, limits)
        --max-outage-seconds N  keep retrying for up to N seconds while the
                      server is away (restart, reboot; default 300, 0 = give
                      up after a few quick tries); see Common flags
  impostor bake MODEL MODEL... --out DIR [flags as above] [--keep-going]
      Several models: a batch, as bake-batch with every model at the flags'
      settings; each result lands in DIR/<model name>/.
  impostor bake-batch SPEC --out DIR [--server HOST:PORT] [--json] [--quiet]
                [--keep-going] [--priority N] [--client-id NAME] [--follow-symlinks]
                [--max-outage-seconds N]
      Bakes every asset listed in SPEC (a .json, .yaml or .yml file, or - for
      JSON or YAML on stdin): {"defaults": {...}, "assets": ["a.glb",
      {"path": "b.gltf", "name": "tree", "frames": 8, ...}]}. Keys of an asset
      and of defaults, as bake's flags: layout, frames (or "auto"),
      resolution, product, preset, point_budget, ring_views, supersampling,
      quality_views, emissive, texture_array, texture_format, albedo_codec,
      lod_ratios, lod_pixel_error, max_planes, tolerance, priority, min_iou,
      min_psnr_db; an asset also has path
      (required, relative to SPEC's folder) and name (its folder in DIR,
      default the file name without extension). Uploads only the blobs the
      server lacks (one FindMissingBlobs for the batch), submits everything,
      follows the jobs over at most 8 WatchJob streams and downloads each
      result into DIR/<name>/ as it finishes. A live summary line (queued,
      running, done, cached, failed, progress bar) goes to stderr.
        --keep-going  bake everything possible after a failure (default: stop
                      submitting after the first failure; what was already
                      submitted is still followed and reported)
        --priority N  default priority of assets that do not set one
        --follow-symlinks as for bake, for every asset
        --json        one JSON object per finished asset on stdout: {type:
                      "asset", asset, name, status (succeeded, failed or
                      skipped), cached, cache_key, job_id, out_dir, files,
                      wall_seconds, priority, quality (the manifest's quality
                      block, or null), warnings, error (null or "CODE:
                      message"), error_code}, then {type: "summary", total,
                      succeeded, baked, cached, failed, skipped, wall_seconds,
                      exit_code, error}: the summary on every outcome
  impostor fetch KEY --out DIR [--server HOST:PORT] [--json] [--quiet]
                [--max-outage-seconds N]
      Downloads the result baked under cache key KEY into DIR. Files already
      in DIR with the right content are kept; a download cut off by a server
      restart resumes where it stopped (default outage budget 30 s).
  impostor fetch NAME_OR_KEY --mirror URL[,URL...] --channel NAME --out DIR
                [--server HOST:PORT] [--cache-dir DIR] [--catalog-key FILE] [--json]
      Fetches from published releases (as a shipped game does): resolves the
      asset NAME (or a cache KEY) through the channel's catalog and downloads
      each file from the first mirror that gives it intact, verifying its
      SHA-256 as it streams (a wrong byte, an error page, a truncated body or
      a stall moves on to the next mirror), then from the farm only when
      --server (or $IMPOSTOR_SERVER) is given. Files go through the local
      cache (--cache-dir), which keeps the catalog for offline use, and are
      copied into DIR.
        --mirror URL  base URL of a release tree (the folder holding v1/):
                      a CDN edge, a static host, or a farm's
                      http://HOST:PORT/releases; comma-separated or repeated,
                      tried in order
        --channel NAME the release channel (nightly, release-1.4, ...)
        --catalog-key FILE accept only catalogs signed with this Ed25519
                      key (PEM public key; see publish --sign-key)
  impostor publish KEY|NAME=KEY... [--from-report FILE] --channel NAME --out DIR
                [--include-quality-views] [--sign-key FILE] [--server HOST:PORT] [--json]
      Writes the results as a release any web server or CDN serves as plain
      files: DIR/v1/blobs/sha256/<2 hex>/<64 hex> (every file a game draws,
      by its SHA-256), DIR/v1/catalogs/sha256/... (the catalog: each asset
      name's cache key, product, layout and files) and
      DIR/v1/channels/NAME.json (the only file that changes). Blobs first,
      then the catalog, then the channel by atomic rename: an interrupted
      publish leaves the previous channel intact. Blobs already in DIR are
      not written again; the same inputs give the same catalog digest.
        KEY           publish the result under KEY as the asset named KEY
        NAME=KEY      ... as the asset NAME (letters, digits, . _ - /; at
                      most 200 characters; no . or .. segments)
        --from-report FILE  the assets of `impostor bake-batch --json`
                      output (- = stdin): each asset's name and cache_key;
                      an asset that did not succeed stops the publish
        --channel NAME the channel to point at the new catalog
        --include-quality-views  also the quality pass's view images,
                      views.json, the worst view and the contact sheet
        --sign-key FILE sign the catalog with this Ed25519 private key (PEM,
                      `openssl genpkey -algorithm ed25519`); clients given
                      the public key refuse anything else
        --json        {channel, catalog_sha256, catalog_path, channel_path,
                      assets, blobs_written, blobs_present, bytes_written,
                      catalog_reused, channel_changed, out_dir, wall_seconds,
                      error}
  impostor catalog ls --mirror URL[,URL...] --channel NAME [--cache-dir DIR]
                [--catalog-key FILE] [--json]
      Lists the assets of the channel's current catalog: name, cache key,
      product, layout, files and bytes (--json: the catalog itself).
  impostor quality KEY [--out DIR] [--server HOST:PORT] [--json] [--quiet]
                [--all-views] [--max-outage-seconds N]
      Downloads the result KEY into DIR (default ./quality-<first 12 hex of
      KEY>), prints its quality report (held-out views against the mesh:
      IoU, albedo PSNR and SSIM, normal and depth error, pop, frames tried)
      and the path of quality_worst_view.png: the worst view side by side,
      mesh | impostor | difference (magenta: only the mesh covers, cyan: only
      the impostor covers). --all-views lists every held-out view's files
      in DIR: view_NN_mesh.png and view_NN_impostor.png (RGBA, straight
      alpha, alpha = coverage) and views.json (each view's direction, up,
      orthographic centre and radius, and its figures), so every number can
      be recomputed; exit 1 if the result has none (baked before format 2).
  impostor status JOB_ID [--server HOST:PORT] [--json] [--max-outage-seconds N]
      Shows a job's state.
  impostor cancel JOB_ID [--server HOST:PORT] [--json] [--max-outage-seconds N]
      Cancels a queued or running job.
      status and cancel --json: {job_id, cache_key, state, progress, stage,
      cached, error}; error is null or {code, message}, the job's error or,
      when the call itself failed, the RPC's (then every key still comes,
      null where not known, with exit_code too).
  impostor cache get KEY [--cache-dir DIR] [--server HOST:PORT] [--json] [--quiet]
                [--max-outage-seconds N]
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
  impostor admin purge --worker NAME [--server HOST:PORT] [--json]
                [--max-outage-seconds N]
      Needs an admin token. Drops every result the worker token NAME baked
      (a compromised worker), so those keys bake again, and deletes the blobs
      only those results used (blobs another result or a queued job uses, or
      published within the server's eviction grace, stay). Prints the purged
      cache keys on stdout, one per line, and a summary on stderr.
        --worker NAME the worker token's name (`impostor-server token list`)
        --json        {worker, cache_keys, blobs_removed, bytes_freed,
                      blobs_kept, error}; on a failure error is "CODE:
                      message", the others null, with exit_code too
  impostor help | --help | -h
  impostor version

Common flags:
  --server HOST:PORT  the bake server (default $IMPOSTOR_SERVER, else localhost:50051)
  --max-outage-seconds N  (bake, bake-batch, fetch, quality, status, cancel,
                      cache get, admin purge) when a server that answered goes away
                      (killed, restarting, refusing connections), keep
                      retrying with backoff for up to N seconds from the
                      first failure: uploads resume, a submit is resent
                      with the same request id (never a second job), watches
                      resume, downloads resume at the byte reached. Default
                      300 for bake and bake-batch, 30 for the others; 0..86400.
                      One line "impostor: lost server ..." goes to stderr when
                      the server goes away and one "impostor: server ... is
                      back after S s" when it returns (not with --quiet).
                      A server that never answered fails at once (exit 3).
  --tls-ca FILE       (every command that takes --server) connect with TLS,
                      trusting only the CA certificate(s) in FILE (PEM)
  --tls-cert FILE --tls-key FILE  mutual TLS: present this client
                      certificate and its key (PEM) to a server run with
                      --tls-client-ca; both or neither, with --tls-ca
  --tls-server-name NAME  the name the server's certificate carries, when it
                      differs from the host in --server (an IP address, a
                      tunnel); needs --tls-ca. See README "Securing a farm: TLS"
  --json              print one JSON object on stdout instead of text; bake prints
                      {model, cache_key, job_id, cached, out_dir, manifest, files,
                      wall_seconds, uploaded_bytes, warnings, quality, error,
                      exit_code} on every outcome, and contact_sheet when the
                      result has one; error is null or "CODE: message"
  --token-file FILE   (every command that takes --server) the bearer token for a
                      server with tokens (`impostor-server token create`); the
                      file wins over $IMPOSTOR_TOKEN
  --farm-http URL     (every command that takes --server) the farm's HTTP front
                      end (its --http-listen, or an https:// proxy before it):
                      results' large files are downloaded from there, verified,
                      and over gRPC when it cannot give them intact; `fetch`
                      and `cache get` take the listing and every file from
                      it, with no gRPC unless it fails them. Default:
                      $IMPOSTOR_FARM_HTTP, else what the farm advertises
                      (impostor-server --http-advertise); "none" turns both
                      off. With --tls-ca, https only
  --keepalive-seconds N  (every command that takes --server) while a call is
                      in flight, ping the server after N quiet seconds and
                      give the connection up when no answer comes within
                      min(N, 10) s, so a watch over a link that died without
                      a reset (a cut cable, a replica's host gone) moves to
                      the next --server address or retries. Default 20;
                      1..7200
  Flags take their value as "--flag VALUE" or "--flag=VALUE"; "--" ends the flags.

Exit codes:
  0  success
  1  the bake failed, was cancelled, or the server refused the request (invalid,
     nothing under that KEY or JOB_ID, no token, a bad one or one without the
     role: retrying the same command gets the same answer); for a batch: at
     least one asset failed or was skipped, whatever the reason, a quota that
     outlasted --max-outage-seconds included (each asset's error_code says
     which; the others are in DIR)
  2  usage error (unknown flag, missing value, not a number, ...); a malformed
     batch SPEC or a listed model that does not exist (nothing is submitted)
  3  cannot reach the server, or an RPC failed otherwise, e.g. a quota
     (RESOURCE_EXHAUSTED) that outlasted --max-outage-seconds (worth retrying
     later); for a batch: the server could not be reached or was lost, so
     the batch as a whole ended
  4  local I/O error (model not found or unusable, cannot write DIR)
Every failure prints exactly one line "impostor: <reason>" on stderr.

Environment:
  IMPOSTOR_SERVER     default for --server
  SOURCE_DATE_EPOCH   publish: the new catalog's created_at (reproducible releases)
  IMPOSTOR_CACHE_DIR  default for --cache-dir
  IMPOSTOR_TOKEN      the bearer token when --token-file is not given
  IMPOSTOR_FARM_HTTP  default for --farm-http
  IMPOSTOR_LOG        spdlog level for diagnostics on stderr (e.g. debug; default off)
)";
}

std::vector<std::string> AllFlags() {
  std::set<std::string> flags;
  for (const auto& [name, spec] : Commands()) {
    flags.insert(spec.value_flags.begin(), spec.value_flags.end());
    flags.insert(spec.bool_flags.begin(), spec.bool_flags.end());
    // Accepted by every command that takes --server (parsed before the
    // per-command table, see ParseCliArgs).
    if (spec.value_flags.contains("--server")) {
      flags.insert({"--tls-ca", "--tls-cert", "--tls-key", "--tls-server-name", "--token-file", "--keepalive-seconds",
                    "--farm-http"});
    }
  }
  return {flags.begin(), flags.end()};
}

}  // namespace impostor::cli
