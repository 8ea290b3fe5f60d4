// absl::Status -> grpc::Status at the service edge (same code, same message).
#ifndef IMPOSTOR_SERVER_GRPC_STATUS_H_
#define IMPOSTOR_SERVER_GRPC_STATUS_H_

#include <grpcpp/support/status.h>

#include "absl/status/status.h"

namespace impostor {

inline grpc::Status ToGrpc(const absl::Status& s) {
  if (s.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(s.code()), std::string(s.message()));
}

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_GRPC_STATUS_H_
