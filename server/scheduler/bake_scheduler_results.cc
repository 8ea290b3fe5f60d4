// Results in the store: a finished bake's manifest recorded, reads of a result checked against the
// blob store (a result whose blobs are gone is dropped, never served), use times batched before
// they are written, pins, and eviction down to the store's cap.
// (BakeScheduler is split by responsibility; bake_scheduler.h declares it.)
#include "server/scheduler/bake_scheduler.h"
#include "server/scheduler/manifest_stamp.h"

#include <openssl/rand.h>

#include <algorithm>
#include <array>
#include <climits>
#include <map>
#include <tuple>
#include <set>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/request/bake_request.h"
#include "common/error_reason.h"
#include "common/util/log_escape.h"
#include "common/request/quality_gate.h"
#include "common/util/sha256.h"
#include "common/util/utf8.h"
#include "server/store/attempt_history.h"
#include "server/store/database_full.h"
#include "server/scheduler/scheduler_internal.h"

namespace impostor {

using scheduler_internal::ToDigest;
using scheduler_internal::SystemNowMs;

void BakeScheduler::ApplyResult(JobRecord& r, const v1::Manifest& result) {
  r.job.set_state(v1::JOB_STATE_SUCCEEDED);
  r.job.set_progress(1.0f);
  if (r.job.stage() != "cached") r.job.set_stage("done");
  r.job.clear_error();
  const absl::Status gate = CheckQualityGate(r.gate, result);
  if (gate.ok()) return;
  r.job.set_state(v1::JOB_STATE_FAILED);
  r.job.set_stage("quality_gate");
  r.job.mutable_error()->set_code(static_cast<int>(gate.code()));
  r.job.mutable_error()->set_message(std::string(gate.message()));
  spdlog::info("event=quality_gate_failed job={} cache_key={} error=\"{}\"", r.job.job_id(), r.job.cache_key(),
               std::string(gate.message()));
}

void BakeScheduler::TouchResult(const std::string& key) {
  const int64_t now = SharedNowMs();
  std::lock_guard lock(touch_mu_);
  touched_[key] = now;
}

int64_t BakeScheduler::UnwrittenUse(const std::string& key) {
  std::lock_guard lock(touch_mu_);
  auto it = touched_.find(key);
  return it == touched_.end() ? 0 : it->second;
}

std::shared_ptr<const v1::Manifest> BakeScheduler::HotResult(const std::string& key) {
  std::shared_ptr<const v1::Manifest> m = hot_results_.Find(key);
  // Blobs are checked on every hit, as from the database: a blob deleted
  // or rotted on disk sends the caller to the path that drops the result.
  if (!m || !BlobsIntact(*m)) return nullptr;
  TouchResult(key);
  return m;
}

absl::Status BakeScheduler::DeleteResultLocked(const std::string& key) {
  hot_results_.Erase(key);
  return jobs_->DeleteResult(key);
}

absl::StatusOr<int64_t> BakeScheduler::FlushTouchesLocked() {
  std::map<std::string, int64_t> batch;
  {
    std::lock_guard lock(touch_mu_);
    batch.swap(touched_);
  }
  if (batch.empty()) return 0;
  // Only eviction order depends on it: a failed write (a full disk) drops
  // the batch rather than fail anything.
  if (auto s = jobs_->TouchResults(batch); !s.ok()) return s;
  return static_cast<int64_t>(batch.size());
}

absl::StatusOr<int64_t> BakeScheduler::FlushResultTouches() {
  std::lock_guard lock(mu_);
  return FlushTouchesLocked();
}

bool BakeScheduler::BlobsIntact(const v1::Manifest& m) const {
  // Verified, not just present: a result whose bytes rotted is a miss.
  bool intact = blobs_->Verify(ToDigest(m.manifest_json())).ok();
  for (const auto& map : m.maps()) intact = intact && blobs_->Verify(ToDigest(map.digest())).ok();
  return intact;
}

absl::StatusOr<std::optional<v1::Manifest>> BakeScheduler::ReadIntactResult(const std::string& key, bool* dropped) {
  if (auto hot = HotResult(key)) return std::optional<v1::Manifest>(*hot);
  std::optional<v1::Manifest> found;
  {
    // Only the database read holds the scheduler's lock: with many callers
    // hitting the cache, the blob checks run side by side.
    std::lock_guard lock(mu_);
    auto result = jobs_->GetResult(key);
    if (!result.ok() || !result->has_value()) return result;
    found = std::move(*result);
    // Under mu_, like every erase: see ResultCache. Hits from memory check
    // the blobs themselves.
    hot_results_.Fill(*found);
    TouchResult(key);
  }
  if (BlobsIntact(*found)) return found;
  std::lock_guard lock(mu_);
  return IntactResult(key, dropped);  // checks again: the result may have been baked anew meanwhile
}

absl::StatusOr<std::optional<v1::Manifest>> BakeScheduler::IntactResult(const std::string& key, bool* dropped) {
  auto result = jobs_->GetResult(key);
  if (!result.ok() || !result->has_value()) return result;
  if (BlobsIntact(**result)) {
    hot_results_.Fill(**result);
    return result;
  }
  spdlog::warn("event=cached_result_incomplete cache_key={} action=rebake", key);
  if (auto s = DeleteResultLocked(key); !s.ok()) return s;
  if (dropped != nullptr) *dropped = true;
  return std::optional<v1::Manifest>();
}

absl::StatusOr<v1::Manifest> BakeScheduler::GetResult(const std::string& cache_key) {
  if (!IsSha256Hex(cache_key)) {
    return absl::InvalidArgumentError(absl::StrCat("cache_key: expected 64 lowercase hex characters, got \"",
                                                    cache_key.substr(0, 80), "\""));
  }
  bool dropped = false;
  auto r = ReadIntactResult(cache_key, &dropped);
  if (!r.ok()) return r.status();
  if (dropped) {
    // Still NOT_FOUND (clients bake on a miss), but saying why: a key a game
    // fetched yesterday is not "never baked".
    return absl::NotFoundError(absl::StrCat("cache_key: the result baked under ", cache_key,
                                            " was damaged on the server (a file failed its digest check) and has "
                                            "been removed; submit the bake again to rebuild it"));
  }
  if (!r->has_value()) return absl::NotFoundError(absl::StrCat("cache_key: nothing baked under ", cache_key));
  return std::move(**r);
}

absl::Status BakeScheduler::PinResult(const std::string& cache_key, bool pinned) {
  if (!IsSha256Hex(cache_key)) {
    return absl::InvalidArgumentError(absl::StrCat("cache_key: expected 64 lowercase hex characters, got \"",
                                                    cache_key.substr(0, 80), "\""));
  }
  std::lock_guard lock(mu_);
  auto found = jobs_->PinResult(cache_key, pinned);
  if (!found.ok()) return found.status();
  if (!*found) return absl::NotFoundError(absl::StrCat("cache_key: nothing baked under ", cache_key));
  spdlog::info("event=pin cache_key={} pinned={}", cache_key, pinned);
  return absl::OkStatus();
}

absl::StatusOr<BakeScheduler::EvictionStats> BakeScheduler::EnforceStoreCap() {
  EvictionStats stats;
  const int64_t cap = options_.store_max_bytes;
  // Replicas on one database share the blob directory too (issue 15): the
  // others' uploads and evictions never reach this process's count, which
  // can be too low (the cap passed unseen) or too high (eviction chasing
  // bytes that are gone). The evicting replica recounts from the
  // directory: whenever its count says over, and every kSharedRecountMs.
  constexpr int64_t kSharedRecountMs = 30'000;
  const bool shared = jobs_->SharedWithOtherServers();
  const int64_t now_ms = options_.now_ms();
  if (cap <= 0 || (blobs_->total_bytes() <= cap && (!shared || now_ms < next_shared_recount_ms_.load()))) {
    return stats;
  }
  std::lock_guard lock(mu_);
  if (shared) next_shared_recount_ms_ = now_ms + kSharedRecountMs;
  // One server on a shared database evicts; the others skip.
  auto maintainer = jobs_->HoldMaintenanceLock();
  if (!maintainer.ok()) return maintainer.status();
  if (!*maintainer) return stats;
  std::vector<BlobStore::StoredBlob> stored = blobs_->List();
  if (shared && blobs_->Recount(stored) <= cap) return stats;
  // Eviction orders results by use: write the uses noted in memory first.
  if (auto s = FlushTouchesLocked(); !s.ok()) return s.status();
  // What must stay: every input of a queued or running job.
  std::set<std::string> needed;
  auto pending = jobs_->Pending();
  if (!pending.ok()) return pending.status();
  for (const JobRecord& r : *pending) {
    needed.insert(r.mesh.entry().digest().hash());
    for (const auto& f : r.mesh.files()) needed.insert(f.digest().hash());
  }
  auto results = jobs_->ResultsByLastUse();
  if (!results.ok()) return results.status();
  std::map<std::string, int> result_refs;
  auto result_blobs = [](const v1::Manifest& m) {
    std::vector<std::string> hashes = {m.manifest_json().hash()};
    for (const auto& map : m.maps()) hashes.push_back(map.digest().hash());
    return hashes;
  };
  for (const auto& r : *results) {
    for (const auto& h : result_blobs(r.manifest)) ++result_refs[h];
  }
  auto remove = [&](const std::string& hash, int64_t size) -> absl::Status {
    if (auto s = blobs_->Remove(hash); !s.ok()) return s;
    ++stats.blobs_removed;
    stats.bytes_freed += size;
    return absl::OkStatus();
  };
  // First, blobs nothing refers to (inputs of finished bakes, orphans),
  // oldest first, sparing recent uploads that may be about to be submitted.
  std::sort(stored.begin(), stored.end(), [](const auto& a, const auto& b) { return a.mtime_ns < b.mtime_ns; });
  std::map<std::string, int64_t> sizes;
  // File times are real time, whatever clock the scheduler runs on.
  const int64_t grace_ns = (SystemNowMs() - options_.eviction_grace_ms) * 1'000'000;
  for (const auto& b : stored) {
    sizes[b.hash] = b.size_bytes;
    if (blobs_->total_bytes() <= cap) break;
    if (needed.count(b.hash) || result_refs.count(b.hash) || b.mtime_ns > grace_ns) continue;
    if (auto s = remove(b.hash, b.size_bytes); !s.ok()) return s;
  }
  // Then whole results, least recently used first, never pinned ones.
  for (const auto& r : *results) {
    if (blobs_->total_bytes() <= cap) break;
    if (r.pinned) continue;
    const std::string& key = r.manifest.cache_key();
    if (auto s = DeleteResultLocked(key); !s.ok()) return s;
    ++stats.results_removed;
    for (const auto& h : result_blobs(r.manifest)) {
      if (--result_refs[h] > 0 || needed.count(h)) continue;
      if (auto s = remove(h, sizes.count(h) ? sizes[h] : 0); !s.ok()) return s;
    }
    spdlog::info("event=evict_result cache_key={}", key);
  }
  if (stats.blobs_removed > 0 || stats.results_removed > 0) {
    observer_.load()->OnEvicted(stats.blobs_removed, stats.results_removed, stats.bytes_freed);
  }
  if (stats.blobs_removed > 0) {
    spdlog::info("event=store_evicted blobs={} results={} bytes={} store_bytes={} cap={}", stats.blobs_removed,
                 stats.results_removed, stats.bytes_freed, blobs_->total_bytes(), cap);
  }
  return stats;
}

absl::StatusOr<bool> BakeScheduler::IsResultBlob(const std::string& hash) {
  std::lock_guard lock(mu_);
  return jobs_->IsResultBlob(hash);
}

}  // namespace impostor
