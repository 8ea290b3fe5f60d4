// gRPC call helpers the worker loop and its farm link share (worker_loop.cc,
// worker_calls.cc); not for use outside worker/.
#ifndef IMPOSTOR_WORKER_WORKER_RPC_H_
#define IMPOSTOR_WORKER_WORKER_RPC_H_

#include <chrono>
#include <memory>
#include <string>
#include <string_view>

#include <grpcpp/grpcpp.h>

#include "common/error_reason.h"

namespace impostor::worker_rpc {

inline std::unique_ptr<grpc::ClientContext> ContextWithDeadline(std::chrono::seconds timeout) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + timeout);
  return ctx;
}

// The error reason (common/error_reason.h) the server sent with the
// finished call of `ctx`, as trailing metadata; "" when none.
inline std::string ServerErrorReason(const grpc::ClientContext& ctx) {
  const auto& trailers = ctx.GetServerTrailingMetadata();
  const auto reason = trailers.find(kErrorReasonMetadataKey);
  return reason == trailers.end() ? std::string() : std::string(reason->second.data(), reason->second.size());
}

// A call the server refused because a disk of its own is full: under its
// database (DATABASE_FULL), or under its blob store (STORE_FULL: CompleteJob
// writes the stamped manifest.json). Nothing was recorded, and the same call
// succeeds once space is freed.
inline bool IsServerFull(const grpc::Status& s, std::string_view reason) {
  return s.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED &&
         (reason == error_reason::kDatabaseFull || reason == error_reason::kStoreFull);
}

}  // namespace impostor::worker_rpc

#endif  // IMPOSTOR_WORKER_WORKER_RPC_H_
