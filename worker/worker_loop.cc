// The worker's main loop: lease a job, bake it (inputs fetched, memory and
// scratch checked, the products built), upload and complete it, drain on a
// signal. Its link to the farm (retries, outages, uploads) is in
// worker_calls.cc.
#include "worker/worker_loop.h"

#include <chrono>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <span>
#include <thread>
#include <utility>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/request/bake_request.h"
#include "common/net/connect_error.h"
#include "common/error_reason.h"
#include "common/net/keepalive.h"
#include "common/net/transfer_window.h"
#include "common/util/log_escape.h"
#include "common/net/server_list.h"
#include "common/util/sha256.h"
#include "common/net/tls_files.h"
#include "common/net/tls_peer_check.h"
#include "worker/bake/atlas_bake.h"
#include "worker/bake/bake_outputs.h"
#include "worker/bake_memory_check.h"
#include "worker/bearer_token.h"
#include "worker/early_result_upload.h"
#include "worker/input_links.h"
#include "worker/input_plan.h"
#include "worker/scratch_file.h"
#include "worker/scratch_shortage.h"
#include "worker/scratch_space.h"
#include "worker/bake/cards_bake.h"
#include "worker/bake/lod_bake.h"
#include "worker/bake/surfel_bake.h"
#include "worker/test_faults.h"
#include "worker/worker_rpc.h"

namespace impostor {
namespace fs = std::filesystem;
namespace {

// The first word of the test pause file ("" when absent).
std::string ReadTestPauseMode(const fs::path& file) {
  std::ifstream in(file);
  std::string word;
  in >> word;
  return word;
}

using Clock = std::chrono::steady_clock;

// A folder under the scratch directory for one job, named by this worker:
// never from a server-sent string such as the job id, which could hold a
// path (the folder is deleted afterwards).
fs::path NewJobDir(const fs::path& scratch_dir) {
  static std::atomic<uint64_t> next{0};
  return scratch_dir / absl::StrCat("job-", next++);
}

// CompleteJob codes that say the server will never accept this result (too
// big for a message, a manifest it refuses): retrying the bake cannot help.
bool ResultRefusedForGood(grpc::StatusCode code) {
  return code == grpc::StatusCode::INVALID_ARGUMENT || code == grpc::StatusCode::RESOURCE_EXHAUSTED;
}

// Bad input fails the job for good; anything else may succeed elsewhere.
bool IsRetryable(absl::StatusCode code) {
  return code != absl::StatusCode::kInvalidArgument && code != absl::StatusCode::kCancelled &&
         code != absl::StatusCode::kResourceExhausted && code != absl::StatusCode::kUnimplemented;
}

}  // namespace

using worker_rpc::ContextWithDeadline;
using worker_rpc::IsServerFull;
using worker_rpc::ServerErrorReason;

WorkerLoop::WorkerLoop(WorkerOptions options, std::unique_ptr<AtlasRenderer> renderer)
    : options_(std::move(options)), renderer_(std::move(renderer)) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  // Reconnect to a restarted server within seconds, not gRPC's default of up
  // to two minutes.
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 200);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 200);
  if (!options_.tls_server_name.empty()) args.SetSslTargetNameOverride(options_.tls_server_name);
  // A replaced channel (failover_channel.h) must not inherit a dead
  // connection from a shared subchannel pool.
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  // Pings while a call is in flight (issue 15): every call has a deadline,
  // but a blob stream's is 10 minutes; a cut link ends it in seconds.
  ApplyClientKeepalive(options_.keepalive_seconds, args);
  // Meshes and textures download at full speed from the first byte
  // (transfer_window.h).
  ApplyClientTransferWindow(args);
  // main checked the list; a bad one here (a test's options) is one target.
  absl::StatusOr<std::vector<std::string>> targets = ParseServerList(options_.server, "WorkerOptions.server");
  channels_ = std::make_unique<FailoverChannel>(
      targets.ok() ? *targets : std::vector<std::string>{options_.server},
      [this, args](const std::string& target) -> std::shared_ptr<grpc::Channel> {
        // Identity (issue 14): the token goes on every call of the channel.
        std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
        if (auto token = BearerTokenInterceptor(options_.token)) interceptors.push_back(std::move(token));
        return grpc::experimental::CreateCustomChannelWithInterceptors(
            target, options_.channel_credentials ? options_.channel_credentials : grpc::InsecureChannelCredentials(),
            args, std::move(interceptors));
      },
      FailoverChannel::LogMoves::kInfo);
}

absl::Status WorkerLoop::Run() {
  int jobs_done = 0;
  auto backoff = std::chrono::milliseconds(200);
  const auto max_outage = std::chrono::seconds(options_.max_outage_seconds);
  std::optional<Clock::time_point> outage_since;
  std::string outage_why;
  while (!stop_) {
    v1::LeaseJobRequest request;
    request.set_worker_id(options_.worker_id);
    request.set_device(renderer_->device().name);
    if (options_.capabilities.ByteSizeLong() > 0) *request.mutable_capabilities() = options_.capabilities;
    request.set_wait_seconds(5);  // short polls so Stop() is honoured quickly
    v1::LeaseJobResponse response;
    bool try_next_now = false;
    std::string refusal;  // the error reason the server sent
    const grpc::Status s = CallServer(
        [&](const std::shared_ptr<grpc::Channel>& channel) {
          auto ctx = ContextWithDeadline(std::chrono::seconds(15));
          const grpc::Status leased = v1::WorkerService::Stub(channel).LeaseJob(ctx.get(), request, &response);
          refusal = ServerErrorReason(*ctx);
          return leased;
        },
        &try_next_now);
    // A server whose database disk is full answers, and takes leases again
    // once space is freed: waited for without end, no outage to give up on.
    if (IsServerFull(s, refusal)) {
      spdlog::warn("event=lease_failed server={} code={} reason={} error=\"{}\" retry_ms={}", options_.server,
                   static_cast<int>(s.error_code()), EscapeUntrusted(refusal), EscapeUntrusted(s.error_message()),
                   backoff.count());
      std::unique_lock lock(job_mu_);
      job_wake_.wait_for(lock, backoff, [this] { return stop_.load(); });
      backoff = std::min(backoff * 2, std::chrono::milliseconds(5000));
      continue;
    }
    // A refused token is no outage: waiting will not make it valid.
    if (s.error_code() == grpc::StatusCode::UNAUTHENTICATED || s.error_code() == grpc::StatusCode::PERMISSION_DENIED) {
      return absl::Status(static_cast<absl::StatusCode>(s.error_code()),
                          absl::StrCat("LeaseJob: ", s.error_message(), " (check --token-file / IMPOSTOR_TOKEN)"));
    }
    // Another replica not yet tried since the last answer: no outage yet.
    if (!s.ok() && try_next_now) continue;
    if (!s.ok()) {
      const auto now = Clock::now();
      // Why, in words, once per outage (a TLS fault costs a handshake of
      // its own to name: common/net/connect_error.h).
      if (!outage_since) {
        outage_since = now;
        outage_why = s.error_code() == grpc::StatusCode::UNAVAILABLE ? ExplainUnreachable(s.error_message()) : "";
      }
      const double down_s = std::chrono::duration<double>(now - *outage_since).count();
      spdlog::warn("event=lease_failed server={} code={} error=\"{}\" down_s={:.1f} retry_ms={}", options_.server,
                   static_cast<int>(s.error_code()), EscapeUntrusted(outage_why.empty() ? s.error_message() : outage_why),
                   down_s, backoff.count());
      if (now - *outage_since >= max_outage) {
        return absl::UnavailableError(absl::StrCat("server ", options_.server, " unreachable for ",
                                                   static_cast<int64_t>(down_s), " s (--max-outage-seconds ",
                                                   options_.max_outage_seconds, "); ",
                                                   outage_why.empty() ? "last error: " + s.error_message()
                                                                      : outage_why));
      }
      // Wait for the channel to come back (or the backoff to pass) rather
      // than spinning on a dead server.
      channels_->Current().channel->WaitForConnected(std::chrono::system_clock::now() + backoff);
      backoff = std::min(backoff * 2, std::chrono::milliseconds(5000));
      continue;
    }
    if (outage_since) {
      spdlog::info("event=server_back server={} down_s={:.1f}", options_.server,
                   std::chrono::duration<double>(Clock::now() - *outage_since).count());
      outage_since.reset();
    }
    backoff = std::chrono::milliseconds(200);
    if (!response.has_job()) continue;
    if (stop_) {
      // Leased while the drain began: not ours to start.
      ReleaseLease(response.job(), "worker draining: leased as the drain began");
      break;
    }
    const int64_t scratch_needed = ProcessJob(response.job());
    if (options_.max_jobs > 0 && ++jobs_done >= options_.max_jobs) break;
    if (scratch_needed > 0) {
      // Not a lease until the job just failed would fit again: another
      // worker takes it meanwhile (scratch_shortage.h).
      WaitForScratchRoom(options_.scratch_dir, scratch_needed, std::chrono::seconds(options_.max_outage_seconds),
                         [this](std::chrono::milliseconds pause) {
                           std::unique_lock lock(job_mu_);
                           return !job_wake_.wait_for(lock, pause, [this] { return stop_.load(); });
                         });
    }
  }
  return absl::OkStatus();
}

void WorkerLoop::Drain(std::chrono::seconds budget) {
  std::lock_guard lock(job_mu_);
  stop_ = true;
  const auto deadline = Clock::now() + budget;
  if (!drain_deadline_ || deadline < *drain_deadline_) {
    drain_deadline_ = deadline;
    drain_budget_s_ = budget.count();
  }
  job_wake_.notify_all();
}

bool WorkerLoop::DrainDue() const { return drain_deadline_ && Clock::now() >= *drain_deadline_; }

int64_t WorkerLoop::ProcessJob(const v1::LeasedJob& job) {
  const auto start = Clock::now();
  spdlog::info("event=job_start job={} cache_key={} attempt={}", job.job_id(), job.cache_key(), job.attempt());
  std::atomic<bool> cancelled{false};
  std::atomic<bool> lease_lost{false};
  // Draining past its budget: the bake stops and the lease goes back.
  std::atomic<bool> releasing{false};

  // Latest progress, sent by the heartbeat thread (and on stage changes).
  std::mutex& mu = job_mu_;
  std::condition_variable& wake = job_wake_;
  std::string stage = "download";
  double fraction = 0.0;
  bool stage_changed = true;
  bool done = false;
  Clock::time_point last_progress = Clock::now();  // stage or fraction last changed

  auto report = [&](const std::string& st, double f) {
    v1::ReportProgressRequest r;
    r.set_job_id(job.job_id());
    r.set_lease_id(job.lease_id());
    r.set_progress(static_cast<float>(std::clamp(f, 0.0, 1.0)));
    r.set_stage(st);
    v1::ReportProgressResponse resp;
    // Not retried: the next heartbeat goes to the next replica if this one failed.
    const grpc::Status s = CallServer([&](const std::shared_ptr<grpc::Channel>& channel) {
      auto ctx = ContextWithDeadline(std::chrono::seconds(10));
      return v1::WorkerService::Stub(channel).ReportProgress(ctx.get(), r, &resp);
    });
    if (s.error_code() == grpc::StatusCode::FAILED_PRECONDITION) {
      spdlog::warn("event=lease_lost job={} error=\"{}\"", job.job_id(), s.error_message());
      lease_lost = true;
      cancelled = true;
    } else if (s.ok() && resp.cancel_requested()) {
      spdlog::info("event=job_cancel_requested job={}", job.job_id());
      cancelled = true;
    }
  };
  std::thread heartbeat([&] {
    bool stalled = false;
    std::unique_lock lock(mu);
    while (!done) {
      auto until = Clock::now() + std::chrono::seconds(options_.heartbeat_seconds);
      if (drain_deadline_ && !releasing) until = std::min(until, *drain_deadline_);
      wake.wait_until(lock, until, [&]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(job_mu_) {
        return done || stage_changed || (!releasing && DrainDue());
      });
      if (done) break;
      if (Clock::now() - last_progress > std::chrono::seconds(options_.stall_seconds)) {
        // No progress: let the lease run out instead of renewing it.
        if (!std::exchange(stalled, true)) {
          spdlog::warn("event=job_stalled job={} stage={} seconds={}", job.job_id(), stage, options_.stall_seconds);
        }
        continue;
      }
      if (!releasing && DrainDue()) {
        // Out of drain time: stop the bake; the lease is handed back below.
        spdlog::info("event=drain_deadline job={} stage={} action=release", job.job_id(), stage);
        releasing = true;
        cancelled = true;
      }
      const std::string st = stage;
      const double f = fraction;
      stage_changed = false;
      lock.unlock();
      report(st, f);
      lock.lock();
    }
  });
  auto progress = [&](std::string_view st, double f) {
    bool entered_stage = false;
    {
      std::lock_guard lock(mu);
      if (st != stage) stage_changed = entered_stage = true;
      if (st != stage || f != fraction) last_progress = Clock::now();
      stage = std::string(st);
      fraction = f;
      if (stage_changed) wake.notify_all();
    }
    if (entered_stage && st == "render" && ShouldCrashForTest(options_.test_crash_on, job.mesh())) {
      report("render", f);  // so the server knows where it died
      CrashForTest();
    }
    // Test hook (WorkerOptions::test_pause_file): pause on entering the
    // render stage, or after each rendered chunk when the file says
    // "render-chunk".
    const std::string pause_mode =
        st == "render" && !options_.test_pause_file.empty() ? ReadTestPauseMode(options_.test_pause_file) : "";
    if (st == "render" && !options_.test_pause_file.empty() && pause_mode != "complete" &&
        entered_stage != (pause_mode == "render-chunk")) {
      std::error_code ec;
      while (!cancelled && fs::exists(options_.test_pause_file, ec)) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
  };

  const fs::path job_dir = NewJobDir(options_.scratch_dir);
  const fs::path input_dir = job_dir / "input";
  const fs::path output_dir = job_dir / "output";
  std::error_code ec;
  fs::remove_all(job_dir, ec);
  fs::create_directories(input_dir, ec);
  fs::create_directories(output_dir, ec);
  // The scratch as the job found it: what its inputs must fit, and what a
  // shortage later is measured against (scratch_shortage.h).
  const absl::StatusOr<ScratchSpace> scratch_at_start = MeasureScratch(options_.scratch_dir);
  int64_t inputs_need = -1;
  // The atlas maps go up while the quality pass still runs (their upload
  // after the bake then finds them stored).
  EarlyResultUpload early_upload([this](const auto& rpc) { return CallAssets(rpc); }, cancelled);

  absl::StatusOr<AtlasBakeOutput> result = [&]() -> absl::StatusOr<AtlasBakeOutput> {
    if (auto s = ValidateMeshInput(job.mesh()); !s.ok()) return s;
    if (auto s = FailureForTest(options_.test_fail_on, job.mesh()); !s.ok()) return s;
    // Too large for this worker's memory: refused before the download, as
    // the job's fault (RESOURCE_EXHAUSTED, final) or, when only what is
    // free now falls short, the worker's (UNAVAILABLE, retried elsewhere).
    if (auto s = CheckBakeFitsWorker(job.parameters(), renderer_->device(), HostMemoryForTest()); !s.ok()) return s;
    if (!scratch_at_start.ok()) return scratch_at_start.status();
    // Inputs: the entry under its own name, the rest under their relative
    // paths (validated above: no absolute paths, no ".."), each distinct
    // blob downloaded once and linked under its other paths.
    const InputPlan plan = PlanInputs(job.mesh(), input_dir);
    const ScratchDemand demand = EstimateScratchDemand(plan, input_dir, scratch_at_start->block_bytes);
    inputs_need = demand.bytes;
    if (auto s = CheckInputsFit(demand, *scratch_at_start, options_.scratch_dir); !s.ok()) return s;
    const fs::path entry = plan.entry_path;
    const auto t = Clock::now();
    for (const InputBlob& blob : plan.blobs) {
      if (cancelled) return absl::CancelledError("cancelled while downloading");
      if (auto s = DownloadThroughOutage(blob.digest, blob.paths.front()); !s.ok()) return s;
      if (auto s = LinkInputCopies(blob.paths.front(), std::span(blob.paths).subspan(1)); !s.ok()) return s;
    }
    const double download_seconds = std::chrono::duration<double>(Clock::now() - t).count();
    // Untrusted bytes meet the loader in a child process first (issue 23).
    // The child's scene is the bake's: the file is decoded once.
    progress("load", 0.0);
    const auto load_start = Clock::now();
    absl::StatusOr<Scene> scene =
        LoadSceneInChild(entry, options_.load_limits, options_.load_isolation, &cancelled);
    if (!scene.ok()) return scene.status();
    const double isolated_load_seconds = std::chrono::duration<double>(Clock::now() - load_start).count();
    AtlasBakeRequest request{.entry_file = entry,
                             .parameters = job.parameters(),
                             .cache_key = job.cache_key(),
                             .output_dir = output_dir,
                             .load_limits = options_.load_limits,
                             .scene = std::make_shared<const Scene>(*std::move(scene)),
                             .map_written = [&](const fs::path& file, const BlobDigest& digest) {
                               if (!lease_lost) early_upload.Offer(file, digest);
                             }};
    auto out = [&]() -> absl::StatusOr<AtlasBakeOutput> {
      switch (job.parameters().product()) {
        case v1::PRODUCT_SURFELS: return BakeSurfels(request, *renderer_, progress, cancelled);
        case v1::PRODUCT_LOD_CHAIN: return BakeLodChain(request, *renderer_, progress, cancelled);
        case v1::PRODUCT_CARDS: return BakeCards(request, *renderer_, progress, cancelled);
        default: return BakeAtlas(request, *renderer_, progress, cancelled);
      }
    }();
    if (!out.ok()) return out;
    out->manifest.mutable_timings()->set_download_seconds(download_seconds);
    v1::BakeTimings* timings = out->manifest.mutable_timings();
    timings->set_load_seconds(timings->load_seconds() + isolated_load_seconds);
    timings->set_total_seconds(timings->total_seconds() + isolated_load_seconds);
    // The bake wrote manifest.json before this loop's own stages (download,
    // the isolated load) were added: written again, so that the file says
    // what the proto does. (Its upload, store_seconds, comes after it.)
    return WriteManifest(output_dir, std::move(out->manifest));
  }();

  const int early_files = early_upload.Finish();
  absl::Status outcome = result.status();
  // The maps and manifest.json into the server's store (again, for a
  // CompleteJob that found one gone: the store may evict between the
  // upload and the completion, with --store-eviction-grace-seconds 0).
  auto upload_result = [&] {
    std::vector<std::pair<fs::path, v1::Digest>> files;
    for (const auto& map : result->manifest.maps()) files.emplace_back(output_dir / map.file(), map.digest());
    files.emplace_back(result->manifest_path, result->manifest.manifest_json());
    return UploadAll(files, "job=" + job.job_id());
  };
  if (result.ok() && !lease_lost) {
    progress("upload", 0.96);
    spdlog::info("event=job_upload job={} files={} stored_during_bake={}", job.job_id(),
                 result->manifest.maps_size() + 1, early_files);
    const auto t = Clock::now();
    outcome = upload_result();
    result->manifest.mutable_timings()->set_store_seconds(std::chrono::duration<double>(Clock::now() - t).count());
    // Test hook (WorkerOptions::test_pause_file saying "complete"): between
    // the upload and CompleteJob, heartbeats going on, the stage reading
    // "uploaded" so a test knows the blobs are in.
    if (!options_.test_pause_file.empty() && ReadTestPauseMode(options_.test_pause_file) == "complete") {
      progress("uploaded", 0.97);
      std::error_code ec;
      while (!cancelled && fs::exists(options_.test_pause_file, ec)) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
  }
  {
    std::lock_guard lock(mu);
    done = true;
    wake.notify_all();
  }
  heartbeat.join();

  if (lease_lost) {
    spdlog::warn("event=job_dropped job={} reason=lease_lost", job.job_id());
  } else if (releasing && !outcome.ok()) {
    int64_t budget_s = 0;
    {
      std::lock_guard lock(job_mu_);
      budget_s = drain_budget_s_;
    }
    // Say which stop it was: SIGINT, a second SIGTERM or the supervising
    // server's death hands the job back at once; a SIGTERM waits its budget.
    ReleaseLease(job, budget_s == 0 ? std::string("worker stopped: handed back at once (SIGINT, a second SIGTERM, or its "
                                                  "supervising server went away)")
                                    : absl::StrCat("worker draining: not done within --drain-seconds ", budget_s));
  } else if (outcome.ok()) {
    v1::CompleteJobRequest r;
    r.set_job_id(job.job_id());
    r.set_lease_id(job.lease_id());
    *r.mutable_result() = result->manifest;
    bool complete_timed_out = false;
    // A full disk on the server is waited out (the result is kept); past
    // the budget the attempt fails retryably, below, with the reason.
    std::string stayed_full;
    auto complete = [&] {
      return RetryThroughFullServer(
          "CompleteJob", "job=" + job.job_id(),
          [&](const std::shared_ptr<grpc::Channel>& channel, std::string* refusal) {
            v1::CompleteJobResponse resp;
            auto ctx = ContextWithDeadline(std::chrono::seconds(30));
            const grpc::Status done = v1::WorkerService::Stub(channel).CompleteJob(ctx.get(), r, &resp);
            if (done.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED) complete_timed_out = true;
            *refusal = ServerErrorReason(*ctx);
            return done;
          },
          &stayed_full);
    };
    grpc::Status s = complete();
    if (s.error_code() == grpc::StatusCode::FAILED_PRECONDITION &&
        s.error_message().find("is not in the store") != std::string::npos) {
      // Evicted since the upload: once more, rather than leave the job to
      // wait out its lease and be baked again.
      spdlog::warn("event=result_blob_gone job={} action=upload_again error=\"{}\"", job.job_id(),
                   EscapeUntrusted(s.error_message()));
      if (absl::Status again = upload_result(); again.ok()) s = complete();
    }
    // A retry whose lease is gone after a try that timed out: that try may
    // well have been recorded (the server answers queued calls once its
    // database is back), so the log says so rather than a plain failure.
    const bool maybe_recorded = s.error_code() == grpc::StatusCode::FAILED_PRECONDITION && complete_timed_out &&
                                s.error_message().find("is not leased under") != std::string::npos;
    spdlog::info("event=job_done job={} ok={} seconds={:.2f}{}", job.job_id(),
                 s.ok() ? "true" : (maybe_recorded ? "unknown" : "false"),
                 std::chrono::duration<double>(Clock::now() - start).count(),
                 s.ok() ? ""
                        : absl::StrCat(" error=\"", EscapeUntrusted(s.error_message()), "\"",
                                       maybe_recorded ? " note=\"an earlier CompleteJob timed out and was probably "
                                                        "recorded by the server after all\""
                                                      : ""));
    // A refused result is failed now, with the reason, rather than left to
    // time out and be baked again three times (issue 23); so is one whose
    // blobs the store dropped twice (the job is retried elsewhere at once).
    if (!stayed_full.empty()) {
      // Retryable: the result is not at fault; another attempt may find
      // space. The reason goes with it to FailJob, so the server does not
      // count its own state against this worker.
      outcome = WithErrorReason(absl::UnavailableError(s.error_message()), stayed_full);
    } else if (ResultRefusedForGood(s.error_code()) ||
               (s.error_code() == grpc::StatusCode::FAILED_PRECONDITION &&
                s.error_message().find("is not in the store") != std::string::npos)) {
      outcome = absl::Status(static_cast<absl::StatusCode>(s.error_code()),
                             absl::StrCat("the server refused the result: CompleteJob: ", s.error_message()));
    }
  }
  int64_t scratch_to_lease_again = 0;
  if (!lease_lost && !outcome.ok() && scratch_at_start.ok()) {
    // A full scratch is named, and ended as the job's fault or the worker's
    // (scratch_shortage.h), instead of an unnamed, retryable INTERNAL.
    const ScratchFacts facts{.at_start = *scratch_at_start,
                             .now = MeasureScratch(job_dir).value_or(*scratch_at_start),
                             .job = BytesHeldUnder(job_dir),
                             .inputs_need = inputs_need};
    outcome = AttributeScratchShortage(outcome, facts, options_.scratch_dir);
    if (IsShortOnThisWorker(outcome)) scratch_to_lease_again = BytesToLeaseAgain(facts);
  }
  if (!lease_lost && !outcome.ok()) {
    v1::FailJobRequest r;
    r.set_job_id(job.job_id());
    r.set_lease_id(job.lease_id());
    r.mutable_error()->set_code(static_cast<int>(outcome.code()));
    r.mutable_error()->set_message(std::string(outcome.message()));
    r.mutable_error()->set_reason(ErrorReasonOf(outcome));
    r.set_retryable(IsRetryable(outcome.code()));
    const grpc::Status s = RetryThroughFullServer(
        "FailJob", "job=" + job.job_id(), [&](const std::shared_ptr<grpc::Channel>& channel, std::string* refusal) {
          v1::FailJobResponse resp;
          auto ctx = ContextWithDeadline(std::chrono::seconds(30));
          const grpc::Status failed = v1::WorkerService::Stub(channel).FailJob(ctx.get(), r, &resp);
          *refusal = ServerErrorReason(*ctx);
          return failed;
        });
    spdlog::info("event=job_failed job={} code={} retryable={}{} error=\"{}\" reported={}", job.job_id(),
                 static_cast<int>(outcome.code()), r.retryable(),
                 r.error().reason().empty() ? "" : absl::StrCat(" reason=", r.error().reason()),
                 EscapeUntrusted(std::string(outcome.message())), s.ok());
  }
  fs::remove_all(job_dir, ec);
  return scratch_to_lease_again;
}

}  // namespace impostor
