// impostor bake-batch SPEC (and impostor bake A B ...): many bakes from one
// command. One FindMissingBlobs and the uploads for the whole batch
// (Client::SubmitBakeBatch), then a bounded pool of WatchJob streams follows
// the submitted jobs, highest priority first then in SPEC order (the order
// the server leases one client's jobs in), and downloads each result into
// DIR/<name>/ as soon as it finishes. Cached results need no stream: a
// watcher downloads them at once.
//
// Threads: the calling thread submits; kWatchStreams watcher threads follow
// and download. Everything shared lives in BatchRunner under `mu_`, and every
// line of output is written under it, so JSON lines never interleave.
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
#include "client/job_convert.h"
#include "common/bake_request.h"
#include "impostor/client.h"

namespace impostor::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// WatchJob streams open at once. Enough to follow every job a farm of a few
// dozen workers runs for one client; each stream is one thread here and one
// cheap wait on the server.
constexpr size_t kWatchStreams = 8;


// A model's manifest.json "quality" block, or null.
nlohmann::json QualityOf(const fs::path& manifest) {
  std::ifstream in(manifest);
  nlohmann::json j = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && j.contains("quality") && j["quality"].is_object()) return j["quality"];
  return nullptr;
}

std::string CodeAndMessage(int code, const std::string& message) {
  return absl::StrCat(absl::StatusCodeToString(static_cast<absl::StatusCode>(code)), ": ", message);
}

// An RPC that failed for want of a working connection, as opposed to the
// server judging this one request.
bool IsConnectionError(const absl::Status& s) {
  if (!sdk::GetRpcErrorInfo(s).has_value()) return false;
  switch (s.code()) {
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kResourceExhausted:
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kOutOfRange: return false;
    default: return true;
  }
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
      std::lock_guard lock(mu_);
      if (!submitted.ok()) {
        // Nothing was submitted: the uploads failed.
        batch_error_ = submitted.status();
        for (size_t i = 0; i < items_.size(); ++i) {
          Finish(i, Failed(i, absl::StrCat("not submitted: ", Describe(submitted.status()))), AssetStatus::kSkipped);
        }
      } else {
        for (size_t i = 0; i < items_.size(); ++i) {
          if ((*submitted)[i].status.code() == absl::StatusCode::kCancelled && items_[i].phase == Phase::kPending) {
            Finish(i, Failed(i, "not submitted: the batch stopped after a failure (use --keep-going to bake the rest)"),
                   AssetStatus::kSkipped);
          }
        }
      }
      submitting_done_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : watchers) t.join();
    return Report();
  }

 private:
  enum class Phase { kPending, kQueued, kRunning, kFinished };
  struct Item {
    Phase phase = Phase::kPending;
    sdk::SubmitResult submitted;
    Clock::time_point submit_time;
  };

  bool OnSubmitted(size_t i, const sdk::BatchSubmission& s) {
    std::lock_guard lock(mu_);
    Item& item = items_[i];
    item.submit_time = Clock::now();
    if (!s.status.ok()) {
      if (IsConnectionError(s.status)) connection_failed_ = true;
      Finish(i, Failed(i, Describe(s.status), static_cast<int>(s.status.code())), AssetStatus::kFailed);
      return !stop_;
    }
    item.submitted = s.result;
    // A cached result that failed this request's quality gate is a failure
    // known now: without --keep-going nothing more is submitted (its
    // watcher still records it and fetches the result for inspection).
    if (s.result.error_code != 0 && !args_.keep_going) stop_ = true;
    SetPhase(i, Phase::kQueued);
    queue_.insert({-spec_.entries[i].settings.priority, i});
    wake_.notify_one();
    Redraw();
    return !stop_;
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
        if (IsConnectionError(done.status())) connection_failed_ = true;
        Finish(i, Failed(i, Describe(done.status()), static_cast<int>(done.status().code())), AssetStatus::kFailed);
        return;
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
        if (IsConnectionError(fetched.status())) connection_failed_ = true;
        AssetOutcome failed = Failed(i, absl::StrCat("download failed: ", Describe(fetched.status())),
                                     static_cast<int>(fetched.status().code()));
        failed.cached = cached;  // the bake was a hit; only its download failed
        Finish(i, std::move(failed), AssetStatus::kFailed);
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

  AssetOutcome Failed(size_t i, const std::string& error, int code = 0) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    AssetOutcome o = Base(i);
    o.error = error;
    o.error_code = code;
    return o;
  }

  void SetPhase(size_t i, Phase phase) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    Phase& p = items_[i].phase;
    if (p == phase || p == Phase::kFinished) return;
    if (p == Phase::kQueued) --counts_.queued;
    if (p == Phase::kRunning) --counts_.running;
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
        if (!args_.keep_going) stop_ = true;
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
  bool connection_failed_ ABSL_GUARDED_BY(mu_) = false;
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
int FailBeforeSubmitting(const CliArgs& args, const BatchSpec* spec, int exit_code, const std::string& reason) {
  int total = 0;
  if (args.json && spec != nullptr && exit_code != kExitUsage) {
    for (const BatchEntry& e : spec->entries) {
      AssetOutcome o;
      o.asset = e.asset;
      o.name = e.name;
      o.out_dir = (fs::path(args.out) / e.name).string();
      o.priority = e.settings.priority;
      o.status = AssetStatus::kSkipped;
      o.error = absl::StrCat("not submitted: ", reason);
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
    return FailBeforeSubmitting(args, &spec, kExitLocalIo,
                                absl::StrCat("cannot create output directory ", args.out, ": ",
                                             ec ? ec.message() : std::string("not a directory")));
  }
  absl::StatusOr<std::unique_ptr<sdk::Client>> client =
      sdk::Client::Connect(ClientOptionsFor(args, kBakeOutageSeconds));
  if (!client.ok()) return FailBeforeSubmitting(args, &spec, kExitServer, Describe(client.status()));
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
  if (!spec.ok()) return FailBeforeSubmitting(args, nullptr, kExitUsage, std::string(spec.status().message()));
  if (args.command == Command::kBakeBatch) {
    if (absl::Status s = CheckEntriesAsTheServerWould(*spec); !s.ok()) {
      return FailBeforeSubmitting(args, &*spec, kExitUsage, std::string(s.message()));
    }
  }
  return RunBatch(args, *spec);
}

}  // namespace impostor::cli
