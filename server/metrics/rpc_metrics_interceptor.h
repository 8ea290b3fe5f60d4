// A gRPC server interceptor that counts every finished call by method and
// status code into FarmMetrics (impostor_rpcs_total). Register it with
// ServerBuilder::experimental().SetInterceptorCreators before BuildAndStart.
#ifndef IMPOSTOR_SERVER_METRICS_RPC_METRICS_INTERCEPTOR_H_
#define IMPOSTOR_SERVER_METRICS_RPC_METRICS_INTERCEPTOR_H_

#include <memory>

#include <grpcpp/support/server_interceptor.h>

#include "server/metrics/farm_metrics.h"

namespace impostor {

class RpcMetricsInterceptorFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  // `metrics` must outlive the server.
  explicit RpcMetricsInterceptorFactory(FarmMetrics* metrics) : metrics_(metrics) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override;

 private:
  FarmMetrics* const metrics_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_METRICS_RPC_METRICS_INTERCEPTOR_H_
