// The JSON documents of the HTTP API (docs/http_api.md), built from the
// scheduler's views and the metrics' totals. Pure functions: data in, text
// out, so each document is unit-testable without a server.
#ifndef IMPOSTOR_SERVER_HTTP_JSON_API_H_
#define IMPOSTOR_SERVER_HTTP_JSON_API_H_

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/scheduler/bake_scheduler.h"
#include "server/http/http_authorize.h"
#include "server/metrics/farm_metrics.h"

namespace impostor {

// A proto message as JSON with its .proto field names; 64-bit integers
// become JSON numbers (protobuf's mapping writes them as strings, which
// every reader would have to convert).
nlohmann::json ProtoJson(const google::protobuf::Message& message);

// One job. With `with_result`, the result's manifest when it has one. A
// viewer who may not see its inputs gets the mesh's paths without digests
// ("digests_hidden": true).
nlohmann::json JobJson(const BakeScheduler::JobListing& listing, bool with_result, const JobViewer& viewer);
// {"jobs": [...], "next_page_token": "..." (only when the page is full)}.
nlohmann::json JobsPageJson(const std::vector<BakeScheduler::JobListing>& jobs, int page_size,
                            const JobViewer& viewer);
// {"workers": [...]} with each worker's jobs done and failed.
// {"pools": [...]}: each pool (--pools) with its workers, running jobs
// and shares (BakeScheduler::Pools).
nlohmann::json PoolsJson(const std::vector<BakeScheduler::PoolInfo>& pools);
nlohmann::json WorkersJson(const std::vector<BakeScheduler::WorkerInfo>& workers, const FarmMetrics& metrics);
// One result: its manifest plus pinned, created_ms, last_used_ms.
nlohmann::json ResultJson(const JobStore::StoredResult& result);
// {"results": [...summaries...], "next_page_token": ...}.
nlohmann::json ResultsPageJson(const std::vector<JobStore::StoredResult>& results, int page_size);
// What the overview shows at a glance.
nlohmann::json SummaryJson(const std::map<v1::JobState, int64_t>& jobs_by_state,
                           const std::vector<BakeScheduler::WorkerInfo>& workers, const FarmMetrics::Totals& totals,
                           int64_t store_bytes, int64_t now_ms);
// {"error": {"code": HTTP status, "message": ...}}.
std::string ErrorJson(int http_status, const std::string& message);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_JSON_API_H_
