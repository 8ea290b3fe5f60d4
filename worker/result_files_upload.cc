#include "worker/result_files_upload.h"

#include <algorithm>
#include <atomic>
#include <mutex>
#include <string>
#include <thread>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/error_reason.h"
#include "common/net/batch_read.h"
#include "common/net/blob_batches.h"
#include "common/util/log_escape.h"

namespace impostor {
namespace {

// Runs work(n) for each n in [0, count), `parallel` at a time, until one
// returns false; true when none did.
bool RunPass(size_t count, int parallel, const std::function<bool(size_t)>& work) {
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  auto worker = [&] {
    for (size_t n; !failed && (n = next.fetch_add(1)) < count;) {
      if (!work(n)) failed = true;
    }
  };
  std::vector<std::thread> threads;
  for (size_t t = 1; t < std::min<size_t>(static_cast<size_t>(std::max(parallel, 1)), count); ++t) {
    threads.emplace_back(worker);
  }
  worker();
  for (std::thread& t : threads) t.join();
  return !failed;
}

}  // namespace

absl::Status UploadResultFiles(const std::vector<ResultFile>& files, const ResultUploadLink& link, int parallel,
                               const ResultUploadOptions& options) {
  std::vector<size_t> small;
  std::vector<int64_t> small_sizes;
  std::vector<size_t> streamed;
  for (size_t i = 0; i < files.size(); ++i) {
    const int64_t size = files[i].digest.size_bytes();
    if (size >= 0 && size <= kBatchUpdateBlobMaxBytes) {
      small.push_back(i);
      small_sizes.push_back(size);
    } else {
      streamed.push_back(i);
    }
  }
  std::vector<std::vector<size_t>> batches;  // indices into files
  for (const std::vector<size_t>& batch : PackBatchesBySize(small_sizes, kMaxBatchUpdateBlobs, kMaxBatchUpdateBytes)) {
    batches.emplace_back();
    for (size_t k : batch) batches.back().push_back(small[k]);
  }

  std::vector<char> stored(files.size(), 0);     // each written by one thread only
  std::vector<std::string> refused(files.size());  // the code a batch refused the file with
  std::mutex unbatched_mu;
  std::vector<size_t> unbatched;  // files of batches an older server could not take
  auto stream = [&](size_t i) {
    const absl::Status s = link.call(
        [&](v1::AssetService::Stub& assets) { return UploadResultFile(assets, files[i].path, files[i].digest, options); });
    stored[i] = s.ok();
    return s.ok();
  };
  auto send_batch = [&](const std::vector<size_t>& batch) {
    std::vector<ResultFile> batch_files;
    for (size_t i : batch) batch_files.push_back(files[i]);
    std::vector<absl::Status> each;
    const absl::Status s = link.call(
        [&](v1::AssetService::Stub& assets) { return UploadResultBatch(assets, batch_files, &each, options); });
    if (absl::IsUnimplemented(s)) {
      std::lock_guard lock(unbatched_mu);
      unbatched.insert(unbatched.end(), batch.begin(), batch.end());
      return true;
    }
    if (!s.ok()) return false;
    size_t refusals = 0;
    size_t first = batch.size();
    for (size_t k = 0; k < batch.size(); ++k) {
      stored[batch[k]] = each[k].ok();
      if (each[k].ok()) continue;
      refused[batch[k]] = absl::StatusCodeToString(each[k].code());
      if (refusals++ == 0) first = k;
    }
    // One line a batch, however many of its blobs were refused (a full
    // store refuses them all); they go to UploadBlob next.
    if (refusals > 0) {
      spdlog::warn("event=batch_blobs_refused refused={} of={} first_file=\"{}\" code={} error=\"{}\" action=upload_blob",
                   refusals, batch.size(), EscapeUntrusted(files[batch[first]].path.filename().string()),
                   absl::StatusCodeToString(each[first].code()), EscapeUntrusted(std::string(each[first].message())));
    }
    return true;
  };
  // The batches first: each is one round trip, and the large files' streams
  // take the other threads meanwhile.
  bool ok = RunPass(batches.size() + streamed.size(), parallel, [&](size_t n) {
    return n < batches.size() ? send_batch(batches[n]) : stream(streamed[n - batches.size()]);
  });
  if (ok && !unbatched.empty()) {
    spdlog::info("event=batch_upload_unsupported files={} action=upload_blob", unbatched.size());
    std::sort(unbatched.begin(), unbatched.end());
    ok = RunPass(unbatched.size(), parallel, [&](size_t n) { return stream(unbatched[n]); });
  }
  for (size_t i = 0; i < files.size(); ++i) {
    if (stored[i]) continue;
    absl::Status s = link.upload_patiently(files[i]);
    if (s.ok() || refused[i].empty()) {
      if (!s.ok()) return s;
      continue;
    }
    // Refused twice: say which file (UploadBlob's words name the blob);
    // its reason (a store still full) stays on the status for the job's
    // retry. The batch's own words are on its log line.
    absl::Status named(s.code(), absl::StrCat("result file ", files[i].path.filename().string(), ": ", s.message(),
                                              " (refused in its batch first: ", refused[i], ")"));
    const std::string reason = ErrorReasonOf(s);
    return reason.empty() ? named : WithErrorReason(std::move(named), reason);
  }
  return absl::OkStatus();
}

}  // namespace impostor
