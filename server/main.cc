// impostor-server: the bake farm's gRPC server. Wires the blob store, the
// job database, the scheduler and the services together; see README.md.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <cstdlib>
#include <thread>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "absl/flags/declare.h"
#include "absl/flags/flag.h"
#include "absl/flags/parse.h"
#include "absl/flags/usage.h"
#include "common/request/bake_request.h"
#include "common/flags/flag_help.h"
#include "common/flags/flag_names.h"
#include "common/flags/flag_precheck.h"
#include "common/util/log_level.h"
#include "server/http/listen_address.h"
#include "common/net/grpc_log.h"
#include "server/scheduler/bake_scheduler.h"
#include "server/blobs/blob_store.h"
#include "server/http/http_frontend.h"
#include "server/store/job_store.h"
#include "server/store/job_store_factory.h"
#include "server/server_help.h"
#include "server/rpc/services.h"
#include "server/rpc/serving_tuning.h"
#include "server/auth/tls_credentials.h"
#include "server/auth/tls_file_monitor.h"
#include "server/worker_supervisor.h"
// Identity and roles (issue 14).
#include "server/auth/auth_mode.h"
#include "server/auth/authenticator.h"
#include "server/rpc/authorized_services.h"
#include "server/auth/call_principals.h"
#include "server/rpc/admin_service.h"
#include "server/commands/purge_command.h"
#include "common/net/keepalive.h"
#include "server/commands/token_command.h"
#include "server/store/token_quotas.h"
#include "server/store/token_store.h"
#include "server/store/token_store_factory.h"

// Defined with the HTTP front end (server/http/http_frontend.cc); its
// address decides --auth's default too.
ABSL_DECLARE_FLAG(std::string, http_listen);

ABSL_FLAG(std::string, listen, "localhost:50051", "HOST:PORT to serve on; port 0 picks a free port");
ABSL_FLAG(std::string, data, "", "Directory for the blob store and the job database (required)");
// Issue 15: several head nodes on one PostgreSQL database and one blob store.
ABSL_FLAG(std::string, database, "",
          "Job database URL, postgresql://USER:PASSWORD@HOST:PORT/DB?..., which several servers may share "
          "(default: SQLite in --data)");
ABSL_FLAG(std::string, blob_dir, "",
          "Blob store directory (holds cas/ and tmp/; a shared filesystem when several servers share "
          "--database) (default: --data)");
ABSL_FLAG(int, database_pool_size, 8, "PostgreSQL connections per server (1..64)");
ABSL_FLAG(int, database_statement_timeout_ms, 10000,
          "PostgreSQL statement timeout in milliseconds (100..600000)");
ABSL_FLAG(int, database_dead_link_seconds, impostor::kDefaultDeadLinkSeconds,
          "Seconds after which a PostgreSQL connection whose link died without a reset is given up, by this "
          "server and by the database (which then frees a vanished replica's maintenance lock); the URL's own "
          "keepalive and timeout keywords win (2..3600)");
ABSL_FLAG(int, database_maintenance_takeover_seconds, 30,
          "Seconds a replica holding the maintenance role (lease expiry, eviction, retention) may go without a "
          "sweep before another replica ends its database session and takes the role over, e.g. when it hangs "
          "(2..3600)");
ABSL_FLAG(int, local_workers, 0, "Number of impostor-worker processes to run and keep alive (0..64)");
ABSL_FLAG(std::string, worker_binary, "", "Worker executable for --local-workers (default: next to this binary)");
ABSL_FLAG(int, lease_timeout_s, 30, "Seconds without a worker report before its job is queued again (1..3600)");
ABSL_FLAG(int, max_attempts, 3, "Leases a job gets before it fails for good (1..100)");
ABSL_FLAG(int64_t, max_pending_jobs, 100000, "Queued or running jobs accepted in total (>= 1)");
ABSL_FLAG(int64_t, max_pending_per_client, 10000, "Queued or running jobs accepted per client (>= 1)");
ABSL_FLAG(int64_t, max_blob_bytes, int64_t{2} << 30, "Largest blob (upload or output) accepted, bytes (>= 1)");
// Issue 44: what a broken upload leaves for its resume (BlobStore).
ABSL_FLAG(int64_t, partial_upload_max_bytes, int64_t{4} << 30,
          "Bytes of broken uploads kept, all together, for the client or worker to resume (QueryUpload); the "
          "oldest go first (0 = keep none, every broken upload starts over; >= 0)");
ABSL_FLAG(int, partial_upload_max_age_seconds, 3600,
          "Seconds a broken upload's bytes are kept for a resume (1..604800)");
ABSL_FLAG(int64_t, store_max_bytes, 0,
          "Store size cap in bytes; least recently used unpinned results are evicted beyond it (0 = no cap)");
ABSL_FLAG(int, shutdown_grace_seconds, 10,
          "On SIGTERM/SIGINT: seconds for local workers to drain and in-flight calls to finish before the "
          "server exits (1..3600)");
ABSL_FLAG(int, worker_failure_limit, 3,
          "Pause a worker after this many different jobs in a row failed or lost on it (0 = never, 0..1000)");
ABSL_FLAG(int, worker_pause_seconds, 300, "How long a paused worker gets no lease (1..86400)");
ABSL_FLAG(int, unplaceable_timeout_seconds, 3600,
          "A queued job no worker can bake (its memory estimate over every worker's totals, or KTX2 maps and no "
          "encoder) waits with the reason as its stage, and fails with it after this many seconds (1..2592000; "
          "never with --database, where other servers' workers may take it)");
ABSL_FLAG(int, retry_elsewhere_seconds, 60,
          "A job a worker failed retryably (memory not free, scratch full, device error) is left to other workers "
          "for this many seconds; that worker gets it back sooner only when it has no other job to take and no "
          "other worker could take it (0 = off, 0..3600)");
ABSL_FLAG(int, prefer_strong_seconds, 30,
          "A large bake (8192 rendered px a side or more: resolution x supersampling) is not leased to a weaker "
          "worker (device kind: discrete > integrated, virtual, other > cpu) while a stronger one that could take "
          "it has asked for work lately; after waiting this many seconds any worker that fits may take it "
          "(0 = off, 0..3600; each server judges by the workers it hears from)");
// Pools and shares (issue 44; server/scheduler/pool_shares.h).
ABSL_FLAG(std::vector<std::string>, pools, {},
          "Comma list of worker pools, each NAME (the workers tagged NAME) or NAME=TAG (the workers tagged TAG), "
          "e.g. gpu; at most 16, names and tags 1..64 of [a-z0-9._-]");
ABSL_FLAG(std::vector<std::string>, pool_shares, {},
          "Comma list of POOL:TEAM=PERCENT: while TEAM (a token name, or a client's impostor-client-id) has work "
          "queued, at least PERCENT of POOL's workers (rounded up) take its jobs first, e.g. gpu:team-forest=50; "
          "a minimum, not a cap (1..100 each, at most 100 in one pool; each server judges by the pool's workers "
          "it hears from)");
ABSL_FLAG(std::string, port_file, "", "Write the bound port to this file once serving (for scripts)");
ABSL_FLAG(std::string, log_level, "info", "trace, debug, info, warn, error");
// Store cap (issue 24): how long an upload no job or result refers to yet is
// spared by eviction, so a client has time to submit the bake that uses it.
ABSL_FLAG(int64_t, store_eviction_grace_seconds, 600,
          "With --store-max-bytes: uploads younger than this many seconds that no job or result uses yet are "
          "never evicted (0..86400)");
// Transport security (README "Securing a farm: TLS"; server/auth/tls_credentials.h).
ABSL_FLAG(std::string, tls_cert, "", "Serve TLS with this certificate chain (PEM, leaf first; needs --tls-key)");
ABSL_FLAG(std::string, tls_key, "", "Private key of --tls-cert (PEM, unencrypted)");
ABSL_FLAG(std::string, tls_client_ca, "",
          "Mutual TLS: clients must present a certificate issued by this CA (PEM; needs --tls-cert)");
ABSL_FLAG(int, tls_reload_seconds, 5,
          "How often the TLS files are checked for a renewed certificate, key or client CA (1..3600)");
// Identity and roles (issue 14).
ABSL_FLAG(std::string, auth, "",
          "none or token: whether callers need a bearer token (`impostor-server token create`). Default: token "
          "unless --listen and --http-listen are loopback addresses; none is refused on other addresses");
ABSL_FLAG(int64_t, token_max_pending_jobs, 1000, "Queued or running jobs per token (not admin) (>= 1)");
ABSL_FLAG(int64_t, token_max_upload_bytes_per_day, int64_t{100} << 30,
          "Bytes a token (not admin) may upload in any 24 hours (>= 1)");
ABSL_FLAG(int64_t, token_max_bakes_per_hour, 1000, "Bakes (non-cached submits) per token (not admin) per hour (>= 1)");
ABSL_FLAG(int, token_cache_ttl_ms, 2000,
          "How long a token check is cached; a token revoked on any replica (or with `impostor-server token "
          "revoke`) is refused here within this time. 0 = read the token store on every call (0..60000)");
ABSL_FLAG(int, keepalive_seconds, impostor::kDefaultKeepaliveSeconds,
          "Ping a connection quiet for this many seconds and drop it (ending its calls) when the ping is not "
          "answered within min(N, 10) s: a client whose link died stops holding watches. Clients may ping as "
          "often as once a second (1..7200)");
// Serving speed (issue 18).
ABSL_FLAG(int, job_retention_days, 7,
          "Finished job records older than this many days are deleted (0 = keep for ever; 0..36500)");
ABSL_FLAG(int, result_touch_flush_seconds, 10,
          "Result use times (LRU eviction order) are written at most this often, and at shutdown (1..3600)");

namespace {

std::atomic<bool> g_stop{false};

// How long past --shutdown-grace-seconds the server may take to exit before
// it exits anyway (the drain, the gRPC shutdown and the last flush normally
// end within the grace).
constexpr std::chrono::seconds kShutdownOverrun{3};

int Fail(const std::string& message) {
  std::fprintf(stderr, "impostor-server: %s\n", message.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  // Logs go to stderr from the first line: stdout carries only what a
  // subcommand prints (a token's secret) or the "listening on" line, and a
  // closed stdout must not take the process down.
  spdlog::set_default_logger(spdlog::stderr_color_mt("impostor"));
  // `impostor-server token ...` manages tokens on a data directory.
  if (argc > 1 && std::string(argv[1]) == "token") {
    return impostor::RunTokenCommand(std::vector<std::string>(argv + 2, argv + argc));
  }
  // `impostor-server purge --worker NAME` drops what a compromised worker baked.
  if (argc > 1 && std::string(argv[1]) == "purge") {
    return impostor::RunPurgeCommand(std::vector<std::string>(argv + 2, argv + argc));
  }
  absl::SetProgramUsageMessage("impostor-server --listen HOST:PORT --data DIR [--local-workers N]");
  impostor::ShowAllFlagsInHelp();
  // --help and --version are generated from the flag registry (common/flags/flag_help.h).
  if (auto status = impostor::HandleHelpAndVersion(argc, argv, impostor::ServerHelp())) return *status;
  impostor::UnderscoreFlagNames(argc, argv);
  if (auto s = impostor::PrecheckFlags(argc, argv); !s.ok()) return Fail(std::string(s.message()));
  absl::ParseCommandLine(argc, argv);
  ::signal(SIGPIPE, SIG_IGN);
  if (auto s = impostor::ValidateLogLevel("--log-level", absl::GetFlag(FLAGS_log_level)); !s.ok()) {
    return Fail(std::string(s.message()));
  }
  if (auto a = impostor::ParseListenAddress(absl::GetFlag(FLAGS_listen), "--listen"); !a.ok()) {
    return Fail(std::string(a.status().message()));
  }
  spdlog::set_level(spdlog::level::from_str(absl::GetFlag(FLAGS_log_level)));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ server %v");
  // gRPC's lines (a refused TLS handshake, ...) in the same format.
  impostor::RouteGrpcLogsToSpdlog();

  // Blocked before any thread starts (gRPC's, the supervisor's), so every
  // thread inherits the mask and only the watcher below receives them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  // A closed terminal or a stray `kill -HUP` stops the server as SIGTERM
  // does (drained, logged), not abruptly; there is no configuration to reload.
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  const std::string data = absl::GetFlag(FLAGS_data);
  if (data.empty()) return Fail("--data: required (directory for blobs and the job database)");
  const int local_workers = absl::GetFlag(FLAGS_local_workers);
  if (local_workers < 0 || local_workers > 64) return Fail("--local-workers: must be in 0..64");
  const int lease_timeout_s = absl::GetFlag(FLAGS_lease_timeout_s);
  if (lease_timeout_s < 1 || lease_timeout_s > 3600) return Fail("--lease-timeout-s: must be in 1..3600");
  const int max_attempts = absl::GetFlag(FLAGS_max_attempts);
  if (max_attempts < 1 || max_attempts > 100) return Fail("--max-attempts: must be in 1..100");

  const int grace_s = absl::GetFlag(FLAGS_shutdown_grace_seconds);
  if (grace_s < 1 || grace_s > 3600) return Fail("--shutdown-grace-seconds: " + std::to_string(grace_s) + " is out of range 1..3600");
  const int worker_failure_limit = absl::GetFlag(FLAGS_worker_failure_limit);
  if (worker_failure_limit < 0 || worker_failure_limit > 1000) return Fail("--worker-failure-limit: " + std::to_string(worker_failure_limit) + " is out of range 0..1000");
  const int worker_pause_s = absl::GetFlag(FLAGS_worker_pause_seconds);
  if (worker_pause_s < 1 || worker_pause_s > 86400) return Fail("--worker-pause-seconds: " + std::to_string(worker_pause_s) + " is out of range 1..86400");
  const int unplaceable_timeout_s = absl::GetFlag(FLAGS_unplaceable_timeout_seconds);
  if (unplaceable_timeout_s < 1 || unplaceable_timeout_s > 2592000) {
    return Fail("--unplaceable-timeout-seconds: " + std::to_string(unplaceable_timeout_s) +
                " is out of range 1..2592000");
  }
  const int retry_elsewhere_s = absl::GetFlag(FLAGS_retry_elsewhere_seconds);
  if (retry_elsewhere_s < 0 || retry_elsewhere_s > 3600) {
    return Fail("--retry-elsewhere-seconds: " + std::to_string(retry_elsewhere_s) + " is out of range 0..3600");
  }
  const int prefer_strong_s = absl::GetFlag(FLAGS_prefer_strong_seconds);
  if (prefer_strong_s < 0 || prefer_strong_s > 3600) {
    return Fail("--prefer-strong-seconds: " + std::to_string(prefer_strong_s) + " is out of range 0..3600");
  }

  auto pools = impostor::ParsePools(absl::GetFlag(FLAGS_pools), absl::GetFlag(FLAGS_pool_shares));
  if (!pools.ok()) return Fail(std::string(pools.status().message()));

  const int64_t max_pending_jobs = absl::GetFlag(FLAGS_max_pending_jobs);
  const int64_t max_pending_per_client = absl::GetFlag(FLAGS_max_pending_per_client);
  const int64_t max_blob_bytes = absl::GetFlag(FLAGS_max_blob_bytes);
  if (max_pending_jobs < 1 || max_pending_per_client < 1 || max_blob_bytes < 1) {
    return Fail("--max-pending-jobs, --max-pending-per-client and --max-blob-bytes must be >= 1");
  }

  impostor::PartialUploadLimits partial_uploads;
  partial_uploads.max_total_bytes = absl::GetFlag(FLAGS_partial_upload_max_bytes);
  if (partial_uploads.max_total_bytes < 0) {
    return Fail("--partial-upload-max-bytes: " + std::to_string(partial_uploads.max_total_bytes) + " is below 0");
  }
  const int partial_max_age_s = absl::GetFlag(FLAGS_partial_upload_max_age_seconds);
  if (partial_max_age_s < 1 || partial_max_age_s > 604800) {
    return Fail("--partial-upload-max-age-seconds: " + std::to_string(partial_max_age_s) +
                " is out of range 1..604800");
  }
  partial_uploads.max_age = std::chrono::seconds(partial_max_age_s);

  const int64_t eviction_grace_s = absl::GetFlag(FLAGS_store_eviction_grace_seconds);
  if (eviction_grace_s < 0 || eviction_grace_s > 86400) {
    return Fail("--store-eviction-grace-seconds: " + std::to_string(eviction_grace_s) + " is out of range 0..86400");
  }
  const int job_retention_days = absl::GetFlag(FLAGS_job_retention_days);
  if (job_retention_days < 0 || job_retention_days > 36500) {
    return Fail("--job-retention-days: " + std::to_string(job_retention_days) + " is out of range 0..36500");
  }
  const int keepalive_seconds = absl::GetFlag(FLAGS_keepalive_seconds);
  if (auto s = impostor::ValidateKeepaliveSeconds("--keepalive-seconds", keepalive_seconds); !s.ok()) {
    return Fail(std::string(s.message()));
  }
  const int touch_flush_s = absl::GetFlag(FLAGS_result_touch_flush_seconds);
  if (touch_flush_s < 1 || touch_flush_s > 3600) {
    return Fail("--result-touch-flush-seconds: " + std::to_string(touch_flush_s) + " is out of range 1..3600");
  }
  // TLS: the files are checked here so that a bad flag stops the start with
  // its name, rather than every handshake failing later.
  const impostor::ServerTlsOptions tls{.cert_file = absl::GetFlag(FLAGS_tls_cert),
                                       .key_file = absl::GetFlag(FLAGS_tls_key),
                                       .client_ca_file = absl::GetFlag(FLAGS_tls_client_ca),
                                       .reload_seconds = absl::GetFlag(FLAGS_tls_reload_seconds)};
  auto listen_credentials = impostor::MakeServerCredentials(tls);
  if (!listen_credentials.ok()) return Fail(std::string(listen_credentials.status().message()));
  // The HTTP front end as clients reach it, sent with GetResult answers.
  auto advertised_http = impostor::AdvertisedHttpFromFlags(!tls.cert_file.empty());
  if (!advertised_http.ok()) return Fail(std::string(advertised_http.status().message()));
  auto auth_mode =
      impostor::ResolveAuthMode(absl::GetFlag(FLAGS_auth), absl::GetFlag(FLAGS_listen), absl::GetFlag(FLAGS_http_listen));
  if (!auth_mode.ok()) return Fail(std::string(auth_mode.status().message()));
  const impostor::QuotaOptions quota_options{
      .max_pending_jobs = absl::GetFlag(FLAGS_token_max_pending_jobs),
      .max_upload_bytes_per_day = absl::GetFlag(FLAGS_token_max_upload_bytes_per_day),
      .max_bakes_per_hour = absl::GetFlag(FLAGS_token_max_bakes_per_hour)};
  if (quota_options.max_pending_jobs < 1 || quota_options.max_upload_bytes_per_day < 1 ||
      quota_options.max_bakes_per_hour < 1) {
    return Fail(
        "--token-max-pending-jobs, --token-max-upload-bytes-per-day and --token-max-bakes-per-hour must be >= 1");
  }

  std::error_code ec;
  std::filesystem::create_directories(data, ec);
  // With TLS, --local-workers reach the server through a Unix socket in a
  // directory only this user may enter, not through the TLS port: they need
  // no certificate (mutual TLS would otherwise need a client certificate the
  // server cannot issue), and no other user on the host can reach the socket.
  std::string local_worker_socket;
  if (tls.enabled() && local_workers > 0) {
    auto socket = impostor::PrepareLocalWorkerSocket(data);
    if (!socket.ok()) return Fail(std::string(socket.status().message()));
    local_worker_socket = *socket;
  }

  const std::string blob_dir = absl::GetFlag(FLAGS_blob_dir).empty() ? data : absl::GetFlag(FLAGS_blob_dir);
  auto blobs = impostor::BlobStore::Open(blob_dir, max_blob_bytes, partial_uploads);
  if (!blobs.ok()) return Fail(std::string(blobs.status().message()));
  const impostor::JobStoreConfig store_config{
      .database_url = absl::GetFlag(FLAGS_database),
      .data_dir = data,
      .pool_size = absl::GetFlag(FLAGS_database_pool_size),
      .statement_timeout_ms = absl::GetFlag(FLAGS_database_statement_timeout_ms),
      .dead_link_seconds = absl::GetFlag(FLAGS_database_dead_link_seconds),
      .maintenance_takeover_ms = int64_t{absl::GetFlag(FLAGS_database_maintenance_takeover_seconds)} * 1000};
  if (store_config.maintenance_takeover_ms < 2000 || store_config.maintenance_takeover_ms > 3'600'000) {
    return Fail("--database-maintenance-takeover-seconds: " +
                std::to_string(store_config.maintenance_takeover_ms / 1000) + " is out of range 2..3600");
  }
  if (store_config.pool_size < 1 || store_config.pool_size > 64) {
    return Fail("--database-pool-size: " + std::to_string(store_config.pool_size) + " is out of range 1..64");
  }
  if (store_config.statement_timeout_ms < 100 || store_config.statement_timeout_ms > 600000) {
    return Fail("--database-statement-timeout-ms: " + std::to_string(store_config.statement_timeout_ms) +
                " is out of range 100..600000");
  }
  if (auto s = impostor::ValidateDeadLinkSeconds("--database-dead-link-seconds", store_config.dead_link_seconds);
      !s.ok()) {
    return Fail(std::string(s.message()));
  }
  auto jobs = impostor::OpenJobStore(store_config);
  if (!jobs.ok()) return Fail(std::string(jobs.status().message()));
  impostor::BakeScheduler scheduler(
      jobs->get(), blobs->get(),
      {.lease_timeout_ms = int64_t{lease_timeout_s} * 1000,
       .max_attempts = static_cast<uint32_t>(max_attempts),
       .max_pending_jobs = max_pending_jobs,
       .max_pending_per_client = max_pending_per_client,
       .store_max_bytes = std::max<int64_t>(0, absl::GetFlag(FLAGS_store_max_bytes)),
       .eviction_grace_ms = eviction_grace_s * 1000,
       .worker_failure_limit = worker_failure_limit,
       .worker_pause_ms = int64_t{worker_pause_s} * 1000,
       .retry_elsewhere_ms = int64_t{retry_elsewhere_s} * 1000,
       .unplaceable_timeout_ms = int64_t{unplaceable_timeout_s} * 1000,
       .prefer_strong_ms = int64_t{prefer_strong_s} * 1000,
       .pools = *pools,
       .job_retention_ms = int64_t{job_retention_days} * 24 * 3600 * 1000});

  // Identity (issue 14): with --auth token every call passes the
  // AccessGuard (authorized_services.h) before reaching a service.
  // Tokens and quota windows live beside the jobs (token_store_factory.h):
  // in --database when the replicas share one, so a token and its quota are
  // the same on every replica; else in DATA/tokens.sqlite3. Either way a
  // restart forgives nothing.
  impostor::NoteWhereTokensLive(data, store_config.database_url);
  std::unique_ptr<impostor::TokenStore> token_store;
  std::unique_ptr<impostor::Authenticator> authenticator;
  std::unique_ptr<impostor::QuotaLedger> quota_ledger;
  // Checked whatever the mode: a bad value waits for the day tokens go on.
  const int token_cache_ttl_ms = absl::GetFlag(FLAGS_token_cache_ttl_ms);
  if (token_cache_ttl_ms < 0 || token_cache_ttl_ms > 60'000) {
    return Fail("--token-cache-ttl-ms: " + std::to_string(token_cache_ttl_ms) + " is out of range 0..60000");
  }
  if (*auth_mode == impostor::AuthMode::kToken) {
    auto opened = impostor::OpenTokenStorage({.database_url = store_config.database_url,
                                              .data_dir = data,
                                              .statement_timeout_ms = store_config.statement_timeout_ms,
                                              .dead_link_seconds = store_config.dead_link_seconds});
    if (!opened.ok()) return Fail(std::string(opened.status().message()));
    token_store = std::move(opened->tokens);
    quota_ledger = std::move(opened->quotas);
    authenticator = std::make_unique<impostor::Authenticator>(token_store.get(), token_cache_ttl_ms);
  }
  impostor::CallPrincipals principals;
  impostor::TokenQuotas quotas(quota_options, {}, std::move(quota_ledger));
  impostor::AccessGuard access_guard(authenticator.get(), &scheduler, &principals, &quotas);

  // HTTP: /metrics, /healthz, /readyz, the JSON API and the dashboard
  // (--http-listen, off by default; server/http/http_frontend.h). Null when off.
  auto http = impostor::HttpFrontend::StartFromFlags(&scheduler, blobs->get(), authenticator.get());
  if (!http.ok()) return Fail(std::string(http.status().message()));
  if (!advertised_http->empty()) spdlog::info("event=http_advertised url={}", *advertised_http);

  impostor::AssetServiceImpl asset_service(blobs->get(), &scheduler, *advertised_http);
  impostor::BakeServiceImpl bake_service(&scheduler, &principals);
  impostor::WorkerServiceImpl worker_service(&scheduler, &principals);
  impostor::AuthorizedAssetService authorized_assets(&access_guard, &asset_service);
  impostor::AuthorizedBakeService authorized_bakes(&access_guard, &bake_service);
  impostor::AuthorizedWorkerService authorized_workers(&access_guard, &worker_service);
  // Administration (issue 14): admin tokens only, e.g. purging a worker's results.
  impostor::AdminServiceImpl admin_service(&scheduler);
  impostor::AuthorizedAdminService authorized_admin(&access_guard, &admin_service);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(absl::GetFlag(FLAGS_listen), *listen_credentials, &port);
  // Local workers' private socket (see above); its directory guards it.
  if (!local_worker_socket.empty()) {
    builder.AddListeningPort("unix:" + local_worker_socket, grpc::InsecureServerCredentials());
  }
  // No SO_REUSEPORT (gRPC's default): a second server on a port in use must
  // fail to start, not share the port and split the clients between two
  // farms with different stores.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.SetMaxReceiveMessageSize(16 << 20);
  impostor::TuneForManyCallers(builder);  // issue 18: server threads, mutex bookkeeping
  impostor::ApplyServerKeepalive(keepalive_seconds, builder);  // issue 15: quiet calls over a cut link
  builder.RegisterService(&authorized_assets);
  builder.RegisterService(&authorized_bakes);
  builder.RegisterService(&authorized_workers);
  builder.RegisterService(&authorized_admin);
  if (*http) builder.experimental().SetInterceptorCreators((*http)->InterceptorCreators());  // RPC metrics
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server || port == 0) return Fail("--listen: cannot listen on " + absl::GetFlag(FLAGS_listen));

  const std::string listen = absl::GetFlag(FLAGS_listen);
  const std::string host = listen.substr(0, listen.rfind(':'));
  spdlog::info("event=listening address={}:{} data={} baker_version={} auth={}", host, port, data,
               impostor::BakerVersion(), token_store ? "token" : "none");
  impostor::LogServerTls(tls, host);
  // Says what gRPC's certificate reload does not (tls_file_monitor.h).
  std::unique_ptr<impostor::TlsFileMonitor> tls_monitor;
  if (tls.enabled()) {
    tls_monitor = std::make_unique<impostor::TlsFileMonitor>(
        tls, [] { return static_cast<int64_t>(std::time(nullptr)); },
        [&http](int64_t not_after) {
          if (*http) (*http)->metrics().SetTlsCertExpiry(not_after);
        });
    tls_monitor->Start();
  }
  std::printf("impostor-server listening on %s:%d\n", host.c_str(), port);
  std::fflush(stdout);
  if (*http) (*http)->AnnounceAddress();
  if (const std::string port_file = absl::GetFlag(FLAGS_port_file); !port_file.empty()) {
    const std::string tmp = port_file + ".tmp";
    if (FILE* f = std::fopen(tmp.c_str(), "w")) {
      std::fprintf(f, "%d\n", port);
      std::fclose(f);
      std::filesystem::rename(tmp, port_file, ec);
    }
  }

  std::unique_ptr<impostor::WorkerSupervisor> supervisor;
  if (local_workers > 0) {
    if (auto released = scheduler.ReleaseLeasesOfPreviousLocalWorkers(); !released.ok()) {
      spdlog::error("event=local_leases_not_released error=\"{}\"", released.status().ToString());
    } else if (*released > 0) {
      spdlog::info("event=local_leases_released jobs={}", *released);
    }
    std::filesystem::path worker_binary = absl::GetFlag(FLAGS_worker_binary);
    if (worker_binary.empty()) {
      worker_binary = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path() / "impostor-worker";
    }
    const std::string connect_host = (host == "0.0.0.0" || host == "[::]" || host.empty()) ? "127.0.0.1" : host;
    // Local workers drain within half the grace period, so a job that cannot
    // finish is handed back while the server can still take it.
    std::vector<std::string> worker_args{"--drain-seconds=" + std::to_string(grace_s / 2)};
    // With tokens, local workers get a worker token minted here, through a
    // file only this user can read (never the secret on a command line).
    if (token_store) {
      auto token_file = impostor::MintLocalWorkerToken(
          token_store.get(), data, impostor::LocalWorkerTokenName(!store_config.database_url.empty(), data));
      if (!token_file.ok()) return Fail(std::string(token_file.status().message()));
      worker_args.push_back("--token-file=" + token_file->string());
    }
    supervisor = std::make_unique<impostor::WorkerSupervisor>(
        worker_binary,
        local_worker_socket.empty() ? connect_host + ":" + std::to_string(port) : "unix:" + local_worker_socket,
        local_workers, worker_args,
        [&scheduler](const std::string& worker_id, const std::string& how) {
          if (auto s = scheduler.WorkerDied(worker_id, how); !s.ok()) {
            spdlog::error("event=worker_death_not_recorded worker={} error=\"{}\"", worker_id, s.ToString());
          }
        });
    if (auto s = supervisor->Start(); !s.ok()) return Fail(std::string(s.message()));
  }

  // SIGINT/SIGTERM/SIGHUP end the server gracefully within --shutdown-grace-seconds;
  // a watcher thread does it (signal handlers may not call into gRPC):
  // 1. local workers drain (finish or hand back their jobs) while the server
  //    still answers them;
  // 2. WatchJob streams and LeaseJob long polls end with UNAVAILABLE, so
  //    clients and workers reconnect to the next server;
  // 3. gRPC stops accepting calls and lets in-flight ones finish until the
  //    deadline, then cancels them.
  // Every accepted job is in the database already; result use times are
  // flushed once the server has stopped (below).
  std::thread signal_thread([&] {
    int sig = 0;
    sigwait(&signals, &sig);
    const auto start = std::chrono::steady_clock::now();
    const auto deadline = start + std::chrono::seconds(grace_s);
    spdlog::info("event=shutdown signal={} grace_s={}", sig, grace_s);
    // The grace is a promise to systemd and to whoever waits on the stop:
    // work blocked on a database that went away during the stop (a pool
    // waits out its reconnect window per call) cannot hold the exit past it.
    // What is cut off is safe to cut: every accepted job is committed, an
    // open transaction rolls back, blob writes are renamed into place whole.
    std::thread([start, deadline] {
      std::this_thread::sleep_until(deadline + kShutdownOverrun);
      spdlog::warn("event=shutdown_forced seconds={:.2f} reason=\"calls or database work still running past "
                   "--shutdown-grace-seconds (a database that stopped answering?)\"",
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
      spdlog::default_logger()->flush();
      std::_Exit(0);
    }).detach();
    if (supervisor) supervisor->Stop(deadline - std::chrono::seconds(grace_s) / 4);
    g_stop = true;
    scheduler.Shutdown();
    const auto left = std::max<std::chrono::steady_clock::duration>(deadline - std::chrono::steady_clock::now(),
                                                                    std::chrono::milliseconds(500));
    server->Shutdown(std::chrono::system_clock::now() +
                     std::chrono::duration_cast<std::chrono::system_clock::duration>(left));
    spdlog::info("event=shutdown_done seconds={:.2f}",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  });

  // Lease expiry and the store cap are checked once a second.
  std::thread reaper([&] {
    uint64_t seen = scheduler.change_count();
    auto next_touch_flush = std::chrono::steady_clock::now() + std::chrono::seconds(touch_flush_s);
    auto next_sweep = std::chrono::steady_clock::now();
    while (!g_stop) {
      if (auto s = scheduler.ExpireLeases(); !s.ok()) spdlog::error("event=expire_leases_failed error=\"{}\"", s.ToString());
      if (auto s = scheduler.EnforceStoreCap(); !s.ok()) {
        spdlog::error("event=eviction_failed error=\"{}\"", s.status().ToString());
      }
      // Serving speed (issue 18): batched use times, bounded job table.
      const auto now = std::chrono::steady_clock::now();
      if (now >= next_touch_flush) {
        next_touch_flush = now + std::chrono::seconds(touch_flush_s);
        if (auto s = scheduler.FlushResultTouches(); !s.ok()) {
          spdlog::warn("event=touch_results_failed error=\"{}\"", s.status().ToString());
        }
      }
      if (now >= next_sweep) {
        next_sweep = now + std::chrono::minutes(10);
        if (auto s = scheduler.SweepFinishedJobs(); !s.ok()) {
          spdlog::error("event=job_sweep_failed error=\"{}\"", s.status().ToString());
        }
      }
      seen = scheduler.WaitForChange(seen, std::chrono::steady_clock::now() + std::chrono::seconds(1));
    }
  });

  server->Wait();
  if (supervisor) supervisor->Stop();
  reaper.join();
  signal_thread.join();
  // Every call has ended: the last result use times go to the database.
  if (auto s = scheduler.FlushResultTouches(); !s.ok()) {
    spdlog::warn("event=touch_results_failed error=\"{}\"", s.status().ToString());
  } else {
    spdlog::info("event=touch_results_flushed results={}", *s);
  }
  spdlog::info("event=stopped");
  return 0;
}
