#include "server/tls_credentials.h"

#include <grpcpp/security/tls_certificate_provider.h>
#include <grpcpp/security/tls_credentials_options.h>

#include "absl/strings/str_cat.h"
#include "common/tls_files.h"

namespace impostor {

absl::Status ValidateServerTls(const ServerTlsOptions& o) {
  if (o.reload_seconds < 1 || o.reload_seconds > 3600) {
    return absl::InvalidArgumentError(
        absl::StrCat("--tls-reload-seconds: ", o.reload_seconds, " is out of range 1..3600"));
  }
  if (o.cert_file.empty()) {
    if (!o.key_file.empty()) return absl::InvalidArgumentError("--tls-key: needs --tls-cert too");
    if (!o.client_ca_file.empty()) {
      return absl::InvalidArgumentError("--tls-client-ca: needs --tls-cert and --tls-key (mutual TLS is TLS)");
    }
    return absl::OkStatus();
  }
  if (o.key_file.empty()) return absl::InvalidArgumentError("--tls-cert: needs --tls-key too");
  absl::StatusOr<std::string> cert = ReadCertificateFile("--tls-cert", o.cert_file);
  if (!cert.ok()) return cert.status();
  absl::StatusOr<std::string> key = ReadPrivateKeyFile("--tls-key", o.key_file);
  if (!key.ok()) return key.status();
  if (absl::Status s = CheckKeyMatchesCertificate("--tls-cert", *cert, "--tls-key", *key); !s.ok()) return s;
  if (!o.client_ca_file.empty()) {
    if (absl::StatusOr<std::string> ca = ReadCertificateFile("--tls-client-ca", o.client_ca_file); !ca.ok()) {
      return ca.status();
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> MakeServerCredentials(const ServerTlsOptions& o) {
  if (absl::Status s = ValidateServerTls(o); !s.ok()) return s;
  if (!o.enabled()) return grpc::InsecureServerCredentials();
  // The provider watches all three files; the credentials keep it alive.
  auto provider = std::make_shared<grpc::experimental::FileWatcherCertificateProvider>(
      o.key_file, o.cert_file, o.client_ca_file, static_cast<unsigned>(o.reload_seconds));
  grpc::experimental::TlsServerCredentialsOptions options(provider);
  options.watch_identity_key_cert_pairs();
  if (o.client_ca_file.empty()) {
    options.set_cert_request_type(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  } else {
    options.watch_root_certs();
    options.set_cert_request_type(GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
  }
  return grpc::experimental::TlsServerCredentials(options);
}

}  // namespace impostor
