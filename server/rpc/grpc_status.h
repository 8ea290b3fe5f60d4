// absl::Status -> grpc::Status at the service edge (same code, same message).
#ifndef IMPOSTOR_SERVER_RPC_GRPC_STATUS_H_
#define IMPOSTOR_SERVER_RPC_GRPC_STATUS_H_

#include <string>

#include <grpcpp/server_context.h>
#include <grpcpp/support/status.h>

#include "absl/status/status.h"
#include "common/error_reason.h"

namespace impostor {

inline grpc::Status ToGrpc(const absl::Status& s) {
  if (s.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(s.code()), std::string(s.message()));
}

// ToGrpc for the calls whose refusals may carry an error reason
// (common/error_reason.h): the reason goes out as trailing metadata of
// `context`'s call.
inline grpc::Status ToGrpc(const absl::Status& s, grpc::ServerContext* context) {
  if (const std::string reason = ErrorReasonOf(s); !reason.empty() && context != nullptr) {
    context->AddTrailingMetadata(kErrorReasonMetadataKey, reason);
  }
  return ToGrpc(s);
}

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_GRPC_STATUS_H_
