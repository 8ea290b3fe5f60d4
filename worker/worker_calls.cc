// The worker's link to the farm: calls through the failover channel, riding
// out outages (--max-outage-seconds) and a server whose disk is full,
// input downloads and result uploads, and handing a lease back. The job
// itself is run by WorkerLoop::ProcessJob (worker_loop.cc).
#include "worker/worker_loop.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <span>
#include <utility>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/request/bake_request.h"
#include "common/net/connect_error.h"
#include "common/error_reason.h"
#include "common/net/keepalive.h"
#include "common/util/log_escape.h"
#include "common/net/server_list.h"
#include "common/util/sha256.h"
#include "common/net/tls_files.h"
#include "common/net/tls_peer_check.h"
#include "worker/bake/atlas_bake.h"
#include "worker/bake/bake_outputs.h"
#include "worker/bake_memory_check.h"
#include "worker/bearer_token.h"
#include "worker/input_links.h"
#include "worker/input_plan.h"
#include "worker/result_files_upload.h"
#include "worker/result_upload.h"
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
using worker_rpc::ContextWithDeadline;
using worker_rpc::IsServerFull;
using worker_rpc::ServerErrorReason;

namespace {

using Clock = std::chrono::steady_clock;

absl::Status FromGrpc(const grpc::Status& s, std::string_view rpc) {
  if (s.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(s.error_code()),
                      absl::StrCat(std::string(rpc), ": ", s.error_message()));
}

// An input blob arriving in pieces: the bytes go to `out` and through
// `hash`, so a ReadBlob cut off midway (a server restart) resumes at
// `received` instead of from zero.
struct InputSink {
  ScratchFile out;
  Sha256 hash;
  int64_t received = 0;
};

// One ReadBlob of `digest` from sink.received on. A write that fails (a
// full scratch) ends the call at once with the write's error, which is no
// UNAVAILABLE: RetryThroughOutage must not wait for a disk.
absl::Status ReadBlobInto(v1::AssetService::Stub& assets, const v1::Digest& digest, InputSink& sink) {
  v1::ReadBlobRequest request;
  *request.mutable_digest() = digest;
  request.set_offset(sink.received);
  auto ctx = ContextWithDeadline(std::chrono::seconds(600));
  auto reader = assets.ReadBlob(ctx.get(), request);
  v1::ReadBlobResponse chunk;
  auto stop = [&](absl::Status why) {
    ctx->TryCancel();
    reader->Finish();
    return why;
  };
  while (reader->Read(&chunk)) {
    if (chunk.offset() != sink.received) {
      return stop(absl::DataLossError(absl::StrCat("ReadBlob: blob ", digest.hash(), " sent offset ", chunk.offset(),
                                                   ", expected ", sink.received)));
    }
    // The scratch check counted size_bytes: no more may land on disk.
    if (static_cast<int64_t>(chunk.data().size()) > digest.size_bytes() - sink.received) {
      return stop(absl::DataLossError(
          absl::StrCat("ReadBlob: blob ", digest.hash(), " sent more than its ", digest.size_bytes(), " bytes")));
    }
    if (absl::Status written = sink.out.Append(chunk.data()); !written.ok()) return stop(written);
    sink.hash.Update(chunk.data());
    sink.received += static_cast<int64_t>(chunk.data().size());
  }
  return FromGrpc(reader->Finish(), "ReadBlob");
}

absl::Status FinishInput(const v1::Digest& digest, InputSink& sink) {
  if (absl::Status closed = sink.out.Close(); !closed.ok()) return closed;
  if (sink.received != digest.size_bytes() || sink.hash.FinishHex() != digest.hash()) {
    return absl::DataLossError(absl::StrCat("ReadBlob: blob ", digest.hash(), " arrived corrupt"));
  }
  return absl::OkStatus();
}

// A result file's upload: resumes what an earlier try left on the server,
// no deadline on the stream, only the stall watchdog (result_upload.h).
absl::Status UploadFile(v1::AssetService::Stub& assets, const fs::path& path, const v1::Digest& digest) {
  return UploadResultFile(assets, path, digest);
}

// "database_full" or "store_full", the log event of a wait for that reason.
std::string FullEvent(std::string_view reason) {
  return reason == error_reason::kStoreFull ? "store_full" : "database_full";
}

// A call that timed out or found no server: an outage to ride out within
// --max-outage-seconds. A deadline passing on a short unary call means the
// server is up but cannot answer now (its database is away), and moving
// through every replica does not change that.
bool IsOutage(grpc::StatusCode code) {
  return code == grpc::StatusCode::UNAVAILABLE || code == grpc::StatusCode::DEADLINE_EXCEEDED;
}

}  // namespace

grpc::Status WorkerLoop::CallServer(const ChannelCall& call, bool* try_next_now) {
  const FailoverChannel::Route route = channels_->Current();
  const grpc::Status s = call(route.channel);
  const bool next_now = channels_->NoteFailure(route, s.error_code());
  if (try_next_now != nullptr) *try_next_now = next_now;
  switch (s.error_code()) {
    case grpc::StatusCode::UNAVAILABLE:
    case grpc::StatusCode::DEADLINE_EXCEEDED:
    case grpc::StatusCode::CANCELLED: break;
    default: channels_->NoteAnswer(route); break;
  }
  return s;
}

std::string WorkerLoop::ExplainUnreachable(const std::string& grpc_message) const {
  const std::string target = channels_->target(channels_->Current().index);
  const auto diagnose_certificate = [this, &target] {
    absl::StatusOr<std::string> ca = ReadCertificateFile("--tls-ca", options_.tls_ca_file);
    return ca.ok() ? DiagnoseServerCertificate(target, *ca, options_.tls_server_name, 2.0) : std::string();
  };
  return ExplainConnectError(grpc_message, !options_.tls_ca_file.empty(), diagnose_certificate).sentence;
}

grpc::Status WorkerLoop::RetryThroughOutage(std::string_view rpc, const ChannelCall& call) {
  const auto outage_end = Clock::now() + std::chrono::seconds(options_.max_outage_seconds);
  // A draining worker does not wait out a long outage: past its drain
  // deadline (and a moment for the last call) the lease expires by itself.
  auto give_up = [&] {
    std::lock_guard lock(job_mu_);
    return drain_deadline_ ? std::min(outage_end, *drain_deadline_ + std::chrono::seconds(1)) : outage_end;
  };
  const auto start = Clock::now();
  auto backoff = std::chrono::milliseconds(200);
  while (true) {
    bool try_next_now = false;
    const grpc::Status s = CallServer(call, &try_next_now);
    if (!IsOutage(s.error_code()) && !try_next_now) return s;
    const double down_s = std::chrono::duration<double>(Clock::now() - start).count();
    if (Clock::now() >= give_up()) {
      if (!IsOutage(s.error_code())) return s;
      // Say that the budget ran out, not only the last call's error.
      return grpc::Status(s.error_code(), absl::StrCat(s.error_message(), " (", std::string(rpc), " found no server ",
                                                       "able to answer for ", static_cast<int64_t>(down_s),
                                                       " s; --max-outage-seconds ", options_.max_outage_seconds,
                                                       " or the drain deadline ran out)"));
    }
    spdlog::warn("event=rpc_retry rpc={} code={} error=\"{}\" down_s={:.1f} max_outage_s={} retry_ms={}",
                 std::string(rpc), static_cast<int>(s.error_code()), EscapeUntrusted(s.error_message()), down_s,
                 options_.max_outage_seconds, try_next_now ? 0 : backoff.count());
    if (try_next_now) continue;  // another replica, at once
    channels_->Current().channel->WaitForConnected(std::chrono::system_clock::now() + backoff);
    backoff = std::min(backoff * 2, std::chrono::milliseconds(5000));
  }
}

absl::Status WorkerLoop::DownloadThroughOutage(const v1::Digest& digest, const fs::path& path) {
  // The lease survives a server restart, so the inputs are worth waiting
  // for: the download resumes where it was cut off, within the outage budget.
  InputSink sink;
  if (absl::Status s = sink.out.Create(path); !s.ok()) return s;
  absl::Status outcome;
  RetryThroughOutage("ReadBlob", [&](const std::shared_ptr<grpc::Channel>& channel) {
    v1::AssetService::Stub assets(channel);
    outcome = ReadBlobInto(assets, digest, sink);
    return grpc::Status(static_cast<grpc::StatusCode>(outcome.code()), std::string(outcome.message()));
  });
  if (!outcome.ok()) return outcome;
  return FinishInput(digest, sink);
}

absl::Status WorkerLoop::UploadThroughOutage(const fs::path& path, const v1::Digest& digest,
                                             const std::string& subject) {
  // A finished bake is worth keeping through a server restart: the lease
  // survives it, so the upload and CompleteJob can go through afterwards.
  // A full blob store is waited out the same way (the heartbeats keep the
  // lease): failing the job for it lost every running and queued bake of
  // a farm whose disk filled for 25 s.
  absl::Status outcome;
  std::string stayed_full;
  const grpc::Status s = RetryThroughFullServer(
      "UploadBlob", absl::StrCat(subject, " file=", path.filename().string()),
      [&](const std::shared_ptr<grpc::Channel>& channel, std::string* refusal) {
        v1::AssetService::Stub assets(channel);
        outcome = UploadFile(assets, path, digest);
        *refusal = ErrorReasonOf(outcome);
        return grpc::Status(static_cast<grpc::StatusCode>(outcome.code()), std::string(outcome.message()));
      },
      &stayed_full);
  // Retryable: the result is not at fault; another attempt may find space.
  // The reason goes with it to FailJob, so the server does not count the
  // store's state against this worker.
  if (!stayed_full.empty()) return WithErrorReason(absl::UnavailableError(s.error_message()), stayed_full);
  return outcome;
}

absl::Status WorkerLoop::CallAssets(const std::function<absl::Status(v1::AssetService::Stub&)>& rpc) {
  absl::Status outcome;
  CallServer([&](const std::shared_ptr<grpc::Channel>& channel) {
    v1::AssetService::Stub assets(channel);
    outcome = rpc(assets);
    return grpc::Status(static_cast<grpc::StatusCode>(outcome.code()), std::string(outcome.message()));
  });
  return outcome;
}

absl::Status WorkerLoop::UploadAll(const std::vector<std::pair<fs::path, v1::Digest>>& files,
                                   const std::string& subject) {
  std::vector<ResultFile> result_files;
  for (const auto& [path, digest] : files) result_files.push_back({path, digest});
  ResultUploadLink link;
  link.call = [this](const std::function<absl::Status(v1::AssetService::Stub&)>& rpc) { return CallAssets(rpc); };
  link.upload_patiently = [&](const ResultFile& file) { return UploadThroughOutage(file.path, file.digest, subject); };
  return UploadResultFiles(result_files, link, kParallelUploads);
}

grpc::Status WorkerLoop::RetryThroughFullServer(std::string_view rpc, const std::string& subject,
                                                const ReasonedCall& call, std::string* stayed_full) {
  // A finished bake (or the word that it failed) is worth waiting for as
  // through a server restart: the server recorded nothing, and takes the
  // same call once space is freed. Failing the job for it threw good bakes
  // away, or baked them again after their lease ran out.
  if (stayed_full != nullptr) stayed_full->clear();
  const auto start = Clock::now();
  const auto give_up = [&] {
    const auto outage_end = start + std::chrono::seconds(options_.max_outage_seconds);
    std::lock_guard lock(job_mu_);
    return drain_deadline_ ? std::min(outage_end, *drain_deadline_) : outage_end;
  };
  auto backoff = std::chrono::milliseconds(500);
  std::string waiting_for;  // the reason waited out; "" when not waiting
  while (true) {
    std::string reason;
    const grpc::Status s = RetryThroughOutage(rpc, [&](const std::shared_ptr<grpc::Channel>& channel) {
      reason.clear();
      return call(channel, &reason);
    });
    const double waited_s = std::chrono::duration<double>(Clock::now() - start).count();
    if (!IsServerFull(s, reason)) {
      if (!waiting_for.empty()) {
        spdlog::info("event={}_end rpc={} {} waited_s={:.1f} ok={}", FullEvent(waiting_for), std::string(rpc),
                     subject, waited_s, s.ok());
      }
      return s;
    }
    if (Clock::now() >= give_up()) {
      spdlog::warn("event={}_end rpc={} {} waited_s={:.1f} ok=false action=give_up", FullEvent(reason),
                   std::string(rpc), subject, waited_s);
      if (stayed_full != nullptr) *stayed_full = reason;
      return grpc::Status(
          grpc::StatusCode::UNAVAILABLE,
          absl::StrCat("the server's ", reason == error_reason::kStoreFull ? "blob store" : "job database",
                       " stayed full for ", static_cast<int64_t>(waited_s), " s (--max-outage-seconds ",
                       options_.max_outage_seconds, " or the drain deadline): ",
                       s.error_message().rfind(rpc, 0) == 0 ? "" : absl::StrCat(std::string(rpc), ": "), s.error_message()));
    }
    if (waiting_for.empty()) {
      spdlog::warn("event={} rpc={} {} action=wait max_wait_s={} error=\"{}\"", FullEvent(reason),
                   std::string(rpc), subject, options_.max_outage_seconds, EscapeUntrusted(s.error_message()));
    }
    waiting_for = reason;
    {
      std::unique_lock lock(job_mu_);
      job_wake_.wait_for(lock, backoff, [&]() ABSL_EXCLUSIVE_LOCKS_REQUIRED(job_mu_) { return DrainDue(); });
    }
    backoff = std::min(backoff * 2, std::chrono::milliseconds(5000));
  }
}

void WorkerLoop::ReleaseLease(const v1::LeasedJob& job, const std::string& reason) {
  v1::ReleaseJobRequest r;
  r.set_job_id(job.job_id());
  r.set_lease_id(job.lease_id());
  r.set_reason(reason);
  const grpc::Status s = RetryThroughFullServer(
      "ReleaseJob", "job=" + job.job_id(), [&](const std::shared_ptr<grpc::Channel>& channel, std::string* refusal) {
        v1::ReleaseJobResponse resp;
        auto ctx = ContextWithDeadline(std::chrono::seconds(10));
        const grpc::Status released = v1::WorkerService::Stub(channel).ReleaseJob(ctx.get(), r, &resp);
        *refusal = ServerErrorReason(*ctx);
        return released;
      });
  spdlog::info("event=job_released job={} reason=\"{}\" ok={}{}", job.job_id(), reason, s.ok(),
               s.ok() ? "" : absl::StrCat(" error=\"", s.error_message(), "\""));
}

}  // namespace impostor
