// impostor bake-batch SPEC (and impostor bake A B ...): many bakes from one
// command. One FindMissingBlobs and the uploads for the whole batch
// (Client::SubmitBakeBatch), then a bounded pool of WatchJob streams follows
// the submitted jobs, highest priority first then in SPEC order (the order
// the server leases one client's jobs in), and downloads each result into
// DIR/<name>/ as soon as it finishes. Cached results need no stream: a
// watcher downloads them at once.
//
// A submit the server refuses for a quota that passes with time (the
// token's pending jobs, its bakes per hour: quota_refusal.h) is not the
// asset's result: the asset is held back ("held N" on the live line) and
// submitted again once one of the batch's own jobs ends, or after a backoff,
// until the batch has made no progress for --max-outage-seconds.
//
// Once the server is declared lost (a call spent the outage budget), the
// batch ends at once: every asset not yet followed or submitted is reported
// with the outage's reason, rather than each asset trying on its own.
//
// Threads: the calling thread submits (and resubmits held assets);
// kWatchStreams watcher threads follow and download. Everything shared
// lives in BatchRunner under `mu_`, and every line of output is written
// under it, so JSON lines never interleave.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>
#include <utility>

#include <nlohmann/json.hpp>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/cli/batch_report.h"
#include "client/cli/batch_spec.h"
#include "client/cli/bake_settings.h"
#include "client/cli/commands.h"
#include "client/cli/connection_options.h"
#include "client/cli/output.h"
#include "client/cli/quota_refusal.h"
#include "client/transport/job_convert.h"
#include "common/request/bake_request.h"
#include "impostor/client.h"

namespace impostor::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// WatchJob streams open at once. Enough to follow every job a farm of a few
// dozen workers runs for one client; each stream is one thread here and one
// cheap wait on the server.
constexpr size_t kWatchStreams = 8;

// Backoff between submits of held assets when no job of the batch ends
// first: doubling from the first to the last.
constexpr double kFirstQuotaRetrySeconds = 1;
constexpr double kMaxQuotaRetrySeconds = 30;


// A model's manifest.json "quality" block, or null.
nlohmann::json QualityOf(const fs::path& manifest) {
  std::ifstream in(manifest);
  nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("quality") && j["quality"].is_object()) return j["quality"];
  return nullptr;
}

// An RPC that failed for want of a working connection, as opposed to the
// server judging this one request (a refusal, a quota or a full disk).
bool IsConnectionError(const absl::Status& s) {
  return sdk::GetRpcErrorInfo(s).has_value() && !IsRefusal(s.code()) &&
         s.code() != absl::StatusCode::kResourceExhausted;
}

class BatchRunner {
 public:
  BatchRunner(const CliArgs& args, const BatchSpec& spec, sdk::Client& client)
      : args_(args), spec_(spec), client_(client), items_(spec.entries.size()),
        progress_(stderr, isatty(STDERR_FILENO) == 1) {
    counts_.total = static_cast<int>(items_.size());
  }

  int Run() {
    start_ = Clock::now();
    std::vector<std::thread> watchers;
    for (size_t i = 0; i < std::min(kWatchStreams, items_.size()); ++i) watchers.emplace_back([this] { Watch(); });

    std::vector<sdk::BatchItem> batch;
    for (const BatchEntry& e : spec_.entries) {
      batch.push_back({e.model, e.settings});
      batch.back().settings.follow_symlinks = args_.follow_symlinks;
    }
    absl::StatusOr<std::vector<sdk::BatchSubmission>> submitted = client_.SubmitBakeBatch(
        batch, [this](size_t i, const sdk::BatchSubmission& s) { return OnSubmitted(i, s); });
    {
      std::unique_lock lock(mu_);
      if (!submitted.ok()) {
        // Nothing was submitted: the uploads failed.
        batch_error_ = submitted.status();
        for (size_t i = 0; i < items_.size(); ++i) {
          Finish(i,
                 Failed(i, Describe(submitted.status(), "not submitted"),
                        static_cast<int>(submitted.status().code())),
                 AssetStatus::kSkipped);
        }
      } else {
        for (size_t i = 0; i < items_.size(); ++i) {
          if ((*submitted)[i].status.code() != absl::StatusCode::kCancelled || items_[i].phase != Phase::kPending) {
            continue;
          }
          // The pass stopped at a quota: the rest would be refused too.
          if (!held_.empty() && !stop_ && !connection_failed_) {
            Hold(i);
          } else {
            SkipUnsubmitted(i);
          }
        }
        SubmitHeld(lock);
      }
      submitting_done_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : watchers) t.join();
    return Report();
  }

 private:
  enum class Phase { kPending, kHeld, kQueued, kRunning, kFinished };
  struct Item {
    Phase phase = Phase::kPending;
    sdk::SubmitResult submitted;
    Clock::time_point submit_time;
  };

  bool OnSubmitted(size_t i, const sdk::BatchSubmission& s) {
    std::lock_guard lock(mu_);
    Accept(i, s.status, s.result);
    // After a quota refusal the rest of this pass would be refused too: the
    // pass stops and they are held (Run).
    return !stop_ && !connection_failed_ && held_.empty();
  }

  // The outcome of submitting asset i (in the batch's pass or again).
  void Accept(size_t i, const absl::Status& status, const sdk::SubmitResult& result)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    Item& item = items_[i];
    item.submit_time = Clock::now();
    if (!status.ok()) {
      if (IsConnectionError(status)) {
        // The asset's own line first, then everything left at once.
        Finish(i, Failed(i, Describe(status), static_cast<int>(status.code())), AssetStatus::kFailed);
        ConnectionLost(status);
        return;
      }
      const std::optional<sdk::RpcErrorInfo> rpc = sdk::GetRpcErrorInfo(status);
      const QuotaWait wait =
          rpc.has_value() ? QuotaWaitFor(status.code(), rpc->rpc, rpc->server_message, rpc->reason) : QuotaWait::kNone;
      if (wait != QuotaWait::kNone && !stop_) {
        // The first refusal starts the hold (its line, clock and backoff);
        // a held asset refused again continues it, also the last one, which
        // is out of held_ while SubmitHeld sends it again.
        if (!holding_) StartHolding(wait, status);
        last_refusal_ = status;
        hold_kind_ = wait;
        Hold(i);
        return;
      }
      Finish(i, Failed(i, Describe(status), status), AssetStatus::kFailed);
      return;
    }
    // A submit got through: the quota wait starts over, and once nothing is
    // held the hold is over (a later refusal starts a new one).
    last_progress_ = Clock::now();
    retry_seconds_ = kFirstQuotaRetrySeconds;
    if (held_.empty()) holding_ = false;
    item.submitted = result;
    // A cached result that failed this request's quality gate is a failure
    // known now: without --keep-going nothing more is submitted (its
    // watcher still records it and fetches the result for inspection).
    if (result.error_code != 0 && !args_.keep_going) stop_ = true;
    SetPhase(i, Phase::kQueued);
    if (connection_failed_) {
      Finish(i, Failed(i, Describe(connection_error_, "not followed"), static_cast<int>(connection_error_.code())),
             AssetStatus::kFailed);
      return;
    }
    queue_.insert({-spec_.entries[i].settings.priority, i});
    wake_.notify_one();
    Redraw();
  }

  // A quota refused a submit: from now on assets are held. One line says
  // so (the live line then counts them as "held").
  void StartHolding(QuotaWait wait, const absl::Status& status) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    holding_ = true;
    last_progress_ = Clock::now();
    retry_seconds_ = kFirstQuotaRetrySeconds;
    if (args_.quiet) return;
    progress_.PrintLine(absl::StrCat(
        "impostor: ", Describe(status), "; holding assets back and submitting them again ",
        wait == QuotaWait::kOwnJobs ? "as this batch's jobs finish" : "after a backoff",
        absl::StrFormat(" (for up to %g s without progress)", OutageBudgetSeconds())));
  }

  void Hold(size_t i) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    SetPhase(i, Phase::kHeld);
    held_.insert({-spec_.entries[i].settings.priority, i});
    Redraw();
  }

  // --max-outage-seconds: also how long held assets wait without progress.
  double OutageBudgetSeconds() const { return args_.max_outage_seconds.value_or(kBakeOutageSeconds); }

  // Submits the held assets again, highest priority first, whenever one of
  // the batch's jobs ends or the backoff has passed, until none is left.
  // Gives them up (failed, with the quota's refusal) once the batch made no
  // progress for OutageBudgetSeconds() and no job of its own is left to
  // free a pending-jobs quota.
  void SubmitHeld(std::unique_lock<std::mutex>& lock) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    while (!held_.empty()) {
      if (stop_ || connection_failed_) {
        while (!held_.empty()) {
          const size_t i = held_.begin()->second;
          held_.erase(held_.begin());
          SkipUnsubmitted(i);
        }
        holding_ = false;
        return;
      }
      const auto budget = std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double>(OutageBudgetSeconds()));
      const auto retry = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(retry_seconds_));
      const Clock::time_point give_up_at = last_progress_ + budget;
      const Clock::time_point next_try = std::min(Clock::now() + retry, give_up_at);
      job_ended_ = false;
      resubmit_wake_.wait_until(lock, next_try, [&]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
        return job_ended_ || stop_ || connection_failed_;
      });
      if (stop_ || connection_failed_) continue;
      const bool own_jobs_left = hold_kind_ == QuotaWait::kOwnJobs && counts_.queued + counts_.running > 0;
      if (!job_ended_ && !own_jobs_left && Clock::now() >= give_up_at) {
        GiveUpHeld();
        return;
      }
      retry_seconds_ = std::min(retry_seconds_ * 2, kMaxQuotaRetrySeconds);
      // Until one is refused again (it is then held once more).
      while (!held_.empty() && !stop_ && !connection_failed_) {
        const size_t i = held_.begin()->second;
        held_.erase(held_.begin());
        SetPhase(i, Phase::kPending);
        sdk::BakeSettings settings = spec_.entries[i].settings;
        settings.follow_symlinks = args_.follow_symlinks;
        lock.unlock();
        absl::StatusOr<sdk::SubmitResult> result = client_.SubmitBake(spec_.entries[i].model, settings);
        lock.lock();
        Accept(i, result.status(), result.ok() ? *result : sdk::SubmitResult{});
        if (items_[i].phase == Phase::kHeld) break;
      }
    }
  }

  // Held assets whose quota did not free up in time: failed, with the
  // server's refusal.
  void GiveUpHeld() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const std::string reason = absl::StrCat(
        Describe(last_refusal_),
        absl::StrFormat(" (held back; no progress for %g s, see --max-outage-seconds)", OutageBudgetSeconds()));
    while (!held_.empty()) {
      const size_t i = held_.begin()->second;
      held_.erase(held_.begin());
      Finish(i, Failed(i, reason, last_refusal_), AssetStatus::kFailed);
    }
    holding_ = false;
  }

  // An asset that will not be submitted: the batch stopped, or the server
  // is gone.
  void SkipUnsubmitted(size_t i) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    if (connection_failed_) {
      Finish(i, Failed(i, Describe(connection_error_, "not submitted"), static_cast<int>(connection_error_.code())),
             AssetStatus::kSkipped);
    } else {
      Finish(i,
             Failed(i,
                    CodeAndMessage(static_cast<int>(absl::StatusCode::kCancelled),
                                   "not submitted: the batch stopped after a failure (use --keep-going to bake the rest)"),
                    static_cast<int>(absl::StatusCode::kCancelled)),
             AssetStatus::kSkipped);
    }
  }

  // A call spent the outage budget (--max-outage-seconds, counted once for
  // the whole client): the server is gone for this batch. Every asset
  // waiting for a watcher is reported now with that reason, instead of each
  // one trying on its own; held assets are skipped; the pass of submits
  // stops (OnSubmitted).
  void ConnectionLost(const absl::Status& status) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    if (connection_failed_) return;
    connection_failed_ = true;
    connection_error_ = status;
    while (!queue_.empty()) {
      const size_t i = queue_.begin()->second;
      queue_.erase(queue_.begin());
      Finish(i, Failed(i, Describe(status, "not followed"), static_cast<int>(status.code())), AssetStatus::kFailed);
    }
    resubmit_wake_.notify_all();
    wake_.notify_all();
  }

  // One of the batch's jobs ended: a pending-jobs quota may have room.
  void JobEnded() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    job_ended_ = true;
    last_progress_ = Clock::now();
    resubmit_wake_.notify_all();
  }

  // A watcher: takes the next job in lease order and follows it to its end.
  void Watch() {
    while (true) {
      size_t i;
      {
        std::unique_lock lock(mu_);
        wake_.wait(lock, [&]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) { return !queue_.empty() || submitting_done_; });
        if (queue_.empty()) return;
        i = queue_.begin()->second;
        queue_.erase(queue_.begin());
      }
      Follow(i);
    }
  }

  void Follow(size_t i) {
    sdk::SubmitResult submitted;
    {
      std::lock_guard lock(mu_);
      submitted = items_[i].submitted;
    }
    int error_code = submitted.error_code;
    std::string error_message = submitted.error_message;
    bool cached = submitted.cached;
    if (!submitted.cached) {
      absl::StatusOr<sdk::JobUpdate> done = client_.WatchJob(submitted.job_id, [&](const sdk::JobUpdate& u) {
        std::lock_guard lock(mu_);
        if (u.state == sdk::JobState::kRunning) SetPhase(i, Phase::kRunning);
        if (u.state == sdk::JobState::kQueued) SetPhase(i, Phase::kQueued);
        Redraw();
      });
      if (!done.ok()) {
        std::lock_guard lock(mu_);
        Finish(i, Failed(i, Describe(done.status()), static_cast<int>(done.status().code())), AssetStatus::kFailed);
        if (IsConnectionError(done.status())) ConnectionLost(done.status());
        return;
      }
      {
        std::lock_guard lock(mu_);
        JobEnded();
      }
      cached = done->cached;
      if (done->state == sdk::JobState::kCancelled) {
        error_code = done->error_code != 0 ? done->error_code : static_cast<int>(absl::StatusCode::kCancelled);
        error_message = done->error_message.empty() ? "the job was cancelled" : done->error_message;
      } else if (done->state != sdk::JobState::kSucceeded) {
        error_code = done->error_code != 0 ? done->error_code : static_cast<int>(absl::StatusCode::kUnknown);
        error_message = done->error_message;
      }
    }
    // A quality gate failure keeps its result: download it for inspection.
    const bool gate_failed = error_code == static_cast<int>(absl::StatusCode::kFailedPrecondition) &&
                             error_message.rfind("quality gate", 0) == 0;
    AssetOutcome outcome;
    {
      std::lock_guard lock(mu_);
      outcome = Base(i);
    }
    outcome.cached = cached;
    if (error_code == 0 || gate_failed) {
      absl::StatusOr<sdk::FetchResult> fetched = client_.Fetch(submitted.cache_key, outcome.out_dir);
      if (!fetched.ok()) {
        std::lock_guard lock(mu_);
        AssetOutcome failed =
            Failed(i, Describe(fetched.status(), "download failed"), static_cast<int>(fetched.status().code()));
        failed.cached = cached;  // the bake was a hit; only its download failed
        Finish(i, std::move(failed), AssetStatus::kFailed);
        if (IsConnectionError(fetched.status())) ConnectionLost(fetched.status());
        return;
      }
      for (const fs::path& f : fetched->files) outcome.files.push_back(f.string());
      outcome.quality = QualityOf(fetched->manifest_path);
      outcome.warnings = fetched->warnings;
    }
    std::lock_guard lock(mu_);
    if (error_code != 0) {
      outcome.error_code = error_code;
      outcome.error = CodeAndMessage(error_code, error_message);
      Finish(i, std::move(outcome), AssetStatus::kFailed);
    } else {
      Finish(i, std::move(outcome), AssetStatus::kSucceeded);
    }
  }

  void Redraw() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    if (!args_.quiet) progress_.Update(counts_);
  }

  AssetOutcome Base(size_t i) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const BatchEntry& e = spec_.entries[i];
    AssetOutcome o;
    o.asset = e.asset;
    o.name = e.name;
    o.out_dir = (fs::path(args_.out) / e.name).string();
    o.priority = e.settings.priority;
    o.cache_key = items_[i].submitted.cache_key;
    o.job_id = items_[i].submitted.job_id;
    return o;
  }

  AssetOutcome Failed(size_t i, const std::string& error, int code) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    AssetOutcome o = Base(i);
    o.error = error;
    o.error_code = code;
    return o;
  }
  // Failed with `status`'s code and the server's error reason, if any.
  AssetOutcome Failed(size_t i, const std::string& error, const absl::Status& status)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    AssetOutcome o = Failed(i, error, static_cast<int>(status.code()));
    if (const std::optional<sdk::RpcErrorInfo> rpc = sdk::GetRpcErrorInfo(status)) o.error_reason = rpc->reason;
    return o;
  }

  void SetPhase(size_t i, Phase phase) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    Phase& p = items_[i].phase;
    if (p == phase || p == Phase::kFinished) return;
    if (p == Phase::kHeld) --counts_.held;
    if (p == Phase::kQueued) --counts_.queued;
    if (p == Phase::kRunning) --counts_.running;
    if (phase == Phase::kHeld) ++counts_.held;
    if (phase == Phase::kQueued) ++counts_.queued;
    if (phase == Phase::kRunning) ++counts_.running;
    p = phase;
  }

  void Finish(size_t i, AssetOutcome outcome, AssetStatus status) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    if (items_[i].phase == Phase::kFinished) return;
    SetPhase(i, Phase::kFinished);
    outcome.status = status;
    if (status != AssetStatus::kSkipped && items_[i].submit_time != Clock::time_point{}) {
      outcome.wall_seconds = std::chrono::duration<double>(Clock::now() - items_[i].submit_time).count();
    }
    switch (status) {
      case AssetStatus::kSucceeded: ++(outcome.cached ? counts_.cached : counts_.baked); break;
      case AssetStatus::kFailed:
        ++counts_.failed;
        if (!args_.keep_going) {
          stop_ = true;
          resubmit_wake_.notify_all();
        }
        break;
      case AssetStatus::kSkipped: ++counts_.skipped; break;
    }
    if (status == AssetStatus::kFailed) failures_.push_back(absl::StrCat(outcome.asset, ": ", outcome.error));
    // Warnings go to stderr even with --quiet, as `impostor bake` prints
    // them: they say what the result lacks.
    for (const std::string& w : outcome.warnings) std::fprintf(stderr, "warning: %s: %s\n", outcome.name.c_str(), w.c_str());
    if (args_.json) {
      PrintJson(AssetJson(outcome));
    } else {
      std::string line;
      if (status == AssetStatus::kSucceeded) {
        line = absl::StrCat("succeeded  ", outcome.name, "  ", outcome.out_dir, "  (",
                            outcome.cached ? "cached" : "baked", absl::StrFormat(", %.1f s)", outcome.wall_seconds));
      } else {
        line = absl::StrCat(status == AssetStatus::kFailed ? "failed     " : "skipped    ", outcome.asset, "  ",
                            outcome.error);
      }
      std::printf("%s\n", line.c_str());
      std::fflush(stdout);
    }
    Redraw();
  }

  int Report() {
    std::lock_guard lock(mu_);
    const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
    int exit_code = kExitOk;
    if (connection_failed_ || !batch_error_.ok()) {
      exit_code = batch_error_.ok() ? kExitServer : ExitCodeFor(batch_error_);
    } else if (counts_.failed + counts_.skipped > 0) {
      exit_code = kExitBakeFailed;
    }
    if (!args_.quiet) {
      progress_.Finish(counts_);
      std::fprintf(stderr, "batch: %d assets, %d succeeded (%d baked, %d cached), %d failed, %d skipped, %.1f s\n",
                   counts_.total, counts_.baked + counts_.cached, counts_.baked, counts_.cached, counts_.failed,
                   counts_.skipped, wall);
    }
    std::string reason;
    if (exit_code != kExitOk && !batch_error_.ok()) {
      reason = Describe(batch_error_);
    } else if (exit_code != kExitOk) {
      // One line naming every failed asset (the first ten) and why.
      std::vector<std::string> shown(failures_.begin(), failures_.begin() + std::min<size_t>(failures_.size(), 10));
      reason = absl::StrCat(counts_.failed, " of ", counts_.total, " assets failed");
      if (counts_.skipped > 0) absl::StrAppend(&reason, ", ", counts_.skipped, " not submitted");
      absl::StrAppend(&reason, ": ", absl::StrJoin(shown, "; "));
      if (failures_.size() > shown.size()) absl::StrAppend(&reason, "; and ", failures_.size() - shown.size(), " more");
    }
    if (args_.json) PrintJson(SummaryJson(counts_, wall, exit_code, reason));
    if (exit_code == kExitOk) return exit_code;
    return Fail(exit_code, reason);
  }

  const CliArgs& args_;
  const BatchSpec& spec_;
  sdk::Client& client_;
  Clock::time_point start_;

  std::mutex mu_;
  std::condition_variable wake_;
  std::vector<Item> items_ ABSL_GUARDED_BY(mu_);
  // Submitted jobs nobody follows yet: (-priority, index), so the first is
  // the one the server leases first.
  std::set<std::pair<int32_t, size_t>> queue_ ABSL_GUARDED_BY(mu_);
  bool submitting_done_ ABSL_GUARDED_BY(mu_) = false;
  bool stop_ ABSL_GUARDED_BY(mu_) = false;
  // The server is gone for this batch, and the call that found it so.
  bool connection_failed_ ABSL_GUARDED_BY(mu_) = false;
  absl::Status connection_error_ ABSL_GUARDED_BY(mu_);
  // Assets a quota refused, to submit again, ordered as queue_.
  std::set<std::pair<int32_t, size_t>> held_ ABSL_GUARDED_BY(mu_);
  // A hold is under way: from the first quota refusal until nothing is held
  // (a submit accepted with held_ empty, or the held assets given up or
  // skipped). Not the same as !held_.empty(): SubmitHeld takes an asset out
  // of held_ while it sends it again.
  bool holding_ ABSL_GUARDED_BY(mu_) = false;
  QuotaWait hold_kind_ ABSL_GUARDED_BY(mu_) = QuotaWait::kNone;
  absl::Status last_refusal_ ABSL_GUARDED_BY(mu_);
  // The last accepted submit or ended job: held assets give up after
  // OutageBudgetSeconds() without either.
  Clock::time_point last_progress_ ABSL_GUARDED_BY(mu_);
  double retry_seconds_ ABSL_GUARDED_BY(mu_) = kFirstQuotaRetrySeconds;
  bool job_ended_ ABSL_GUARDED_BY(mu_) = false;
  // Wakes SubmitHeld: a job ended, or the batch stops.
  std::condition_variable resubmit_wake_;
  absl::Status batch_error_ ABSL_GUARDED_BY(mu_);
  BatchCounts counts_ ABSL_GUARDED_BY(mu_);
  std::vector<std::string> failures_ ABSL_GUARDED_BY(mu_);
  BatchProgressLine progress_ ABSL_GUARDED_BY(mu_);
};

// A batch that fails before its first submit: the --json summary still
// comes (every asset counted as not submitted), then the one line.
// Nothing was submitted. A refused spec (exit 2) judged no asset: `total`
// 0. Otherwise (no server, no output directory) every asset is skipped, with
// one JSON line each as when a batch stops, then the summary.
// `reason` is the one line on stderr (and the summary's error); `why` gives
// each skipped asset's error ("CODE: not submitted: message") and error_code.
int FailBeforeSubmitting(const CliArgs& args, const BatchSpec* spec, int exit_code, const std::string& reason,
                         const absl::Status& why) {
  int total = 0;
  if (args.json && spec != nullptr && exit_code != kExitUsage) {
    for (const BatchEntry& e : spec->entries) {
      AssetOutcome o;
      o.asset = e.asset;
      o.name = e.name;
      o.out_dir = (fs::path(args.out) / e.name).string();
      o.priority = e.settings.priority;
      o.status = AssetStatus::kSkipped;
      o.error = Describe(why, "not submitted");
      o.error_code = static_cast<int>(why.code());
      PrintJson(AssetJson(o));
      ++total;
    }
  }
  if (args.json) PrintJson(SummaryJson(BatchCounts{.total = total, .skipped = total}, 0.0, exit_code, reason));
  return Fail(exit_code, reason);
}

int RunBatch(const CliArgs& args, const BatchSpec& spec) {
  std::error_code ec;
  fs::create_directories(args.out, ec);
  if (ec || !fs::is_directory(args.out)) {
    const std::string reason = absl::StrCat("cannot create output directory ", args.out, ": ",
                                            ec ? ec.message() : std::string("not a directory"));
    return FailBeforeSubmitting(args, &spec, kExitLocalIo, reason, absl::InternalError(reason));
  }
  absl::StatusOr<std::unique_ptr<sdk::Client>> client =
      sdk::Client::Connect(ClientOptionsFor(args, kBakeOutageSeconds));
  if (!client.ok()) {
    return FailBeforeSubmitting(args, &spec, kExitServer, Describe(client.status()), client.status());
  }
  BatchRunner runner(args, spec, **client);
  return runner.Run();
}

}  // namespace

// Every entry's settings judged as the server will judge them (frames,
// resolution, layout, ... in range and consistent), so that a spec with one
// bad value is refused before anything is sent rather than failing that
// asset after the others were submitted.
absl::Status CheckEntriesAsTheServerWould(const BatchSpec& spec) {
  for (size_t i = 0; i < spec.entries.size(); ++i) {
    const BatchEntry& e = spec.entries[i];
    absl::StatusOr<v1::BakeParameters> parameters = sdk::ToBakeParameters(e.settings);
    if (parameters.ok()) parameters = NormalizeParameters(*parameters);
    if (!parameters.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat("assets[", i, "] (\"", e.asset, "\"): ", parameters.status().message()));
    }
  }
  return absl::OkStatus();
}

int RunBakeBatch(const CliArgs& args) {
  absl::StatusOr<BatchSpec> spec = args.command == Command::kBakeBatch
                                       ? LoadBatchSpec(args.target, args.priority)
                                       : BatchFromModels(args.targets, BakeSettingsFromArgs(args));
  if (!spec.ok()) {
    return FailBeforeSubmitting(args, nullptr, kExitUsage, std::string(spec.status().message()), spec.status());
  }
  if (args.command == Command::kBakeBatch) {
    if (absl::Status s = CheckEntriesAsTheServerWould(*spec); !s.ok()) {
      return FailBeforeSubmitting(args, &*spec, kExitUsage, std::string(s.message()), s);
    }
  }
  return RunBatch(args, *spec);
}

}  // namespace impostor::cli
