// BakeScheduler::PurgeResultsBakedBy: the admin's answer to a compromised
// worker (issue 14). Runs under the scheduler's mutex, like eviction, so no
// result can be completed or read from the job table half-way through.
#include <sys/stat.h>

#include <chrono>
#include <map>
#include <set>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "server/scheduler/bake_scheduler.h"
#include "server/store/token_store.h"

namespace impostor {

absl::StatusOr<BakeScheduler::PurgeStats> BakeScheduler::PurgeResultsBakedBy(const std::string& worker) {
  if (auto s = ValidateTokenName(worker); !s.ok()) {
    // ValidateTokenName names --name; here the field is `worker`.
    return absl::InvalidArgumentError(
        absl::StrCat("worker", std::string(s.message()).substr(std::string("--name").size())));
  }
  PurgeStats stats;
  std::lock_guard lock(mu_);
  auto results = jobs_->ResultsByLastUse();
  if (!results.ok()) return results.status();
  auto pending = jobs_->Pending();
  if (!pending.ok()) return pending.status();
  std::set<std::string> needed;
  for (const JobRecord& r : *pending) {
    needed.insert(r.mesh.entry().digest().hash());
    for (const auto& f : r.mesh.files()) needed.insert(f.digest().hash());
  }
  // Blobs the surviving results list, and the digests of the purged ones.
  std::set<std::string> kept_refs;
  std::map<std::string, v1::Digest> purged_blobs;
  for (const auto& r : *results) {
    const v1::Manifest& m = r.manifest;
    const bool purge = m.baked_by() == worker;
    auto note = [&](const v1::Digest& d) {
      if (purge) {
        purged_blobs.emplace(d.hash(), d);
      } else {
        kept_refs.insert(d.hash());
      }
    };
    note(m.manifest_json());
    for (const auto& map : m.maps()) note(map.digest());
    if (!purge) continue;
    if (auto s = DeleteResultLocked(m.cache_key()); !s.ok()) return s;
    stats.cache_keys.push_back(m.cache_key());
  }
  // File times are real time, whatever clock the scheduler runs on.
  const int64_t now_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count();
  const int64_t grace_ns = now_ns - options_.eviction_grace_ms * 1'000'000;
  for (const auto& [hash, digest] : purged_blobs) {
    if (kept_refs.count(hash) || needed.count(hash)) {
      ++stats.blobs_kept;
      continue;
    }
    struct stat st {};
    if (::stat(blobs_->PathFor({digest.hash(), digest.size_bytes()}).c_str(), &st) != 0) continue;  // already gone
    const int64_t mtime_ns = int64_t{st.st_mtim.tv_sec} * 1'000'000'000 + st.st_mtim.tv_nsec;
    if (mtime_ns > grace_ns) {
      ++stats.blobs_kept;
      continue;
    }
    if (auto s = blobs_->Remove(hash); !s.ok()) return s;
    ++stats.blobs_removed;
    stats.bytes_freed += st.st_size;
  }
  spdlog::info("event=purge_worker_results worker=\"{}\" results={} blobs_removed={} bytes_freed={} blobs_kept={}",
               worker, stats.cache_keys.size(), stats.blobs_removed, stats.bytes_freed, stats.blobs_kept);
  return stats;
}

}  // namespace impostor
