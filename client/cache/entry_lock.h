// Advisory locks (flock) on an entry's `.entry` file that keep an in-use
// result from being evicted, also by another process sharing the cache
// directory: every holder of a CachedResult holds a shared lock (through one
// EntryPin per entry and process); eviction takes the exclusive lock without
// waiting and skips the entry when it cannot.
//
// Not thread-safe per object; distinct objects may be used concurrently.
#ifndef IMPOSTOR_CLIENT_CACHE_ENTRY_LOCK_H_
#define IMPOSTOR_CLIENT_CACHE_ENTRY_LOCK_H_

#include <filesystem>
#include <memory>

#include "absl/status/statusor.h"

namespace impostor::sdk {

class EntryLock {
 public:
  // A shared lock on dir/.entry, after checking that the file locked is
  // still the one under `dir` (an evictor may have moved the entry away
  // between open and lock). NOT_FOUND when the entry is gone.
  static absl::StatusOr<std::unique_ptr<EntryLock>> Shared(const std::filesystem::path& dir);
  // The exclusive lock if no one holds any lock on dir/.entry, else nullptr
  // (also when the entry is gone).
  static std::unique_ptr<EntryLock> TryExclusive(const std::filesystem::path& dir);

  ~EntryLock();
  EntryLock(const EntryLock&) = delete;
  EntryLock& operator=(const EntryLock&) = delete;

 private:
  explicit EntryLock(int fd) : fd_(fd) {}
  int fd_;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_ENTRY_LOCK_H_
