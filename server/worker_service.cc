#include "server/grpc_status.h"
#include "server/services.h"

namespace impostor {

grpc::Status WorkerServiceImpl::LeaseJob(grpc::ServerContext* context, const v1::LeaseJobRequest* request,
                                         v1::LeaseJobResponse* response) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(request->wait_seconds());
  const Principal principal = principals_ ? principals_->Of(context) : Principal{};
  // Worker ids belong to worker tokens; an admin leasing (by hand, in a
  // test) neither takes one nor is refused one.
  auto job = scheduler_->Lease(*request, deadline, [context] { return context->IsCancelled(); }, principal.name,
                               /*bind_worker_id=*/principal.role == Role::kWorker);
  if (!job.ok()) return ToGrpc(job.status());
  if (job->has_value()) *response->mutable_job() = std::move(**job);
  return grpc::Status::OK;
}

grpc::Status WorkerServiceImpl::ReportProgress(grpc::ServerContext*, const v1::ReportProgressRequest* request,
                                               v1::ReportProgressResponse* response) {
  auto r = scheduler_->ReportProgress(*request);
  if (!r.ok()) return ToGrpc(r.status());
  *response = std::move(*r);
  return grpc::Status::OK;
}

grpc::Status WorkerServiceImpl::CompleteJob(grpc::ServerContext*, const v1::CompleteJobRequest* request,
                                            v1::CompleteJobResponse*) {
  return ToGrpc(scheduler_->Complete(*request));
}

grpc::Status WorkerServiceImpl::FailJob(grpc::ServerContext*, const v1::FailJobRequest* request,
                                        v1::FailJobResponse*) {
  return ToGrpc(scheduler_->Fail(*request));
}

grpc::Status WorkerServiceImpl::ReleaseJob(grpc::ServerContext*, const v1::ReleaseJobRequest* request,
                                           v1::ReleaseJobResponse*) {
  return ToGrpc(scheduler_->Release(*request));
}

}  // namespace impostor
