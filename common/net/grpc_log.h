// Sends gRPC's own log lines (e.g. "Handshake failed with fatal error ...
// certificate verify failed" for every refused TLS connection) through
// spdlog as one escaped line per event, instead of gRPC's separate format
// on stderr: errors as warnings ("event=grpc_log ..."), the rest at debug.
// Call once, early in main.
#ifndef IMPOSTOR_COMMON_NET_GRPC_LOG_H_
#define IMPOSTOR_COMMON_NET_GRPC_LOG_H_

namespace impostor {

void RouteGrpcLogsToSpdlog();

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_GRPC_LOG_H_
