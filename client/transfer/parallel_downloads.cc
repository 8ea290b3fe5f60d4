#include "client/transfer/parallel_downloads.h"

#include <algorithm>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

namespace impostor::sdk {

int DefaultParallelDownloads() { return std::thread::hardware_concurrency() > 2 ? 4 : 1; }

absl::Status RunParallelDownloads(size_t count, int parallel, const CancelSource* outer,
                                  const std::function<absl::Status(size_t i, const CancelSource& cancel)>& download) {
  CancelSource cancel("cancelled: another file of the result failed");
  std::optional<CancelSource::Registration> forward;
  if (outer != nullptr) forward.emplace(outer->OnCancel([&cancel] { cancel.Cancel(); }));

  std::mutex mu;  // guards next and first_failure
  size_t next = 0;
  absl::Status first_failure;
  auto run = [&] {
    while (true) {
      size_t i;
      {
        std::lock_guard lock(mu);
        if (!first_failure.ok() || next == count) return;
        i = next++;
      }
      absl::Status status = download(i, cancel);
      if (status.ok()) continue;
      {
        std::lock_guard lock(mu);
        if (!first_failure.ok()) return;  // cancelled by that failure, or a second one
        first_failure = std::move(status);
      }
      cancel.Cancel();
      return;
    }
  };
  const size_t threads = std::min(count, static_cast<size_t>(std::max(parallel, 1)));
  std::vector<std::thread> helpers;
  for (size_t t = 1; t < threads; ++t) helpers.emplace_back(run);
  run();
  for (std::thread& t : helpers) t.join();
  forward.reset();
  // Cancelled from outside, every call answers our own CANCELLED: the
  // caller's reason is the one to give.
  if (outer != nullptr && outer->cancelled() && absl::IsCancelled(first_failure)) return outer->error();
  return first_failure;
}

}  // namespace impostor::sdk
