// Sends "authorization: Bearer <token>" on every call of a channel
// (issue 14), so the worker's many call sites (lease, progress, blob
// downloads and uploads, complete) need not each remember it.
#ifndef IMPOSTOR_WORKER_BEARER_TOKEN_H_
#define IMPOSTOR_WORKER_BEARER_TOKEN_H_

#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>
#include <grpcpp/support/client_interceptor.h>

namespace impostor {

// A factory whose interceptors add the token ("" = add nothing).
std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface> BearerTokenInterceptor(std::string token);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BEARER_TOKEN_H_
