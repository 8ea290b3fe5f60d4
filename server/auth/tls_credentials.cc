#include "server/auth/tls_credentials.h"

#include <chrono>

#include <grpcpp/security/tls_certificate_provider.h>
#include <grpcpp/security/tls_credentials_options.h>
#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/net/tls_files.h"
#include "server/auth/loopback_host.h"

namespace impostor {
namespace {

int64_t NowUnixSeconds() {
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// sockaddr_un's sun_path holds this many bytes and a terminating NUL.
constexpr size_t kMaxSocketPathBytes = 107;

}  // namespace

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
  absl::StatusOr<std::string> cert = ReadServableCertificate(o);
  if (!cert.ok()) return cert.status();
  return CheckNotExpired("--tls-cert", o.cert_file, *cert, NowUnixSeconds());
}

absl::StatusOr<std::string> ReadServableCertificate(const ServerTlsOptions& o) {
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
  return cert;
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

void LogServerTls(const ServerTlsOptions& o, const std::string& listen_host) {
  if (!o.enabled()) {
    if (!IsLoopbackHost(listen_host)) {
      spdlog::warn("event=plaintext_listener host={} note=\"no TLS: traffic to this port can be read and altered on "
                   "the network; see --tls-cert\"",
                   listen_host);
    }
    return;
  }
  absl::StatusOr<int64_t> not_after = absl::UnknownError("unread");
  if (absl::StatusOr<std::string> pem = ReadCertificateFile("--tls-cert", o.cert_file); pem.ok()) {
    not_after = CertificateNotAfter(*pem);
  }
  spdlog::info("event=tls mode={} cert={} cert_expires=\"{}\" client_ca={} reload_s={}",
               o.client_ca_file.empty() ? "tls" : "mutual", o.cert_file,
               not_after.ok() ? FormatUtc(*not_after) : "?", o.client_ca_file.empty() ? "-" : o.client_ca_file,
               o.reload_seconds);
  if (!not_after.ok()) return;
  if (const int64_t days_left = (*not_after - NowUnixSeconds()) / 86400; days_left < 30) {
    spdlog::warn("event=tls_cert_expiring_soon cert={} days_left={}", o.cert_file, days_left);
  }
}

absl::StatusOr<std::string> PrepareLocalWorkerSocket(const std::filesystem::path& data) {
  const std::filesystem::path run_dir = data / "run";
  std::error_code ec;
  std::filesystem::create_directories(run_dir, ec);
  if (!ec) std::filesystem::permissions(run_dir, std::filesystem::perms::owner_all, ec);
  if (ec) {
    return absl::InvalidArgumentError(
        absl::StrCat("--data: cannot make ", run_dir.string(), " private for the local workers' socket: ", ec.message()));
  }
  std::string socket = (run_dir / "local-workers.sock").string();
  if (socket.size() > kMaxSocketPathBytes) {
    return absl::InvalidArgumentError(absl::StrCat("--data: ", socket, " is longer than a Unix socket path may be (",
                                                   kMaxSocketPathBytes,
                                                   " bytes); use a shorter --data with --tls-cert and --local-workers"));
  }
  return socket;
}

}  // namespace impostor
