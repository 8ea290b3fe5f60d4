#include "server/rpc/grpc_status.h"
#include "server/rpc/services.h"

namespace impostor {

// Every refusal goes out with its error reason (DATABASE_FULL when the job
// database's disk is full, which a worker waits out: common/error_reason.h).
grpc::Status WorkerServiceImpl::LeaseJob(grpc::ServerContext* context, const v1::LeaseJobRequest* request,
                                         v1::LeaseJobResponse* response) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(request->wait_seconds());
  const Principal principal = principals_ ? principals_->Of(context) : Principal{};
  // Worker ids belong to worker tokens; an admin leasing (by hand, in a
  // test) neither takes one nor is refused one.
  auto job = scheduler_->Lease(*request, deadline, [context] { return context->IsCancelled(); }, principal.name,
                               /*bind_worker_id=*/principal.role == Role::kWorker);
  if (!job.ok()) return ToGrpc(job.status(), context);
  if (job->has_value()) *response->mutable_job() = std::move(**job);
  return grpc::Status::OK;
}

grpc::Status WorkerServiceImpl::ReportProgress(grpc::ServerContext* context, const v1::ReportProgressRequest* request,
                                               v1::ReportProgressResponse* response) {
  auto r = scheduler_->ReportProgress(*request);
  if (!r.ok()) return ToGrpc(r.status(), context);
  *response = std::move(*r);
  return grpc::Status::OK;
}

grpc::Status WorkerServiceImpl::CompleteJob(grpc::ServerContext* context, const v1::CompleteJobRequest* request,
                                            v1::CompleteJobResponse*) {
  return ToGrpc(scheduler_->Complete(*request), context);
}

grpc::Status WorkerServiceImpl::FailJob(grpc::ServerContext* context, const v1::FailJobRequest* request,
                                        v1::FailJobResponse*) {
  return ToGrpc(scheduler_->Fail(*request), context);
}

grpc::Status WorkerServiceImpl::ReleaseJob(grpc::ServerContext* context, const v1::ReleaseJobRequest* request,
                                           v1::ReleaseJobResponse*) {
  return ToGrpc(scheduler_->Release(*request), context);
}

}  // namespace impostor
