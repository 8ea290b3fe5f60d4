#include "server/http/json_api.h"

#include <cmath>
#include <cstdint>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>

#include "server/store/attempt_history.h"
#include "server/http/api_params.h"

namespace impostor {
namespace {

// protobuf's JSON writes int64/uint64 as strings; turn them back into
// numbers (every value here is far below 2^53).
void NumbersFor64BitFields(const google::protobuf::Descriptor* d, nlohmann::json& j) {
  if (!j.is_object()) return;
  for (int i = 0; i < d->field_count(); ++i) {
    const google::protobuf::FieldDescriptor* f = d->field(i);
    auto it = j.find(f->name());
    if (it == j.end()) continue;
    auto fix = [&](nlohmann::json& v) {
      using FD = google::protobuf::FieldDescriptor;
      if (f->cpp_type() == FD::CPPTYPE_MESSAGE) {
        NumbersFor64BitFields(f->message_type(), v);
      } else if (v.is_string() && (f->cpp_type() == FD::CPPTYPE_INT64 || f->cpp_type() == FD::CPPTYPE_UINT64)) {
        v = std::stoll(v.get<std::string>());
      }
    };
    if (f->is_repeated() && it->is_array()) {
      for (auto& v : *it) fix(v);
    } else {
      fix(*it);
    }
  }
}

// FarmMetrics keeps counts as Prometheus counters (doubles); the API gives
// counts as JSON integers (301, not 301.0), like the jobs-by-state counts.
int64_t Count(double counter) { return std::llround(counter); }

}  // namespace

nlohmann::json ProtoJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string text;
  if (!google::protobuf::util::MessageToJsonString(message, &text, options).ok()) return nlohmann::json::object();
  nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) return nlohmann::json::object();
  NumbersFor64BitFields(message.GetDescriptor(), j);
  return j;
}

nlohmann::json JobJson(const BakeScheduler::JobListing& listing, bool with_result, const JobViewer& viewer) {
  v1::Job job = listing.job;
  if (!with_result) job.clear_result();
  nlohmann::json j = ProtoJson(job);
  j["state"] = StateName(job.state());
  // Outcomes as lower-case words, like `state`.
  for (int i = 0; i < job.attempt_history_size() && i < static_cast<int>(j["attempt_history"].size()); ++i) {
    j["attempt_history"][i]["outcome"] = AttemptOutcomeName(job.attempt_history(i).outcome());
  }
  j["requester"] = listing.client_id;
  j["leader_job_id"] = listing.leader_job_id;
  j["lease_priority"] = listing.lease_priority;
  j["product"] = ProductLabel(listing.parameters.product());
  j["parameters"] = ProtoJson(listing.parameters);
  j["mesh"] = ProtoJson(listing.mesh);
  if (!viewer.MaySeeInputsOf(listing)) {
    nlohmann::json& mesh = j["mesh"];
    if (mesh.contains("entry") && mesh["entry"].is_object()) mesh["entry"].erase("digest");
    if (mesh.contains("files") && mesh["files"].is_array()) {
      for (auto& file : mesh["files"]) {
        if (file.is_object()) file.erase("digest");
      }
    }
    mesh["digests_hidden"] = true;
  }
  if (!with_result || !job.has_result()) j.erase("result");
  return j;
}

nlohmann::json JobsPageJson(const std::vector<BakeScheduler::JobListing>& jobs, int page_size,
                            const JobViewer& viewer) {
  nlohmann::json j;
  j["jobs"] = nlohmann::json::array();
  for (const auto& l : jobs) j["jobs"].push_back(JobJson(l, false, viewer));
  if (static_cast<int>(jobs.size()) == page_size && !jobs.empty()) {
    j["next_page_token"] = JobPageToken({jobs.back().job.created_ms(), jobs.back().job.job_id()});
  }
  return j;
}

// What a worker reported it can do (issue 44); null when it reported nothing.
nlohmann::json CapabilitiesJson(const std::optional<v1::WorkerCapabilities>& caps) {
  if (!caps) return nullptr;
  return {{"device_kind", caps->device_kind()},
          {"device_memory_bytes", caps->device_memory_bytes()},
          {"max_allocation_bytes", caps->max_allocation_bytes()},
          {"host_memory_bytes", caps->host_memory_bytes()},
          {"ktx2_encoder", caps->ktx2_encoder()},
          {"baker_version", caps->baker_version()},
          {"tags", std::vector<std::string>(caps->tags().begin(), caps->tags().end())}};
}

nlohmann::json PoolsJson(const std::vector<BakeScheduler::PoolInfo>& pools) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& pool : pools) {
    nlohmann::json shares = nlohmann::json::array();
    for (const auto& share : pool.shares) {
      shares.push_back({{"team", share.team},
                        {"percent", share.percent},
                        {"guaranteed_workers", share.guaranteed},
                        {"running", share.running}});
    }
    list.push_back({{"name", pool.name},
                    {"tag", pool.tag},
                    {"workers", pool.workers},
                    {"running", pool.running},
                    {"shares", shares}});
  }
  return {{"pools", list}};
}

nlohmann::json WorkersJson(const std::vector<BakeScheduler::WorkerInfo>& workers, const FarmMetrics& metrics) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& w : workers) {
    const auto [done, failed] = metrics.WorkerTotals(w.worker_id);
    list.push_back({{"worker_id", w.worker_id},
                    {"device", w.device},
                    {"state", w.state},
                    {"last_seen_ms", w.last_seen_ms},
                    {"job_ids", w.job_ids},
                    {"paused_until_ms", w.paused_until_ms},
                    {"jobs_completed", Count(done)},
                    {"jobs_failed", Count(failed)},
                    {"capabilities", CapabilitiesJson(w.capabilities)}});
  }
  return {{"workers", list}};
}

nlohmann::json ResultJson(const JobStore::StoredResult& result) {
  return {{"cache_key", result.manifest.cache_key()},
          {"pinned", result.pinned},
          {"created_ms", result.created_ms},
          {"last_used_ms", result.last_used_ms},
          {"job_id", result.source_job_id},
          {"manifest", ProtoJson(result.manifest)}};
}

nlohmann::json ResultsPageJson(const std::vector<JobStore::StoredResult>& results, int page_size) {
  nlohmann::json j;
  j["results"] = nlohmann::json::array();
  for (const auto& r : results) {
    const v1::Manifest& m = r.manifest;
    int64_t bytes = m.manifest_json().size_bytes();
    for (const auto& map : m.maps()) bytes += map.digest().size_bytes();
    nlohmann::json item = {{"cache_key", m.cache_key()},
                           {"product", ProductLabel(m.product())},
                           {"layout", v1::Layout_Name(m.layout())},
                           {"frames", m.frames()},
                           {"resolution", m.resolution()},
                           {"bytes", bytes},
                           {"pinned", r.pinned},
                           {"created_ms", r.created_ms},
                           {"last_used_ms", r.last_used_ms}};
    if (m.has_quality()) {
      item["silhouette_iou_mean"] = m.quality().silhouette_iou_mean();
      item["albedo_psnr_shared_db_mean"] = m.quality().albedo_psnr_shared_db_mean();
    }
    j["results"].push_back(std::move(item));
  }
  if (static_cast<int>(results.size()) == page_size && !results.empty()) {
    j["next_page_token"] = ResultPageToken({results.back().created_ms, results.back().manifest.cache_key()});
  }
  return j;
}

nlohmann::json SummaryJson(const std::map<v1::JobState, int64_t>& jobs_by_state,
                           const std::vector<BakeScheduler::WorkerInfo>& workers, const FarmMetrics::Totals& totals,
                           int64_t store_bytes, int64_t now_ms) {
  nlohmann::json jobs = nlohmann::json::object();
  for (int s = v1::JOB_STATE_QUEUED; s <= v1::JOB_STATE_CANCELLED; ++s) {
    const auto it = jobs_by_state.find(static_cast<v1::JobState>(s));
    jobs[StateName(static_cast<v1::JobState>(s))] = it == jobs_by_state.end() ? 0 : it->second;
  }
  nlohmann::json by_state = {{"busy", 0}, {"paused", 0}, {"idle", 0}, {"offline", 0}};
  for (const auto& w : workers) by_state[w.state] = by_state[w.state].get<int>() + 1;
  const double lookups = totals.cache_hits + totals.cache_misses;
  return {{"now_ms", now_ms},
          {"jobs", jobs},
          {"workers", by_state},
          {"cache_hits", Count(totals.cache_hits)},
          {"cache_misses", Count(totals.cache_misses)},
          {"cache_hit_ratio", lookups > 0 ? totals.cache_hits / lookups : 0.0},
          {"jobs_completed", Count(totals.jobs_completed)},
          {"jobs_failed", Count(totals.jobs_failed)},
          {"store_bytes", store_bytes}};
}

std::string ErrorJson(int http_status, const std::string& message) {
  // The message may echo a caller's bytes (a path, a query value): invalid
  // UTF-8 becomes U+FFFD instead of an exception and an empty 500.
  return nlohmann::json({{"error", {{"code", http_status}, {"message", message}}}})
             .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) +
         "\n";
}

}  // namespace impostor
