// Why a gRPC client could not reach an impostor server, as a sentence that
// names the fix, from gRPC's own message for the failed call ("failed to
// connect to all addresses; last error: ..."). Shared by the SDK's Connect
// (client/transport/transport.cc) and impostor-worker's lease loop, so a technical
// artist and an IT admin read the same explanation for the same fault.
#ifndef IMPOSTOR_COMMON_NET_CONNECT_ERROR_H_
#define IMPOSTOR_COMMON_NET_CONNECT_ERROR_H_

#include <functional>
#include <string>
#include <string_view>

namespace impostor {

struct ConnectFailure {
  std::string sentence;  // ends with gRPC's message in parentheses
  // A TCP connection was accepted but no HTTP/2 greeting came (a stopped or
  // overloaded server): worth waiting out; the rest are not.
  bool silent = false;
};

// `uses_tls`: the client dials with TLS. `diagnose_certificate` (may be
// empty) says why the server's certificate does not verify, or ""
// (tls_peer_check.h); it is called only for "certificate verify failed".
ConnectFailure ExplainConnectError(std::string_view grpc_message, bool uses_tls,
                                   const std::function<std::string()>& diagnose_certificate);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_CONNECT_ERROR_H_
