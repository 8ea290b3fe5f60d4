// gRPC channel credentials for a client's TLS settings (the `impostor` CLI,
// impostor-worker, the SDK and the cache all dial through this): plaintext
// when no CA is given; TLS trusting only the given CA (not the system's
// roots: a farm's certificates come from the studio's own CA) otherwise,
// presenting a client certificate for mutual TLS when one is given.
//
// The files are read once, here: a client that must pick up a renewed
// client certificate reconnects (for impostor-worker: a restart).
// Thread-safe.
#ifndef IMPOSTOR_COMMON_NET_TLS_CHANNEL_H_
#define IMPOSTOR_COMMON_NET_TLS_CHANNEL_H_

#include <memory>
#include <string>

#include <grpcpp/security/credentials.h>
#include <grpcpp/support/channel_arguments.h>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "common/net/tls_files.h"

namespace impostor {

struct ClientTls {
  TlsFilePaths files;
  // The name the server's certificate must carry when it differs from the
  // host in the dial address (e.g. dialling 10.0.0.5:50051 for a
  // certificate issued to bake.studio.lan). Empty = the dial address's host.
  std::string server_name;
};

struct ClientTlsNames {
  TlsFileNames files;
  absl::string_view server_name;
};

// Credentials for `tls` (see the file comment); sets the server-name
// override on `args` when tls.server_name is given. INVALID_ARGUMENT naming
// the field at fault (see ReadClientTlsFiles; a server name without a CA too).
absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> MakeChannelCredentials(const ClientTls& tls,
                                                                                 const ClientTlsNames& names,
                                                                                 grpc::ChannelArguments* args);

// True when `tls` asks for TLS (a CA is given).
inline bool UsesTls(const ClientTls& tls) { return !tls.files.ca.empty(); }

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_TLS_CHANNEL_H_
