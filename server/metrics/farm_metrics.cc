#include "server/metrics/farm_metrics.h"

#include <google/protobuf/descriptor.h>

#include <algorithm>
#include <cctype>

#include "impostor/v1/asset_service.pb.h"
#include "impostor/v1/bake_service.pb.h"
#include "impostor/v1/worker_service.pb.h"

namespace impostor {
namespace {

// Seconds, from a cache hit's milliseconds to a large bake's hour.
const std::vector<double> kBakeBuckets = {0.5, 1, 2, 5, 10, 20, 30, 60, 120, 300, 600, 1200, 3600};
const std::vector<double> kStageBuckets = {0.01, 0.05, 0.1, 0.25, 0.5, 1, 2, 5, 10, 30, 60, 300, 1200};
const std::vector<double> kLatencyBuckets = {0.01, 0.05, 0.1, 0.5, 1, 2, 5, 10, 30, 60, 300, 900, 3600};

constexpr const char* kGrpcCodes[] = {
    "OK",        "CANCELLED",         "UNKNOWN",        "INVALID_ARGUMENT", "DEADLINE_EXCEEDED", "NOT_FOUND",
    "ALREADY_EXISTS", "PERMISSION_DENIED", "RESOURCE_EXHAUSTED", "FAILED_PRECONDITION", "ABORTED", "OUT_OF_RANGE",
    "UNIMPLEMENTED", "INTERNAL", "UNAVAILABLE", "DATA_LOSS", "UNAUTHENTICATED"};

const char* OutcomeLabel(SchedulerObserver::SubmitOutcome o) {
  switch (o) {
    case SchedulerObserver::SubmitOutcome::kCacheHit: return "cache_hit";
    case SchedulerObserver::SubmitOutcome::kQueued: return "queued";
    case SchedulerObserver::SubmitOutcome::kSharedBake: return "shared_bake";
    case SchedulerObserver::SubmitOutcome::kRetry: return "retry";
  }
  return "other";
}

std::string StateLabel(v1::JobState s) {
  std::string name = v1::JobState_Name(s);
  if (name.rfind("JOB_STATE_", 0) == 0) name = name.substr(10);
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  return name;
}

}  // namespace

std::string ProductLabel(v1::Product product) {
  switch (product) {
    case v1::PRODUCT_SURFELS: return "surfels";
    case v1::PRODUCT_CARDS: return "cards";
    case v1::PRODUCT_LOD_CHAIN: return "lod_chain";
    default: return "atlas";
  }
}

FarmMetrics::FarmMetrics(BakeScheduler* scheduler, const BlobStore* blobs)
    : scheduler_(scheduler),
      blobs_(blobs),
      jobs_(registry_.AddGauge("impostor_jobs", "Jobs in the job table by state (one per request; a request "
                                                "sharing a bake counts as queued until it ends)",
                               {"state"})),
      submits_(registry_.AddCounter("impostor_submits_total", "Accepted SubmitBake calls by product and outcome",
                                    {"product", "outcome"})),
      cache_hits_(registry_.AddCounter("impostor_cache_hits_total",
                                       "Submits answered from the result cache, by product", {"product"})),
      cache_misses_(registry_.AddCounter("impostor_cache_misses_total",
                                         "Submits that needed a bake (queued or shared), by product", {"product"})),
      bake_seconds_(registry_.AddHistogram("impostor_bake_seconds", "Worker time of a delivered bake, by product",
                                           {"product"}, kBakeBuckets)),
      stage_seconds_(registry_.AddHistogram("impostor_bake_stage_seconds",
                                            "Worker time per bake stage of a delivered bake", {"product", "stage"},
                                            kStageBuckets)),
      lease_latency_(registry_.AddHistogram("impostor_lease_latency_seconds",
                                            "Time from submit to a job's first lease, by product", {"product"},
                                            kLatencyBuckets)),
      leases_(registry_.AddCounter("impostor_leases_total", "Jobs leased to workers (every attempt), by product",
                                   {"product"})),
      completed_(registry_.AddCounter("impostor_jobs_completed_total", "Bakes delivered by workers, by product",
                                      {"product"})),
      failed_(registry_.AddCounter("impostor_jobs_failed_total",
                                   "FailJob reports by product and whether the job was queued again",
                                   {"product", "retried"})),
      leases_lost_(registry_.AddCounter("impostor_leases_lost_total",
                                        "Leases that ended without a report (expired or worker died), by product",
                                        {"product"})),
      workers_(registry_.AddGauge("impostor_workers", "Known workers by state (busy, paused, idle, offline)",
                                  {"state"})),
      workers_by_kind_(registry_.AddGauge(
          "impostor_workers_by_device_kind",
          "Workers heard from (not offline) by the device kind they report: discrete, integrated, virtual, cpu, "
          "other, or unreported (issue 44)",
          {"device_kind"})),
      pool_workers_(registry_.AddGauge("impostor_pool_workers",
                                       "Workers of each pool (--pools) this server heard from lately, not paused",
                                       {"pool"})),
      pool_running_(registry_.AddGauge("impostor_pool_running_jobs", "Running jobs on each pool's workers",
                                       {"pool"})),
      pool_share_running_(registry_.AddGauge("impostor_pool_share_running_jobs",
                                             "Running jobs of each team with a share (--pool-shares) on the pool's "
                                             "workers",
                                             {"pool", "team"})),
      pool_share_guaranteed_(registry_.AddGauge("impostor_pool_share_guaranteed_workers",
                                                "Workers each share guarantees its team now (percent of the pool's "
                                                "workers, rounded up)",
                                                {"pool", "team"})),
      worker_done_(registry_.AddCounter("impostor_worker_jobs_completed_total", "Bakes delivered, per worker",
                                        {"worker"})),
      worker_failed_(registry_.AddCounter("impostor_worker_jobs_failed_total",
                                          "FailJob reports and lost leases, per worker", {"worker"})),
      store_bytes_(registry_.AddGauge("impostor_blob_store_bytes", "Bytes of all blobs in the store")),
      evicted_blobs_(registry_.AddCounter("impostor_evicted_blobs_total", "Blobs removed by the store cap")),
      evicted_results_(registry_.AddCounter("impostor_evicted_results_total", "Results removed by the store cap")),
      evicted_bytes_(registry_.AddCounter("impostor_evicted_bytes_total", "Bytes freed by the store cap")),
      rpcs_(registry_.AddCounter("impostor_rpcs_total", "Finished gRPC calls by method and status code",
                                 {"method", "code"})),
      scrape_errors_(registry_.AddCounter("impostor_scrape_errors_total",
                                          "Scrapes whose job or worker gauges could not be read")),
      ready_(registry_.AddGauge("impostor_ready",
                                "1 when /readyz would answer 200: not shutting down, and the job database "
                                "answered a probe at this scrape")),
      tls_cert_expiry_(registry_.AddGauge("impostor_tls_cert_expiry_timestamp_seconds",
                                          "When the served TLS certificate expires (Unix seconds; absent "
                                          "without TLS)")) {
  for (const char* name : {"impostor.v1.AssetService", "impostor.v1.BakeService", "impostor.v1.WorkerService"}) {
    const google::protobuf::ServiceDescriptor* service =
        google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(name);
    if (service == nullptr) continue;
    for (int i = 0; i < service->method_count(); ++i) {
      rpc_methods_.insert("/" + service->full_name() + "/" + service->method(i)->name());
    }
  }
  tls_cert_expiry_.set_absent_until_set();
  rpc_methods_.insert("/grpc.health.v1.Health/Check");
  rpc_methods_.insert("/grpc.health.v1.Health/Watch");
}

std::string FarmMetrics::WorkerLabel(const std::string& worker_id) {
  std::lock_guard lock(labels_mu_);
  if (worker_labels_.count(worker_id)) return worker_id;
  if (worker_labels_.size() >= kMaxWorkerLabels) return "_other";
  worker_labels_.insert(worker_id);
  return worker_id;
}

std::string FarmMetrics::WorkerLabelIfKnown(const std::string& worker_id) const {
  std::lock_guard lock(labels_mu_);
  if (worker_labels_.count(worker_id)) return worker_id;
  return worker_labels_.size() >= kMaxWorkerLabels ? "_other" : "";
}

void FarmMetrics::OnSubmit(v1::Product product, SubmitOutcome outcome) {
  const std::string p = ProductLabel(product);
  submits_.Add({p, OutcomeLabel(outcome)});
  if (outcome == SubmitOutcome::kCacheHit) cache_hits_.Add({p});
  if (outcome == SubmitOutcome::kQueued || outcome == SubmitOutcome::kSharedBake) cache_misses_.Add({p});
}

void FarmMetrics::OnLease(const std::string& worker_id, v1::Product product, uint32_t attempt, double queued_seconds) {
  leases_.Add({ProductLabel(product)});
  if (attempt == 1) lease_latency_.Observe({ProductLabel(product)}, queued_seconds);
}

void FarmMetrics::OnComplete(const std::string& worker_id, const v1::Manifest& result) {
  const std::string p = ProductLabel(result.product());
  completed_.Add({p});
  worker_done_.Add({WorkerLabel(worker_id)});
  const v1::BakeTimings& t = result.timings();
  bake_seconds_.Observe({p}, t.total_seconds());
  const std::pair<const char*, double> stages[] = {{"download", t.download_seconds()}, {"load", t.load_seconds()},
                                                   {"render", t.render_seconds()},     {"readback", t.readback_seconds()},
                                                   {"encode", t.encode_seconds()},     {"store", t.store_seconds()}};
  for (const auto& [stage, seconds] : stages) stage_seconds_.Observe({p, stage}, seconds);
}

void FarmMetrics::OnFail(const std::string& worker_id, v1::Product product, bool will_retry) {
  failed_.Add({ProductLabel(product), will_retry ? "true" : "false"});
  worker_failed_.Add({WorkerLabel(worker_id)});
}

void FarmMetrics::OnLeaseLost(const std::string& worker_id, v1::Product product) {
  leases_lost_.Add({ProductLabel(product)});
  worker_failed_.Add({WorkerLabel(worker_id)});
}

void FarmMetrics::OnEvicted(int64_t blobs, int64_t results, int64_t bytes) {
  evicted_blobs_.Add({}, static_cast<double>(blobs));
  evicted_results_.Add({}, static_cast<double>(results));
  evicted_bytes_.Add({}, static_cast<double>(bytes));
}

void FarmMetrics::OnRpc(const std::string& method, int code) {
  const std::string m = rpc_methods_.count(method) ? method : "other";
  const std::string c = code >= 0 && code < static_cast<int>(std::size(kGrpcCodes)) ? kGrpcCodes[code] : "UNKNOWN";
  rpcs_.Add({m, c});
}

std::string FarmMetrics::Scrape() {
  store_bytes_.Set({}, static_cast<double>(blobs_->total_bytes()));
  // First, so that a database outage it finds makes the views below
  // answer at once rather than wait out a reconnect.
  ready_.Set({}, scheduler_->CheckReady().ok() ? 1.0 : 0.0);
  auto counts = scheduler_->JobCountsByState();
  auto workers = scheduler_->Workers();
  if (!counts.ok() || !workers.ok()) scrape_errors_.Add({});
  // A gauge that cannot be read is left out, not shown at its last value.
  if (!counts.ok()) jobs_.Clear();
  if (!workers.ok()) workers_.Clear();
  if (counts.ok()) {
    // Every state is listed, 0 included, so a rate() never sees a gap.
    for (int s = v1::JOB_STATE_QUEUED; s <= v1::JOB_STATE_CANCELLED; ++s) {
      if (!v1::JobState_IsValid(s)) continue;
      const auto it = counts->find(static_cast<v1::JobState>(s));
      jobs_.Set({StateLabel(static_cast<v1::JobState>(s))},
                it == counts->end() ? 0.0 : static_cast<double>(it->second));
    }
  }
  if (workers.ok()) {
    std::map<std::string, double> by_state;
    for (int i = 0; i < 4; ++i) by_state[std::string(BakeScheduler::WorkerStateName(i))] = 0;
    for (const auto& w : *workers) by_state[w.state] += 1;
    for (const auto& [state, n] : by_state) workers_.Set({state}, n);
    // A fixed label set, whatever workers send.
    std::map<std::string, double> by_kind = {{"discrete", 0}, {"integrated", 0}, {"virtual", 0},
                                             {"cpu", 0},      {"other", 0},      {"unreported", 0}};
    for (const auto& w : *workers) {
      if (w.state == "offline") continue;
      std::string kind = w.capabilities ? w.capabilities->device_kind() : "unreported";
      if (!by_kind.count(kind)) kind = "other";
      by_kind[kind] += 1;
    }
    for (const auto& [kind, n] : by_kind) workers_by_kind_.Set({kind}, n);
  }
  if (!scheduler_->options().pools.empty()) {
    auto pools = scheduler_->Pools();
    if (!pools.ok()) {
      scrape_errors_.Add({});
      for (auto* family : {&pool_workers_, &pool_running_, &pool_share_running_, &pool_share_guaranteed_}) {
        family->Clear();
      }
    } else {
      for (const auto& pool : *pools) {
        pool_workers_.Set({pool.name}, static_cast<double>(pool.workers));
        pool_running_.Set({pool.name}, static_cast<double>(pool.running));
        for (const auto& share : pool.shares) {
          pool_share_running_.Set({pool.name, share.team}, static_cast<double>(share.running));
          pool_share_guaranteed_.Set({pool.name, share.team}, static_cast<double>(share.guaranteed));
        }
      }
    }
  }
  return registry_.Render();
}

FarmMetrics::Totals FarmMetrics::totals() const {
  Totals t;
  for (const char* p : {"atlas", "surfels", "cards", "lod_chain"}) {
    t.cache_hits += cache_hits_.Get({p});
    t.cache_misses += cache_misses_.Get({p});
    t.jobs_completed += completed_.Get({p});
    t.jobs_failed += failed_.Get({p, "false"});
  }
  return t;
}

std::pair<double, double> FarmMetrics::WorkerTotals(const std::string& worker_id) const {
  const std::string label = WorkerLabelIfKnown(worker_id);
  if (label.empty()) return {0, 0};
  return {worker_done_.Get({label}), worker_failed_.Get({label})};
}

}  // namespace impostor
