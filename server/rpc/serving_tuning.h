// gRPC server settings for many small concurrent calls (issue 18: cache
// hits at 200 callers). Kept out of main.cc so the reasons sit with them.
#ifndef IMPOSTOR_SERVER_RPC_SERVING_TUNING_H_
#define IMPOSTOR_SERVER_RPC_SERVING_TUNING_H_

#include <grpcpp/server_builder.h>

namespace impostor {

// Applies the settings below to `builder`, and turns off abseil's mutex
// deadlock detection for the process (see serving_tuning.cc).
void TuneForManyCallers(grpc::ServerBuilder& builder);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_SERVING_TUNING_H_
