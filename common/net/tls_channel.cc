#include "common/net/tls_channel.h"

#include <utility>

#include "absl/strings/str_cat.h"

namespace impostor {

absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> MakeChannelCredentials(const ClientTls& tls,
                                                                                 const ClientTlsNames& names,
                                                                                 grpc::ChannelArguments* args) {
  const TlsFilePaths& f = tls.files;
  if (f.ca.empty() && f.cert.empty() && f.key.empty()) {
    if (!tls.server_name.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat(names.server_name, ": needs ", names.files.ca, " (a server name only matters with TLS)"));
    }
    return grpc::InsecureChannelCredentials();
  }
  absl::StatusOr<ClientTlsPem> pem = ReadClientTlsFiles(f, names.files);
  if (!pem.ok()) return pem.status();
  grpc::SslCredentialsOptions options;
  options.pem_root_certs = std::move(pem->ca);
  options.pem_cert_chain = std::move(pem->cert);
  options.pem_private_key = std::move(pem->key);
  if (!tls.server_name.empty()) args->SetSslTargetNameOverride(tls.server_name);
  return grpc::SslCredentials(options);
}

}  // namespace impostor
