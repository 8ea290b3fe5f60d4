// gRPC adapters for the three impostor.v1 services. Each translates requests
// into calls on BlobStore / BakeScheduler and statuses back; no bake logic
// lives here. The objects are stateless beyond their pointers and are
// called concurrently by gRPC's thread pool.
#ifndef IMPOSTOR_SERVER_RPC_SERVICES_H_
#define IMPOSTOR_SERVER_RPC_SERVICES_H_

#include <string>
#include <utility>

#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/bake_service.grpc.pb.h"
#include "impostor/v1/worker_service.grpc.pb.h"
#include "server/scheduler/bake_scheduler.h"
#include "server/blobs/blob_store.h"
#include "server/auth/call_principals.h"

namespace impostor {

class AssetServiceImpl final : public v1::AssetService::Service {
 public:
  // `advertised_http`: the farm's HTTP front end as clients reach it
  // (--http-advertise), sent with every GetResult answer; "" = none.
  AssetServiceImpl(BlobStore* blobs, BakeScheduler* scheduler, std::string advertised_http = "")
      : blobs_(blobs), scheduler_(scheduler), advertised_http_(std::move(advertised_http)) {}

  grpc::Status FindMissingBlobs(grpc::ServerContext* context, const v1::FindMissingBlobsRequest* request,
                                v1::FindMissingBlobsResponse* response) override;
  grpc::Status UploadBlob(grpc::ServerContext* context, grpc::ServerReader<v1::UploadBlobRequest>* reader,
                          v1::UploadBlobResponse* response) override;
  grpc::Status BatchUpdateBlobs(grpc::ServerContext* context, const v1::BatchUpdateBlobsRequest* request,
                                v1::BatchUpdateBlobsResponse* response) override;
  grpc::Status QueryUpload(grpc::ServerContext* context, const v1::QueryUploadRequest* request,
                           v1::QueryUploadResponse* response) override;
  grpc::Status ReadBlob(grpc::ServerContext* context, const v1::ReadBlobRequest* request,
                        grpc::ServerWriter<v1::ReadBlobResponse>* writer) override;
  grpc::Status BatchReadBlobs(grpc::ServerContext* context, const v1::BatchReadBlobsRequest* request,
                              v1::BatchReadBlobsResponse* response) override;
  grpc::Status GetResult(grpc::ServerContext* context, const v1::GetResultRequest* request,
                         v1::Manifest* response) override;
  grpc::Status PinResult(grpc::ServerContext* context, const v1::PinResultRequest* request,
                         v1::PinResultResponse* response) override;

 private:
  BlobStore* const blobs_;
  BakeScheduler* const scheduler_;
  const std::string advertised_http_;
};

class BakeServiceImpl final : public v1::BakeService::Service {
 public:
  // `principals` (null without tokens) names the caller of SubmitBake: the
  // job's owner, and the scope of its impostor-client-id label.
  explicit BakeServiceImpl(BakeScheduler* scheduler, CallPrincipals* principals = nullptr)
      : scheduler_(scheduler), principals_(principals) {}

  grpc::Status SubmitBake(grpc::ServerContext* context, const v1::SubmitBakeRequest* request,
                          v1::SubmitBakeResponse* response) override;
  grpc::Status LookupBake(grpc::ServerContext* context, const v1::SubmitBakeRequest* request,
                          v1::LookupBakeResponse* response) override;
  grpc::Status WatchJob(grpc::ServerContext* context, const v1::WatchJobRequest* request,
                        grpc::ServerWriter<v1::Job>* writer) override;
  grpc::Status GetJob(grpc::ServerContext* context, const v1::GetJobRequest* request, v1::Job* response) override;
  grpc::Status CancelJob(grpc::ServerContext* context, const v1::CancelJobRequest* request,
                         v1::Job* response) override;

 private:
  BakeScheduler* const scheduler_;
  CallPrincipals* const principals_;
};

class WorkerServiceImpl final : public v1::WorkerService::Service {
 public:
  // `principals` (null without tokens) names the worker token that leases.
  explicit WorkerServiceImpl(BakeScheduler* scheduler, CallPrincipals* principals = nullptr)
      : scheduler_(scheduler), principals_(principals) {}

  grpc::Status LeaseJob(grpc::ServerContext* context, const v1::LeaseJobRequest* request,
                        v1::LeaseJobResponse* response) override;
  grpc::Status ReportProgress(grpc::ServerContext* context, const v1::ReportProgressRequest* request,
                              v1::ReportProgressResponse* response) override;
  grpc::Status CompleteJob(grpc::ServerContext* context, const v1::CompleteJobRequest* request,
                           v1::CompleteJobResponse* response) override;
  grpc::Status FailJob(grpc::ServerContext* context, const v1::FailJobRequest* request,
                       v1::FailJobResponse* response) override;
  grpc::Status ReleaseJob(grpc::ServerContext* context, const v1::ReleaseJobRequest* request,
                          v1::ReleaseJobResponse* response) override;

 private:
  BakeScheduler* const scheduler_;
  CallPrincipals* const principals_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_SERVICES_H_
