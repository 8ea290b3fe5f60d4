// Command-line parsing of the `impostor` tool, kept apart from the tool so
// that tests can drive it. Pure functions; thread-safe.
#ifndef IMPOSTOR_CLIENT_CLI_CLI_ARGS_H_
#define IMPOSTOR_CLIENT_CLI_CLI_ARGS_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor::cli {

// Process exit codes; documented in UsageText().
enum ExitCode : int {
  kExitOk = 0,
  kExitBakeFailed = 1,   // the bake failed or was cancelled, or the server refused it
  kExitUsage = 2,        // bad command line
  kExitServer = 3,       // cannot reach the server, or an RPC failed
  kExitLocalIo = 4,      // local input/output: model missing or unusable, cannot write DIR
};

enum class Command { kHelp, kVersion, kBake, kBakeBatch, kFetch, kStatus, kCancel, kCacheGet, kCacheLs, kCacheGc, kQuality, kAdminPurge, kPublish, kCatalogLs };

inline constexpr char kDefaultServer[] = "localhost:50051";

// Default --max-outage-seconds: bake and bake-batch wait out a server restart
// or reboot (the SDK's default); fetch, quality, status, cancel and cache get
// are interactive and give up sooner.
inline constexpr double kBakeOutageSeconds = 300;
inline constexpr double kInteractiveOutageSeconds = 30;

// --lod-pixel-error's range: the server's (kMinLodPixelError and
// kMaxLodPixelError in common/request/lod_parameters.h, which this library cannot
// include; tests/batch/lod_pixel_error_request_test.cc keeps them equal).
inline constexpr float kLodPixelErrorMin = 0.1f;
inline constexpr float kLodPixelErrorMax = 16.0f;

struct CliArgs {
  Command command = Command::kHelp;
  // The positional argument: MODEL (bake), SPEC (bake-batch), KEY (fetch;
  // also an asset NAME with --mirror), JOB_ID, or the first of publish's
  // KEY / NAME=KEY inputs.
  std::string target;
  // bake: every MODEL given (targets[0] == target); more than one makes a
  // batch (batch_command.cc). publish: every input.
  std::vector<std::string> targets;
  // --priority (bake, bake-batch): -100..100, checked here; unset = 0 (for
  // bake-batch: the spec's own default).
  std::optional<int32_t> priority;
  // --require-tag (bake; repeatable): worker tags the bake needs, checked by
  // the server.
  std::vector<std::string> required_tags;
  // --keep-going (batches): bake everything possible after a failure.
  bool keep_going = false;
  // --client-id: names this client to the server for fairness and limits.
  std::string client_id;
  // --token-file FILE (commands that talk to the server): the bearer token
  // (issue 14); unset = $IMPOSTOR_TOKEN, else none. Read by the SDK.
  std::string token_file;
  // --farm-http URL (commands that talk to the server): the farm's HTTP
  // front end for results' large files (issue 45); unset =
  // $IMPOSTOR_FARM_HTTP, else none. Checked by the SDK.
  std::string farm_http;
  // --max-outage-seconds (commands that talk to the server): how long to
  // keep retrying while the server is away, 0..86400 (checked here); unset =
  // the command's default (kBakeOutageSeconds or kInteractiveOutageSeconds).
  std::optional<double> max_outage_seconds;
  // --keepalive-seconds (commands that talk to the server): ping a quiet
  // connection while a call is in flight, 1..7200 (checked here); unset =
  // the SDK's default (ClientOptions::keepalive_seconds).
  std::optional<int> keepalive_seconds;
  std::string out;
  // --server, else $IMPOSTOR_SERVER, else kDefaultServer.
  std::string server = kDefaultServer;
  // --server or $IMPOSTOR_SERVER was given: fetch with --mirror uses the
  // farm only then (mirrors first, the farm last, only what is given).
  bool server_given = false;
  // Releases (issue 40). --mirror URL[,URL...] (fetch, catalog ls; may be
  // repeated): base URLs of published release trees, in the order tried;
  // --channel NAME (publish, fetch, catalog ls); --catalog-key FILE (fetch,
  // catalog ls): an Ed25519 public key that catalogs must be signed with.
  std::vector<std::string> mirrors;
  std::string channel;
  std::string catalog_key;
  // publish: --from-report FILE (a bake-batch --json report; - = stdin),
  // --sign-key FILE (Ed25519 private key, PEM), --include-quality-views.
  std::string from_report;
  std::string sign_key;
  bool include_quality_views = false;
  std::string layout = "octahedral";
  // 0 = not given (the server's default). Other values go to the server
  // unchecked: it owns the ranges.
  uint32_t frames = 0;
  uint32_t resolution = 0;
  // --frames auto: the server picks frames by measured quality (frames stays
  // 0; --min-iou / --min-psnr are the target).
  bool frames_auto = false;
  // --min-iou X / --min-psnr Y: the quality gate (and frames_auto's target);
  // numbers checked here, ranges by the server. Unset = not given.
  std::optional<float> min_iou;
  std::optional<float> min_psnr_db;
  // --quality-views N: held-out views of the quality pass (server: 0..256).
  std::optional<uint32_t> quality_views;
  // --product: "atlas" or "surfels" (checked here).
  std::string product = "atlas";
  // --preset and --point-budget (surfels): passed to the server unchecked;
  // unset = not given.
  std::string preset;
  std::optional<uint32_t> point_budget;
  // --ring K (layout ring-top): passed to the server unchecked.
  std::optional<uint32_t> ring_views;
  // --supersampling S: passed to the server unchecked.
  std::optional<uint32_t> supersampling;
  // --lod-ratios 0.5,0.1 (product lod-chain): comma-separated numbers, passed
  // to the server unchecked (it owns the rules); empty = not given. With
  // product lod-chain and no --layout, `layout` is empty: the server's
  // default for LOD chains (hemi-octahedral).
  std::vector<float> lod_ratios;
  // --lod-pixel-error E (product lod-chain): screen-space error allowed at
  // each switch, pixels; the batch key lod_pixel_error. The number and its
  // range (0.1..16, the server's) are checked here; that it needs product
  // lod-chain is the server's to say. Unset = not given (the server's 1).
  std::optional<float> lod_pixel_error;
  // --max-planes N and --tolerance E (product cards): passed to the server
  // unchecked (it owns the ranges); unset = not given.
  std::optional<uint32_t> max_planes;
  std::optional<float> tolerance;
  bool json = false;
  bool quiet = false;
  // --all-views (quality): list every held-out view's files (views.json).
  bool all_views = false;
  // --emissive (bake): also bake the emissive map.
  bool emissive = false;
  // --array (bake): texture arrays instead of atlases.
  bool texture_array = false;
  // --texture-format png|ktx2 and --albedo-codec uastc|uastc-rdo (bake):
  // checked here, meaning the server's. Empty = the server's default.
  std::string texture_format;
  std::string albedo_codec;
  // --follow-symlinks (bake, bake-batch): BakeSettings::follow_symlinks.
  bool follow_symlinks = false;
  // cache commands: --cache-dir (empty = $IMPOSTOR_CACHE_DIR, else
  // $XDG_CACHE_HOME/impostor, else ~/.cache/impostor; see cache_commands.cc),
  // --max-bytes (unset = the cache's default cap), gc --verify.
  std::string cache_dir;
  std::optional<int64_t> max_bytes;
  bool verify = false;
  // Transport security (commands that talk to the server; README "Securing
  // a farm: TLS"): --tls-ca FILE (TLS, trusting that CA), --tls-cert FILE
  // and --tls-key FILE (mutual TLS; both or neither, and they need
  // --tls-ca), --tls-server-name NAME (the name the server's certificate
  // carries, when it differs from --server's host; needs --tls-ca). The
  // pairing is checked here; the files when connecting. Empty = not given.
  std::string tls_ca;
  std::string tls_cert;
  std::string tls_key;
  std::string tls_server_name;
  // --worker NAME (admin purge): the worker token whose results to drop;
  // required, its rules are the server's.
  std::string worker;
};

// Parses argv without argv[0]. `env_server` is $IMPOSTOR_SERVER (nullptr or
// empty when unset). INVALID_ARGUMENT is a usage error; its message names the
// flag or argument at fault. "--help"/"-h" anywhere, or "help", gives
// Command::kHelp.
absl::StatusOr<CliArgs> ParseCliArgs(const std::vector<std::string>& args, const char* env_server);

// The text of `impostor --help`.
std::string UsageText();

// Every flag some command accepts ("--out", "--json", ...), sorted: what
// UsageText() must document (tests/help).
std::vector<std::string> AllFlags();

}  // namespace impostor::cli

#endif  // IMPOSTOR_CLIENT_CLI_CLI_ARGS_H_
