// The server listener's credentials: plaintext, TLS, or mutual TLS, from the
// --tls-cert, --tls-key and --tls-client-ca flags.
//
// With TLS the files are watched (gRPC's FileWatcherCertificateProvider
// re-reads them every `reload_seconds`), so a renewed certificate, key or
// client CA is served to new connections without a restart; connections
// already open keep the certificate they were made with. A renewal must
// replace the key and the certificate together (see README "Securing a
// farm: TLS"); while the pair does not match, every new handshake fails
// (gRPC takes what it reads; tls_file_monitor.h logs it).
//
// Thread-safety: plain functions; the returned credentials are used by
// gRPC's threads.
#ifndef IMPOSTOR_SERVER_AUTH_TLS_CREDENTIALS_H_
#define IMPOSTOR_SERVER_AUTH_TLS_CREDENTIALS_H_

#include <filesystem>
#include <memory>
#include <string>

#include <grpcpp/security/server_credentials.h>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor {

struct ServerTlsOptions {
  // --tls-cert: the server's certificate chain (PEM, leaf first). Empty =
  // plaintext (then key and client_ca must be empty too).
  std::string cert_file;
  // --tls-key: the private key of cert_file (PEM, unencrypted).
  std::string key_file;
  // --tls-client-ca: CA bundle (PEM) that client certificates must chain
  // to; set = mutual TLS: a client without such a certificate is refused in
  // the handshake.
  std::string client_ca_file;
  // --tls-reload-seconds: how often the files are checked for changes.
  // Range 1..3600.
  int reload_seconds = 5;

  bool enabled() const { return !cert_file.empty(); }
};

// OK when the flags form a usable combination and the files are readable
// PEM of the right kind, the key matching the certificate.
// INVALID_ARGUMENT naming the flag at fault otherwise.
absl::Status ValidateServerTls(const ServerTlsOptions& options);

// The file checks of ValidateServerTls without the expiry check, i.e. what
// gRPC's reload takes: readable PEM of the right kind, the key matching the
// certificate, a readable client CA when one is set. The certificate's PEM,
// or INVALID_ARGUMENT naming the flag and the file.
absl::StatusOr<std::string> ReadServableCertificate(const ServerTlsOptions& options);

// Insecure credentials when TLS is off; otherwise watched TLS credentials
// as described above. Runs ValidateServerTls first (same errors).
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> MakeServerCredentials(const ServerTlsOptions& options);

// Logs the TLS settings once at start ("event=tls mode=tls|mutual cert=...
// cert_expires=..."), and "event=tls_cert_expiring_soon" when the
// certificate has fewer than 30 days left: an expired certificate is the
// usual way a TLS service stops. Without TLS on a `listen_host` other than
// loopback (or a Unix socket), warns "event=plaintext_listener": anyone
// who can reach the port reads and writes in the clear.
void LogServerTls(const ServerTlsOptions& options, const std::string& listen_host);

// With TLS, --local-workers dial the server through a Unix socket,
// <data>/run/local-workers.sock, in a directory only the server's user may
// enter (made here, mode 0700), instead of the TLS port: they need no
// certificate (under mutual TLS they would need one the server cannot
// issue), and no other user of the host can reach the socket. Returns the
// socket's path; INVALID_ARGUMENT naming --data when the directory cannot
// be made private or the path is too long for a socket (107 bytes).
absl::StatusOr<std::string> PrepareLocalWorkerSocket(const std::filesystem::path& data);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_AUTH_TLS_CREDENTIALS_H_
