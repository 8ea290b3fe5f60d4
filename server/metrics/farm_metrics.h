// The farm's Prometheus metrics. Event counters and histograms are fed by the
// scheduler (FarmMetrics is its SchedulerObserver) and by the gRPC
// interceptor (rpc_metrics_interceptor.h); gauges (jobs by state, workers by
// state, store bytes) are read from the scheduler and the blob store at each
// scrape, so they are never a second copy of the farm's state.
//
// Label values are bounded: products and stages are enums, RPC methods are
// the registered ones ("other" beyond them), status codes are gRPC's 17,
// and worker ids, which workers choose, are capped at kMaxWorkerLabels
// distinct values (later ones are counted under worker="_other"). Pools
// and teams are the operator's (--pools, --pool-shares: at most 16 pools of
// 16 shares). No job id, cache key or client id a request sends is ever a
// label.
//
// Thread-safety: every method may be called from any thread.
#ifndef IMPOSTOR_SERVER_METRICS_FARM_METRICS_H_
#define IMPOSTOR_SERVER_METRICS_FARM_METRICS_H_

#include <mutex>
#include <set>
#include <string>

#include "absl/base/thread_annotations.h"
#include "server/scheduler/bake_scheduler.h"
#include "server/blobs/blob_store.h"
#include "server/metrics/prometheus_text.h"
#include "server/scheduler/scheduler_observer.h"

namespace impostor {

// "atlas", "surfels", "cards", "lod_chain" (unspecified counts as atlas).
std::string ProductLabel(v1::Product product);

class FarmMetrics final : public SchedulerObserver {
 public:
  static constexpr size_t kMaxWorkerLabels = 256;

  // `scheduler` and `blobs` are read at each Scrape; both must outlive this.
  FarmMetrics(BakeScheduler* scheduler, const BlobStore* blobs);

  // The exposition text (Content-Type text/plain; version=0.0.4). The
  // gauges are refreshed from the scheduler first; when the job database
  // cannot be read, impostor_scrape_errors_total counts it and the job
  // gauges are left out.
  std::string Scrape();

  // One finished RPC: `method` the full gRPC path
  // ("/impostor.v1.BakeService/SubmitBake"), `code` its grpc::StatusCode.
  void OnRpc(const std::string& method, int code);

  // The served TLS certificate's expiry, Unix seconds (TlsFileMonitor).
  void SetTlsCertExpiry(int64_t not_after) { tls_cert_expiry_.Set({}, static_cast<double>(not_after)); }

  // SchedulerObserver.
  void OnSubmit(v1::Product product, SubmitOutcome outcome) override;
  void OnLease(const std::string& worker_id, v1::Product product, uint32_t attempt, double queued_seconds) override;
  void OnComplete(const std::string& worker_id, const v1::Manifest& result) override;
  void OnFail(const std::string& worker_id, v1::Product product, bool will_retry) override;
  void OnLeaseLost(const std::string& worker_id, v1::Product product) override;
  void OnEvicted(int64_t blobs, int64_t results, int64_t bytes) override;

  // Totals for the dashboard's summary (same numbers as /metrics).
  struct Totals {
    double cache_hits = 0;
    double cache_misses = 0;
    double jobs_completed = 0;
    double jobs_failed = 0;
  };
  Totals totals() const;
  // Jobs done and failed by one worker (its label; see kMaxWorkerLabels).
  std::pair<double, double> WorkerTotals(const std::string& worker_id) const;

 private:
  std::string WorkerLabel(const std::string& worker_id);
  std::string WorkerLabelIfKnown(const std::string& worker_id) const;

  BakeScheduler* const scheduler_;
  const BlobStore* const blobs_;
  metrics::Registry registry_;
  metrics::ValueFamily& jobs_;
  metrics::ValueFamily& submits_;
  metrics::ValueFamily& cache_hits_;
  metrics::ValueFamily& cache_misses_;
  metrics::HistogramFamily& bake_seconds_;
  metrics::HistogramFamily& stage_seconds_;
  metrics::HistogramFamily& lease_latency_;
  metrics::ValueFamily& leases_;
  metrics::ValueFamily& completed_;
  metrics::ValueFamily& failed_;
  metrics::ValueFamily& leases_lost_;
  metrics::ValueFamily& workers_;
  metrics::ValueFamily& workers_by_kind_;
  metrics::ValueFamily& pool_workers_;
  metrics::ValueFamily& pool_running_;
  metrics::ValueFamily& pool_share_running_;
  metrics::ValueFamily& pool_share_guaranteed_;
  metrics::ValueFamily& worker_done_;
  metrics::ValueFamily& worker_failed_;
  metrics::ValueFamily& store_bytes_;
  metrics::ValueFamily& evicted_blobs_;
  metrics::ValueFamily& evicted_results_;
  metrics::ValueFamily& evicted_bytes_;
  metrics::ValueFamily& rpcs_;
  metrics::ValueFamily& scrape_errors_;
  metrics::ValueFamily& ready_;
  metrics::ValueFamily& tls_cert_expiry_;

  mutable std::mutex labels_mu_;
  std::set<std::string> worker_labels_ ABSL_GUARDED_BY(labels_mu_);
  std::set<std::string> rpc_methods_;  // fixed at construction
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_METRICS_FARM_METRICS_H_
