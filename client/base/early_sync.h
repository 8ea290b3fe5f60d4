// Makes a download's finished files durable while the rest of it runs.
//
// Why: on a disk with a write cache (a VM's virtual disk, most SSDs) what a
// sync waits for is the flush of the bytes written, not the journal commit:
// measured on the CI machine's virtual disk, fsync of one new 1-byte file
// 0.6 ms, of a 6 MB file 4.5 ms, of a result's 26 MB 16 ms, and the same
// 16 ms even when sync_file_range had finished writing the bytes out 100 ms
// earlier. A fetch that syncs its files at the end (one wait per result,
// atomic_file.h's CommitAll, the cache's install) therefore waits that long
// with nothing else to do. Handed each large file as soon as it is complete
// and verified, a background thread fdatasyncs it, so the flush overlaps
// the download of the files after it and the final syncs find little left.
//
// The final syncs still run for every file: an early sync only moves the
// wait. Its failure is kept and returned by Finish, because after a failed
// fdatasync the kernel may report the next one on the same file as a
// success although the bytes are lost.
#ifndef IMPOSTOR_CLIENT_BASE_EARLY_SYNC_H_
#define IMPOSTOR_CLIENT_BASE_EARLY_SYNC_H_

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <mutex>
#include <thread>

#include "absl/status/status.h"
#include "client/base/unique_fd.h"

namespace impostor::sdk {

class EarlySync {
 public:
  // Smaller files are left to the caller's final sync: their flush costs
  // little, and each would cost a descriptor and a wake-up here.
  static constexpr int64_t kMinBytes = int64_t{1} << 20;
  // Files waiting at most; more are left to the final sync, so a batch of
  // many large files holds a bounded number of descriptors open.
  static constexpr size_t kMaxPending = 8;

  EarlySync() = default;
  // Drops what is still waiting and waits for the sync under way.
  ~EarlySync();
  EarlySync(const EarlySync&) = delete;
  EarlySync& operator=(const EarlySync&) = delete;

  // Hands over the complete file open as `fd` (not taken: a duplicate is
  // kept until its sync is done; it must hold no lock its owner means to
  // release by closing) of `size_bytes` bytes; `name` is what an error
  // names. Thread-safe. Does nothing for a small file, when kMaxPending
  // are waiting, or when no descriptor is left.
  void Add(int fd, int64_t size_bytes, const std::filesystem::path& name);

  // Waits until every file handed over is synced. The first failure,
  // naming its file (LocalIoError); OK when nothing was handed over.
  absl::Status Finish();

  // Files synced so far (tests).
  int synced() const;

 private:
  struct Pending {
    UniqueFd fd;
    std::filesystem::path name;
  };
  void Run();

  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Pending> pending_;
  bool syncing_ = false;
  bool stopping_ = false;
  int synced_ = 0;
  absl::Status first_error_;
  std::thread thread_;  // started by the first file handed over
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_BASE_EARLY_SYNC_H_
