#include "common/net/connect_error.h"

#include "absl/strings/str_cat.h"

namespace impostor {

ConnectFailure ExplainConnectError(std::string_view grpc_message, bool uses_tls,
                                   const std::function<std::string()>& diagnose_certificate) {
  const std::string last(grpc_message);
  const auto has = [&last](std::string_view text) { return last.find(text) != std::string::npos; };
  if (uses_tls) {
    if (has("certificate verify failed")) {
      if (const std::string why = diagnose_certificate ? diagnose_certificate() : ""; !why.empty()) {
        return {absl::StrCat("TLS handshake failed: ", why, " (", last, ")")};
      }
      return {absl::StrCat("TLS handshake failed: the server's certificate is not signed by the CA given "
                           "(--tls-ca / tls_ca_file) (", last, ")")};
    }
    if (has("No match found for server name") || has("Peer name")) {
      return {absl::StrCat("TLS handshake failed: the server's certificate does not carry the name dialled; give "
                           "the name it carries with --tls-server-name / tls_server_name (", last, ")")};
    }
    if (has("wrong version number") || has("packet length too long") || has("http request")) {
      return {absl::StrCat("TLS handshake failed: the server does not speak TLS; connect without --tls-ca (", last,
                           ")")};
    }
    if (has("Handshake") || has("handshake") || has("SSL") || has("certificate") || has("Socket closed")) {
      return {absl::StrCat("TLS handshake failed: the server ended it (a server run with --tls-client-ca needs a "
                           "client certificate it trusts: --tls-cert/--tls-key; or the server's own certificate "
                           "files are unusable: its log says event=tls_files_refused) (", last, ")")};
    }
  }
  if (has("DNS resolution failed") || has("Domain name not found") || has("name resolution")) {
    return {absl::StrCat("the host name does not resolve (", last, ")")};
  }
  if (has("Connection refused")) return {"connection refused; is impostor-server running there?"};
  if (has("Failed parsing HTTP/2") || has("http1") || has("HTTP/1")) {
    return {absl::StrCat("something answers on that port, but it is not a gRPC server; is it impostor-server's "
                         "port? (", last, ")")};
  }
  if (has("before receiving SETTINGS") || has("Deadline Exceeded") || has("timed out")) {
    return {absl::StrCat("a connection was accepted but no gRPC server answered on it (a stopped or overloaded "
                         "server, or another program on that port) (", last, ")"),
            /*silent=*/true};
  }
  if (has("Socket closed") || has("Connection reset") || has("connection closed") || has("EOF")) {
    return {absl::StrCat("the server closed the connection; if it serves TLS, connect with its CA "
                         "(--tls-ca / tls_ca_file) (", last, ")")};
  }
  return {absl::StrCat("cannot connect (", last.empty() ? std::string("no reason given") : last, ")")};
}

}  // namespace impostor
