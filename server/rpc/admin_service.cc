#include "server/rpc/admin_service.h"

#include "server/rpc/grpc_status.h"

namespace impostor {

grpc::Status AdminServiceImpl::PurgeWorkerResults(grpc::ServerContext*, const v1::PurgeWorkerResultsRequest* request,
                                                  v1::PurgeWorkerResultsResponse* response) {
  auto stats = scheduler_->PurgeResultsBakedBy(request->worker());
  if (!stats.ok()) return ToGrpc(stats.status());
  for (const std::string& key : stats->cache_keys) response->add_cache_keys(key);
  response->set_blobs_removed(stats->blobs_removed);
  response->set_bytes_freed(stats->bytes_freed);
  response->set_blobs_kept(stats->blobs_kept);
  return grpc::Status::OK;
}

}  // namespace impostor
