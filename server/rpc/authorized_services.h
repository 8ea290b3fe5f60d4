// The identity layer in front of the impostor.v1 services (issue 14):
// every call is authenticated (bearer token -> Principal), checked against
// the role table (access_policy.h) and, where the table says so, against
// the object it touches (own job; readable blob), before the real service's
// handler runs. State-changing calls get one audit line each.
//
// Why decorators of the generated Service classes, and not a gRPC hook:
//  - gRPC C++ server interceptors (grpc::experimental::
//    ServerInterceptorFactoryInterface, 1.51 as in Debian 12 and still
//    today) cannot end a call with a status before the handler runs: they
//    may observe and mutate, not hijack (grpc/grpc#24017, #28807).
//  - AuthMetadataProcessor can reject, but only runs on secure credentials;
//    the plaintext loopback quickstart has none (LocalServerCredentials
//    would change what clients must send), so two code paths would be
//    needed.
// A decorator works the same on plaintext and TLS listeners, sees the
// request (for per-object checks) and keeps the services free of identity
// conditionals. Each override below is one line: rule lookup, checks and
// audit live in AccessGuard.
//
// gRPC's own health and reflection services are not behind the layer:
// health answers load balancers that carry no token and reveals nothing;
// reflection describes the public API only.
//
// Thread-safety: called concurrently by gRPC's threads; holds only pointers.
#ifndef IMPOSTOR_SERVER_RPC_AUTHORIZED_SERVICES_H_
#define IMPOSTOR_SERVER_RPC_AUTHORIZED_SERVICES_H_

#include <functional>
#include <string>
#include <string_view>

#include "impostor/v1/admin_service.grpc.pb.h"
#include "server/auth/authenticator.h"
#include "server/scheduler/bake_scheduler.h"
#include "server/auth/call_principals.h"
#include "server/rpc/services.h"
#include "server/store/token_quotas.h"

namespace impostor {

class AccessGuard {
 public:
  // `authenticator` null = --auth none: every call runs as the anonymous
  // admin, without checks or audit. All pointers must outlive the guard.
  // `quotas` (may be null: none) apply to non-admin tokens.
  AccessGuard(Authenticator* authenticator, BakeScheduler* scheduler, CallPrincipals* principals,
              TokenQuotas* quotas = nullptr)
      : authenticator_(authenticator), scheduler_(scheduler), principals_(principals), quotas_(quotas) {}

  using Handler = std::function<grpc::Status(const Principal&)>;

  // Authenticates and authorises the call to `method` on `object` (a job
  // id or a blob hash, as the method's rule needs; may be empty), runs
  // `handler` with the principal registered, and writes the audit line.
  // `describe` (optional) names what the call touched, read after the
  // handler (e.g. the job SubmitBake created).
  grpc::Status Run(grpc::ServerContext* context, std::string_view method, const std::string& object,
                   const Handler& handler,
                   const std::function<std::string()>& describe = {});

 public:
  // The method rule's object check for one more object of a call that
  // names many (BatchReadBlobs: each digest under ReadBlob's rule): OK, or
  // PERMISSION_DENIED whose message starts with `field`, audited as a
  // refusal of `method` is.
  absl::Status AuthorizeObject(const Principal& principal, std::string_view method, const std::string& object,
                               std::string_view field);

  // Quotas (token_quotas.h) around SubmitBake, UploadBlob and
  // BatchUpdateBlobs: the check before, the record after a call that
  // succeeded.
  absl::Status CheckSubmitQuota(const Principal& principal);
  void RecordBake(const Principal& principal);
  absl::Status CheckUploadQuota(const Principal& principal);
  void RecordUpload(const Principal& principal, int64_t bytes);

 private:
  // OK, or PERMISSION_DENIED naming what the principal may not touch.
  absl::Status CheckObject(const Principal& principal, std::string_view method, const std::string& object);

  Authenticator* const authenticator_;
  BakeScheduler* const scheduler_;
  CallPrincipals* const principals_;
  TokenQuotas* const quotas_;
};

class AuthorizedAssetService final : public v1::AssetService::Service {
 public:
  AuthorizedAssetService(AccessGuard* guard, v1::AssetService::Service* inner) : guard_(guard), inner_(inner) {}
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
  AccessGuard* const guard_;
  v1::AssetService::Service* const inner_;
};

class AuthorizedBakeService final : public v1::BakeService::Service {
 public:
  AuthorizedBakeService(AccessGuard* guard, v1::BakeService::Service* inner) : guard_(guard), inner_(inner) {}
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
  AccessGuard* const guard_;
  v1::BakeService::Service* const inner_;
};

class AuthorizedWorkerService final : public v1::WorkerService::Service {
 public:
  AuthorizedWorkerService(AccessGuard* guard, v1::WorkerService::Service* inner) : guard_(guard), inner_(inner) {}
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
  AccessGuard* const guard_;
  v1::WorkerService::Service* const inner_;
};

class AuthorizedAdminService final : public v1::AdminService::Service {
 public:
  AuthorizedAdminService(AccessGuard* guard, v1::AdminService::Service* inner) : guard_(guard), inner_(inner) {}
  grpc::Status PurgeWorkerResults(grpc::ServerContext* context, const v1::PurgeWorkerResultsRequest* request,
                                  v1::PurgeWorkerResultsResponse* response) override;

 private:
  AccessGuard* const guard_;
  v1::AdminService::Service* const inner_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_AUTHORIZED_SERVICES_H_
