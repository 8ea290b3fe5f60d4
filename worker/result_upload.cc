#include "worker/result_upload.h"

#include <algorithm>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "common/error_reason.h"
#include "worker/worker_rpc.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;

// The most bytes a link may hold unseen once the last message was handed
// over (send buffers): the answer is awaited once per message of them.
constexpr int64_t kMaxBytesTheLinkHolds = int64_t{4} << 20;

// Cancels a call when it makes no progress for its limit: the stall
// watchdog of a stream without an overall deadline. Progress() and
// set_limit() from the call's thread; the watch runs on a thread of its own,
// joined by the destructor.
class StallWatchdog {
 public:
  StallWatchdog(grpc::ClientContext* context, Clock::duration limit)
      : context_(context), limit_(limit), last_(Clock::now()), thread_([this] { Watch(); }) {}
  ~StallWatchdog() {
    {
      std::lock_guard lock(mu_);
      done_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }

  void Progress() {
    std::lock_guard lock(mu_);
    last_ = Clock::now();
  }
  void set_limit(Clock::duration limit) {
    std::lock_guard lock(mu_);
    limit_ = limit;
    last_ = Clock::now();
  }
  bool stalled() {
    std::lock_guard lock(mu_);
    return stalled_;
  }
  Clock::duration limit() {
    std::lock_guard lock(mu_);
    return limit_;
  }

 private:
  void Watch() {
    std::unique_lock lock(mu_);
    while (!done_) {
      const Clock::time_point deadline = last_ + limit_;
      if (Clock::now() >= deadline) {
        stalled_ = true;
        context_->TryCancel();
        return;
      }
      changed_.wait_until(lock, deadline);
    }
  }

  grpc::ClientContext* const context_;
  std::mutex mu_;
  std::condition_variable changed_;
  Clock::duration limit_;
  Clock::time_point last_;
  bool done_ = false;
  bool stalled_ = false;
  std::thread thread_;  // last: starts once the rest is set
};

absl::Status FromGrpc(const grpc::Status& s, std::string_view rpc) {
  if (s.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(s.error_code()),
                      absl::StrCat(std::string(rpc), ": ", s.error_message()));
}

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// Where the stream starts: what the server kept, 0 when nothing (or when it
// cannot say), -1 when it has the whole blob.
int64_t ResumeOffset(v1::AssetService::Stub& assets, const v1::Digest& digest, const ResultUploadOptions& options) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + options.query_timeout);
  const UploadCancel::Call registered(options.cancel, &ctx);
  v1::QueryUploadRequest request;
  *request.mutable_digest() = digest;
  v1::QueryUploadResponse response;
  if (!assets.QueryUpload(&ctx, request, &response).ok()) return 0;
  if (response.complete()) return -1;
  const int64_t kept = response.committed_bytes();
  return kept > 0 && kept < digest.size_bytes() ? kept : 0;
}

// One stream from the blob's byte `offset`.
absl::Status UploadFrom(v1::AssetService::Stub& assets, const std::filesystem::path& path, const v1::Digest& digest,
                        int64_t offset, const ResultUploadOptions& options, int64_t* bytes_sent) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InternalError(absl::StrCat("cannot open ", path.string()));
  if (offset > 0 && !in.seekg(offset)) {
    return absl::InternalError(absl::StrCat("cannot seek to byte ", offset, " of ", path.string()));
  }
  grpc::ClientContext ctx;  // no deadline: the watchdog bounds each step
  const UploadCancel::Call registered(options.cancel, &ctx);
  v1::UploadBlobResponse response;
  StallWatchdog watchdog(&ctx, options.stall_limit);
  auto writer = assets.UploadBlob(&ctx, &response);
  v1::UploadBlobRequest chunk;
  *chunk.mutable_digest() = digest;
  chunk.set_offset(offset);
  std::string buf(std::max<size_t>(options.chunk_bytes, 1), '\0');
  int64_t sent = 0;
  int64_t largest = 1;
  bool first = true;
  bool all_sent = false;
  while (true) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    if (in.bad()) {
      ctx.TryCancel();
      writer->Finish();
      return absl::InternalError(absl::StrCat("read error on ", path.string()));
    }
    const size_t n = static_cast<size_t>(in.gcount());
    if (n == 0 && !first) {
      all_sent = true;
      break;
    }
    chunk.set_data(buf.data(), n);
    if (!writer->Write(chunk)) break;  // the stream ended: Finish says why
    watchdog.Progress();
    sent += static_cast<int64_t>(n);
    largest = std::max<int64_t>(largest, static_cast<int64_t>(n));
    if (bytes_sent != nullptr) *bytes_sent += static_cast<int64_t>(n);
    chunk.clear_digest();
    chunk.clear_offset();
    first = false;
    if (n < buf.size()) {
      all_sent = true;
      break;
    }
  }
  if (all_sent) {
    // The server answers once it has every byte: what the link still holds
    // crosses unseen, each message of it given the time any message gets.
    const int64_t held = (std::min(sent, kMaxBytesTheLinkHolds) + largest - 1) / largest;
    watchdog.set_limit(options.stall_limit * (1 + held));
    writer->WritesDone();
  }
  absl::Status finished = FromGrpc(writer->Finish(), "UploadBlob");
  if (watchdog.stalled()) {
    return absl::DeadlineExceededError(absl::StrCat(
        "UploadBlob: the link stalled: ",
        all_sent ? absl::StrCat("no answer for ", Seconds(watchdog.limit()), " s after all ", sent, " bytes were sent")
                 : absl::StrCat("it took nothing for ", Seconds(options.stall_limit), " s, with ", offset + sent,
                                " of the blob's ", digest.size_bytes(), " bytes sent")));
  }
  // The server's reason for a refusal (a full store) rides as trailing
  // metadata; kept on the status so the caller can tell it from the
  // blob's own fault.
  if (const std::string reason = worker_rpc::ServerErrorReason(ctx); !finished.ok() && !reason.empty()) {
    finished = WithErrorReason(std::move(finished), reason);
  }
  return finished;
}

}  // namespace

absl::Status UploadResultFile(v1::AssetService::Stub& assets, const std::filesystem::path& path,
                              const v1::Digest& digest, const ResultUploadOptions& options, int64_t* bytes_sent) {
  const bool ask = digest.size_bytes() > static_cast<int64_t>(options.chunk_bytes);
  for (int moved = 0;; ++moved) {
    const int64_t offset = ask ? ResumeOffset(assets, digest, options) : 0;
    if (offset < 0) return absl::OkStatus();  // the store has it
    absl::Status status = UploadFrom(assets, path, digest, offset, options, bytes_sent);
    // The kept partial is not where the question said (another stream of
    // the blob moved it, or it expired): ask again, a few times.
    if (status.code() != absl::StatusCode::kFailedPrecondition || offset == 0 || moved >= 3) return status;
  }
}

}  // namespace impostor
