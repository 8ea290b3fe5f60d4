// gRPC adapter of impostor.v1.AdminService (issue 14): farm administration
// over BakeScheduler. Only admin tokens reach it (the AuthorizedAdminService
// decorator in authorized_services.h and the role table in
// access_policy.cc); no identity logic here. Stateless beyond its pointer;
// called concurrently by gRPC's threads.
#ifndef IMPOSTOR_SERVER_RPC_ADMIN_SERVICE_H_
#define IMPOSTOR_SERVER_RPC_ADMIN_SERVICE_H_

#include "impostor/v1/admin_service.grpc.pb.h"
#include "server/scheduler/bake_scheduler.h"

namespace impostor {

class AdminServiceImpl final : public v1::AdminService::Service {
 public:
  explicit AdminServiceImpl(BakeScheduler* scheduler) : scheduler_(scheduler) {}

  grpc::Status PurgeWorkerResults(grpc::ServerContext* context, const v1::PurgeWorkerResultsRequest* request,
                                  v1::PurgeWorkerResultsResponse* response) override;

 private:
  BakeScheduler* const scheduler_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_ADMIN_SERVICE_H_
