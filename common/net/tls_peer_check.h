// Why a TLS server's certificate fails verification, in words. gRPC reports
// every verification failure as "certificate verify failed", whether the
// certificate expired, is not valid yet, comes from another CA or does not
// carry the name dialled; the fixes differ (renew it on the server, fix a
// clock, give the right --tls-ca, --tls-server-name). This makes one TLS
// handshake of its own with OpenSSL, trusting only `ca_pem`, and reads
// OpenSSL's verification result.
//
// Thread-safe; blocks for at most about `timeout_seconds`.
#ifndef IMPOSTOR_COMMON_NET_TLS_PEER_CHECK_H_
#define IMPOSTOR_COMMON_NET_TLS_PEER_CHECK_H_

#include <string>

namespace impostor {

// `address` is HOST:PORT or [IPV6]:PORT (anything else: ""); `server_name`
// the name the certificate must carry ('' = HOST). Returns a sentence such
// as "the server's certificate expired on 2026-11-22 14:26:11 UTC; renew it
// on the server", or "" when the certificate verifies or the check cannot
// tell (no connection, no certificate).
std::string DiagnoseServerCertificate(const std::string& address, const std::string& ca_pem,
                                      const std::string& server_name, double timeout_seconds);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_TLS_PEER_CHECK_H_
