// An in-memory copy of recently served results (cache key -> manifest), so
// that a cache hit (SubmitBake, LookupBake, GetResult) reads no database
// and takes no scheduler lock (issue 18: 10,000 hits a second).
//
// It must never serve a result the store no longer has. The scheduler
// guarantees that: every path that deletes or replaces a result row
// (eviction, an admin purge, a result found with blobs missing, a new
// result for the key) calls Erase under the scheduler's mutex, and Fill is
// only called under that same mutex right after the database read, so an
// erased entry cannot come back from a read that started before the erase.
// A store that other servers write too (a shared PostgreSQL database) gets
// no cache at all: their purges would not reach this process.
//
// Bounded: past `capacity` entries, one arbitrary entry makes room (a miss
// here only costs the database read it used to). Capacity 0 turns it off.
#ifndef IMPOSTOR_SERVER_SCHEDULER_RESULT_CACHE_H_
#define IMPOSTOR_SERVER_SCHEDULER_RESULT_CACHE_H_

#include <cstddef>
#include <memory>
#include <shared_mutex>
#include <string>
#include <unordered_map>

#include "absl/base/thread_annotations.h"
#include "impostor/v1/bake_service.pb.h"

namespace impostor {

class ResultCache {
 public:
  explicit ResultCache(size_t capacity) : capacity_(capacity) {}

  // The cached manifest for `cache_key`, or null.
  std::shared_ptr<const v1::Manifest> Find(const std::string& cache_key) const;
  // Remembers `manifest` under its cache_key (replacing any entry).
  void Fill(const v1::Manifest& manifest);
  void Erase(const std::string& cache_key);
  size_t size() const;

 private:
  const size_t capacity_;
  mutable std::shared_mutex mu_;
  std::unordered_map<std::string, std::shared_ptr<const v1::Manifest>> entries_ ABSL_GUARDED_BY(mu_);
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_SCHEDULER_RESULT_CACHE_H_
