#include <cmath>
#include <map>
#include <mutex>
#include <string>

#include <spdlog/spdlog.h>

#include "common/request/normalized_bake_request.h"
#include "common/util/log_escape.h"
#include "common/util/utf8.h"
#include "server/rpc/grpc_status.h"
#include "server/rpc/services.h"
#include "server/rpc/submit_tags.h"

namespace impostor {
namespace {

bool IsTerminal(v1::JobState s) {
  return s == v1::JOB_STATE_SUCCEEDED || s == v1::JOB_STATE_FAILED || s == v1::JOB_STATE_CANCELLED;
}

// Watchers hear about state and stage changes, and progress in 1% steps.
bool WorthSending(const v1::Job& last, const v1::Job& now) {
  return last.state() != now.state() || last.stage() != now.stage() ||
         std::abs(last.progress() - now.progress()) >= 0.01f;
}

// Who is asking, for per-client limits: the "impostor-client-id" metadata a
// client may send (a CI job names itself), else the peer's address without
// its port.
std::string ClientId(const grpc::ServerContext& context) {
  const auto& metadata = context.client_metadata();
  if (auto it = metadata.find("impostor-client-id"); it != metadata.end()) {
    return std::string(Utf8Prefix(std::string_view(it->second.data(), it->second.size()), 128));
  }
  std::string peer = context.peer();
  if (const size_t colon = peer.rfind(':'); colon != std::string::npos && colon > peer.find(':')) {
    peer.resize(colon);
  }
  return peer;
}

// Open WatchJob streams, in all and per connection (peer address and
// port: one client process's channel), logged (debug) as each opens and
// closes: clients promise to hold few at once (bake-batch at most 8), and
// tests read the counts from the log to hold them to it.
class OpenWatch {
 public:
  OpenWatch(const grpc::ServerContext& context, const std::string& job_id)
      : client_(ClientId(context)), peer_(context.peer()), job_id_(job_id) {
    Log("watch_open", +1);
  }
  ~OpenWatch() { Log("watch_close", -1); }
  OpenWatch(const OpenWatch&) = delete;
  OpenWatch& operator=(const OpenWatch&) = delete;

 private:
  void Log(std::string_view event, int delta) {
    if (!spdlog::should_log(spdlog::level::debug)) return;
    int mine, all;
    {
      static std::mutex mu;
      static std::map<std::string, int> per_peer;
      static int total = 0;
      std::lock_guard lock(mu);
      mine = per_peer[peer_] += delta;
      if (mine == 0) per_peer.erase(peer_);
      all = total += delta;
    }
    spdlog::debug("event={} client=\"{}\" peer=\"{}\" peer_watches={} open_watches={} job=\"{}\"", event,
                  EscapeUntrusted(client_), EscapeUntrusted(peer_), mine, all, EscapeUntrusted(job_id_, 128));
  }

  const std::string client_;
  const std::string peer_;
  const std::string& job_id_;
};

}  // namespace

grpc::Status BakeServiceImpl::SubmitBake(grpc::ServerContext* context, const v1::SubmitBakeRequest* request,
                                         v1::SubmitBakeResponse* response) {
  const Principal caller = principals_ ? principals_->Of(context) : Principal{};
  // With tokens, per-client limits and fairness count inside the token:
  // the impostor-client-id label cannot make one token look like another.
  const std::string& owner = caller.name;
  // Checked, normalised and keyed here, before the scheduler sees it; the
  // token's default tags join the request's (not the key: a cached result
  // is served whoever asks).
  auto normalized = NormalizeSubmit(*request);
  if (!normalized.ok()) return ToGrpc(normalized.status(), context);
  auto tags = WithTokenRequiredTags(normalized->required_tags, caller);
  if (!tags.ok()) return ToGrpc(tags.status(), context);
  normalized->required_tags = *std::move(tags);
  auto r = scheduler_->Submit(*normalized, owner.empty() ? ClientId(*context) : owner + "/" + ClientId(*context),
                              owner);
  if (!r.ok()) return ToGrpc(r.status(), context);
  *response = std::move(*r);
  return grpc::Status::OK;
}

grpc::Status BakeServiceImpl::LookupBake(grpc::ServerContext*, const v1::SubmitBakeRequest* request,
                                         v1::LookupBakeResponse* response) {
  auto normalized = NormalizeLookup(*request);
  if (!normalized.ok()) return ToGrpc(normalized.status());
  auto r = scheduler_->Lookup(*normalized);
  if (!r.ok()) return ToGrpc(r.status());
  *response = std::move(*r);
  return grpc::Status::OK;
}

grpc::Status BakeServiceImpl::WatchJob(grpc::ServerContext* context, const v1::WatchJobRequest* request,
                                       grpc::ServerWriter<v1::Job>* writer) {
  const OpenWatch open_watch(*context, request->job_id());
  std::optional<v1::Job> last;
  while (!context->IsCancelled()) {
    // A stopping server ends the stream so the client reconnects to the
    // next one instead of hanging on a server that will never send again.
    if (scheduler_->shutting_down()) {
      return grpc::Status(grpc::StatusCode::UNAVAILABLE, "WatchJob: the server is shutting down; watch again");
    }
    const uint64_t seen = scheduler_->change_count();
    auto job = scheduler_->GetJob(request->job_id());
    if (!job.ok()) return ToGrpc(job.status());
    if (!last || WorthSending(*last, *job)) {
      if (!writer->Write(*job)) return grpc::Status::OK;  // the client went away
      last = *job;
    }
    if (IsTerminal(job->state())) return grpc::Status::OK;
    // Wake at least once a second to notice a cancelled call.
    scheduler_->WaitForChange(seen, std::chrono::steady_clock::now() + std::chrono::seconds(1));
  }
  return grpc::Status(grpc::StatusCode::CANCELLED, "WatchJob: the client cancelled the call");
}

grpc::Status BakeServiceImpl::GetJob(grpc::ServerContext*, const v1::GetJobRequest* request, v1::Job* response) {
  auto r = scheduler_->GetJob(request->job_id());
  if (!r.ok()) return ToGrpc(r.status());
  *response = std::move(*r);
  return grpc::Status::OK;
}

grpc::Status BakeServiceImpl::CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request,
                                        v1::Job* response) {
  auto r = scheduler_->CancelJob(request->job_id());
  if (!r.ok()) return ToGrpc(r.status(), context);  // DATABASE_FULL, if so
  *response = std::move(*r);
  return grpc::Status::OK;
}

}  // namespace impostor
