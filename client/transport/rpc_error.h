// Building and reading the Status of a failed RPC. The RPC's name, the server
// address and the server's own message travel as Status payloads so that
// callers (the CLI) can tell RPC failures from local ones without parsing
// text. No gRPC types here: transport.cc converts grpc::Status first.
#ifndef IMPOSTOR_CLIENT_TRANSPORT_RPC_ERROR_H_
#define IMPOSTOR_CLIENT_TRANSPORT_RPC_ERROR_H_

#include <string>
#include <string_view>

#include "absl/status/status.h"

namespace impostor::sdk {

// A Status with `code` and the message "<rpc> (server <server>): <message>",
// carrying RpcErrorInfo as payloads. `reason`: the server's error reason
// (common/error_reason.h), "" for none.
absl::Status MakeRpcError(absl::StatusCode code, std::string_view rpc, std::string_view server,
                          std::string_view server_message, std::string_view reason = {});

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_RPC_ERROR_H_
