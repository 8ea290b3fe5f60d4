// impostor-worker: pulls bake jobs from impostor-server and renders them
// with headless Vulkan (lavapipe when there is no GPU).
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "absl/strings/str_cat.h"
#include "common/flags/flag_help.h"
#include "common/flags/flag_names.h"
#include "common/flags/flag_precheck.h"
#include "common/util/log_level.h"
#include "common/net/grpc_log.h"
#include "common/net/keepalive.h"
#include "common/net/server_list.h"
#include "common/net/tls_channel.h"
#include "common/net/token_source.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/worker_loop.h"
#include "common/worker_exit_codes.h"
#include "worker/capabilities.h"
#include "worker/worker_help.h"

ABSL_FLAG(std::string, server, "",
          "HOST:PORT of impostor-server, or several replicas of one farm: HOST1:PORT,HOST2:PORT (fails over) "
          "(default: $IMPOSTOR_SERVER, else localhost:50051)");
ABSL_FLAG(std::string, name, "", "Worker name for logs and leases (default: host-pid)");
ABSL_FLAG(std::string, device, "", "Substring of the Vulkan device name to use (default: best available)");
ABSL_FLAG(std::string, scratch, "", "Directory for per-job files (default: $TMPDIR/impostor-worker-<pid>)");
ABSL_FLAG(int, max_jobs, 0, "Exit after this many jobs (0 = serve forever)");
ABSL_FLAG(int, heartbeat_s, 1, "Seconds between lease renewals and cancel checks while baking (1..60)");
ABSL_FLAG(int, stall_s, 1800, "Stop renewing a job whose progress has not moved for this many seconds (1..86400)");
ABSL_FLAG(uint64_t, max_triangles, 20'000'000, "Largest mesh accepted, triangles as drawn (>= 1)");
ABSL_FLAG(int, max_texture_dimension, 16384, "Largest texture side accepted, pixels (1..65536)");
ABSL_FLAG(int, drain_seconds, 60,
          "On SIGTERM, seconds the current job may take to finish before its lease is handed back (0..3600)");
ABSL_FLAG(int, max_outage_seconds, 300,
          "Seconds the server may stay unreachable before the worker exits with status 1 (1..86400)");
// Issue 15: a call over a link that died without a reset (a cut cable).
ABSL_FLAG(int, keepalive_seconds, impostor::kDefaultKeepaliveSeconds,
          "While a call is in flight, ping the server after this many quiet seconds and give the connection up "
          "when no answer comes within min(N, 10) s, so a blob transfer over a dead link moves on in seconds "
          "(1..7200)");
ABSL_FLAG(uint64_t, max_draws, 1'000'000, "Most mesh primitives drawn, instances x primitives (1..2^31)");
ABSL_FLAG(uint64_t, max_load_bytes, uint64_t{6} << 30, "Estimated peak heap of one mesh load, bytes (>= 1)");
ABSL_FLAG(bool, isolate_load, true, "Load each input in a child process under rlimits first");
ABSL_FLAG(uint64_t, load_memory_mb, 8192, "Address space the isolated load may add, MiB (>= 64)");
ABSL_FLAG(int, load_cpu_s, 300, "CPU seconds the isolated load may use (1..86400)");
ABSL_FLAG(std::string, log_level, "info", "trace, debug, info, warn, error");
ABSL_FLAG(std::vector<std::string>, tags, {},
          "Comma list of tags this worker reports to the server (e.g. gpu,team-forest): at most 16, each 1..64 of "
          "[a-z0-9._-]");
// Transport security (README "Securing a farm: TLS"): TLS when --tls-ca is
// given; --tls-cert/--tls-key add a client certificate for mutual TLS.
ABSL_FLAG(std::string, tls_ca, "", "Connect with TLS, trusting only this CA bundle (PEM) for the server's certificate");
ABSL_FLAG(std::string, tls_cert, "", "Mutual TLS: this worker's certificate chain (PEM; needs --tls-key, --tls-ca)");
ABSL_FLAG(std::string, tls_key, "", "Mutual TLS: private key of --tls-cert (PEM, unencrypted)");
ABSL_FLAG(std::string, tls_server_name, "",
          "Name the server's certificate must carry, when it differs from the host in --server");
// Identity (issue 14).
ABSL_FLAG(std::string, token_file, "",
          "File holding this worker's bearer token (role worker); else $IMPOSTOR_TOKEN. The file wins");

namespace {

// Test hooks come from the environment (see worker/test_faults.h).
std::string EnvOrEmpty(const char* name) {
  const char* value = std::getenv(name);
  return value ? value : "";
}

}  // namespace

int main(int argc, char** argv) {
  absl::SetProgramUsageMessage("impostor-worker --server HOST:PORT");
  impostor::ShowAllFlagsInHelp();
  // --help and --version are generated from the flag registry (common/flags/flag_help.h).
  if (auto status = impostor::HandleHelpAndVersion(argc, argv, impostor::WorkerHelp())) return *status;
  impostor::UnderscoreFlagNames(argc, argv);
  if (auto s = impostor::PrecheckFlags(argc, argv); !s.ok()) {
    std::fprintf(stderr, "impostor-worker: %s\n", std::string(s.message()).c_str());
    return impostor::kWorkerExitUsage;
  }
  absl::ParseCommandLine(argc, argv);
  // Blocked before any thread starts (Vulkan's, gRPC's), so only the
  // watcher thread below receives them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  // Logs go to stderr: stdout carries only the "listening on" line, and a
  // closed stdout must not take the process down.
  spdlog::set_default_logger(spdlog::stderr_color_mt("impostor"));
  ::signal(SIGPIPE, SIG_IGN);
  if (auto s = impostor::ValidateLogLevel("--log-level", absl::GetFlag(FLAGS_log_level)); !s.ok()) {
    std::fprintf(stderr, "impostor-worker: %s\n", std::string(s.message()).c_str());
    return 2;
  }
  spdlog::set_level(spdlog::level::from_str(absl::GetFlag(FLAGS_log_level)));

  char host[256] = {};
  ::gethostname(host, sizeof(host) - 1);
  std::string name = absl::GetFlag(FLAGS_name);
  const std::string worker_id = absl::StrCat(name.empty() ? host : name, "-", ::getpid());
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ worker " + worker_id + " %v");
  // gRPC's lines (a refused TLS handshake, ...) in the same format.
  impostor::RouteGrpcLogsToSpdlog();
  const int heartbeat = absl::GetFlag(FLAGS_heartbeat_s);
  if (heartbeat < 1 || heartbeat > 60) {
    std::fprintf(stderr, "impostor-worker: --heartbeat-s must be in 1..60\n");
    return 2;
  }

  // As the CLI: the flag, else $IMPOSTOR_SERVER (what README, the systemd
  // unit's Environment= and the containers set), else the local default.
  std::string server = absl::GetFlag(FLAGS_server);
  const char* server_source = "--server";
  if (server.empty()) {
    server = EnvOrEmpty("IMPOSTOR_SERVER");
    server_source = "$IMPOSTOR_SERVER";
  }
  if (server.empty()) server = "localhost:50051";
  // Several replicas (issue 15): a malformed list fails here, naming the flag.
  if (auto targets = impostor::ParseServerList(server, server_source); !targets.ok()) {
    std::fprintf(stderr, "impostor-worker: %s\n", std::string(targets.status().message()).c_str());
    return 2;
  }

  const int drain_seconds = absl::GetFlag(FLAGS_drain_seconds);
  if (drain_seconds < 0 || drain_seconds > 3600) {
    std::fprintf(stderr, "impostor-worker: --drain-seconds: %d is out of range 0..3600\n", drain_seconds);
    return 2;
  }
  const int max_outage_seconds = absl::GetFlag(FLAGS_max_outage_seconds);
  if (max_outage_seconds < 1 || max_outage_seconds > 86400) {
    std::fprintf(stderr, "impostor-worker: --max-outage-seconds: %d is out of range 1..86400\n", max_outage_seconds);
    return 2;
  }

  const int keepalive_seconds = absl::GetFlag(FLAGS_keepalive_seconds);
  if (auto s = impostor::ValidateKeepaliveSeconds("--keepalive-seconds", keepalive_seconds); !s.ok()) {
    std::fprintf(stderr, "impostor-worker: %s\n", std::string(s.message()).c_str());
    return 2;
  }

  // TLS files are read and checked before the GPU is touched: a bad flag
  // fails at once, naming itself.
  grpc::ChannelArguments unused_args;
  const impostor::ClientTls tls{.files = {.ca = absl::GetFlag(FLAGS_tls_ca),
                                          .cert = absl::GetFlag(FLAGS_tls_cert),
                                          .key = absl::GetFlag(FLAGS_tls_key)},
                                .server_name = absl::GetFlag(FLAGS_tls_server_name)};
  auto credentials = impostor::MakeChannelCredentials(
      tls, {.files = {.ca = "--tls-ca", .cert = "--tls-cert", .key = "--tls-key"}, .server_name = "--tls-server-name"},
      &unused_args);
  if (!credentials.ok()) {
    std::fprintf(stderr, "impostor-worker: %s\n", std::string(credentials.status().message()).c_str());
    return 2;
  }

  if (impostor::UsesTls(tls)) {
    spdlog::info("event=tls mode={} ca={}", tls.files.cert.empty() ? "tls" : "mutual", tls.files.ca);
  }

  // Identity (issue 14): checked before the GPU starts, so a bad token file
  // fails at once.
  auto token = impostor::ResolveToken(absl::GetFlag(FLAGS_token_file), "", std::getenv(impostor::kTokenEnvVar));
  if (!token.ok()) {
    std::fprintf(stderr, "impostor-worker: %s\n", std::string(token.status().message()).c_str());
    return 2;
  }

  auto renderer = impostor::AtlasRenderer::Create(absl::GetFlag(FLAGS_device));
  if (!renderer.ok()) {
    std::fprintf(stderr, "impostor-worker: no usable Vulkan device: %s\n", renderer.status().ToString().c_str());
    return 3;
  }

  // What the server places jobs by (issue 44), measured once.
  auto capabilities = impostor::MeasureCapabilities((*renderer)->device(), absl::GetFlag(FLAGS_tags));
  if (!capabilities.ok()) {
    std::fprintf(stderr, "impostor-worker: %s\n", std::string(capabilities.status().message()).c_str());
    return 2;
  }

  std::filesystem::path scratch = absl::GetFlag(FLAGS_scratch);
  if (scratch.empty()) scratch = std::filesystem::temp_directory_path() / absl::StrCat("impostor-worker-", ::getpid());
  std::error_code ec;
  std::filesystem::create_directories(scratch, ec);

  impostor::WorkerLoop loop({.server = server,
                             .worker_id = worker_id,
                             .scratch_dir = scratch,
                             .heartbeat_seconds = heartbeat,
                             .stall_seconds = std::clamp(absl::GetFlag(FLAGS_stall_s), 1, 86400),
                             .max_jobs = absl::GetFlag(FLAGS_max_jobs),
                             .load_limits = {.max_triangles = absl::GetFlag(FLAGS_max_triangles),
                                             .max_texture_dimension = absl::GetFlag(FLAGS_max_texture_dimension),
                                             .max_draws = absl::GetFlag(FLAGS_max_draws),
                                             .max_load_bytes = absl::GetFlag(FLAGS_max_load_bytes)},
                             .load_isolation = {.enabled = absl::GetFlag(FLAGS_isolate_load),
                                                .address_space_bytes = absl::GetFlag(FLAGS_load_memory_mb) << 20,
                                                .cpu_seconds = absl::GetFlag(FLAGS_load_cpu_s)},
                             .drain_seconds = drain_seconds,
                             .max_outage_seconds = max_outage_seconds,
                             .keepalive_seconds = keepalive_seconds,
                             .test_crash_on = EnvOrEmpty("IMPOSTOR_WORKER_TEST_CRASH_ON"),
                             .test_fail_on = EnvOrEmpty("IMPOSTOR_WORKER_TEST_FAIL_ON"),
                             .test_pause_file = EnvOrEmpty("IMPOSTOR_WORKER_TEST_PAUSE_FILE"),
                             .channel_credentials = *credentials,
                             .tls_server_name = tls.server_name,
                             .tls_ca_file = tls.files.ca,
                             .token = *token,
                             .capabilities = *std::move(capabilities)},
                            std::move(*renderer));

  // SIGTERM: drain (no new job; the current one finishes within
  // --drain-seconds or is handed back). SIGINT (Ctrl-C, or the death of a
  // supervising server) or a second SIGTERM: hand it back now. A third
  // signal ends the process at once.
  std::thread([&] {
    for (int received = 1;; ++received) {
      int sig = 0;
      sigwait(&signals, &sig);
      if (received >= 3) std::_Exit(1);
      const int budget = (sig == SIGTERM && received == 1) ? drain_seconds : 0;
      spdlog::info("event=draining signal={} drain_s={}", sig, budget);
      loop.Drain(std::chrono::seconds(budget));
    }
  }).detach();

  spdlog::info("event=worker_ready server={}", server);
  const auto status = loop.Run();
  std::filesystem::remove_all(scratch, ec);
  if (!status.ok()) {
    spdlog::error("event=worker_exit error=\"{}\"", status.ToString());
    std::fprintf(stderr, "impostor-worker: %s\n", status.ToString().c_str());
    const bool token_refused =
        absl::IsUnauthenticated(status) || absl::IsPermissionDenied(status);
    return token_refused ? impostor::kWorkerExitTokenRefused : 1;
  }
  spdlog::info("event=worker_exit");
  return 0;
}
