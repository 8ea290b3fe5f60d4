#include "common/net/tls_peer_check.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <ctime>
#include <memory>

#include "absl/strings/str_cat.h"
#include "common/net/tls_files.h"

namespace impostor {
namespace {

using Clock = std::chrono::steady_clock;

bool SplitHostPort(const std::string& address, std::string* host, std::string* port) {
  if (!address.empty() && address.front() == '[') {
    const size_t close = address.find(']');
    if (close == std::string::npos || close + 1 >= address.size() || address[close + 1] != ':') return false;
    *host = address.substr(1, close - 1);
    *port = address.substr(close + 2);
  } else {
    const size_t colon = address.rfind(':');
    if (colon == std::string::npos) return false;
    *host = address.substr(0, colon);
    *port = address.substr(colon + 1);
    if (host->find(':') != std::string::npos) return false;
  }
  return !host->empty() && !port->empty() &&
         std::all_of(port->begin(), port->end(), [](unsigned char c) { return std::isdigit(c) != 0; });
}

// A connected, blocking socket whose reads and writes time out at
// `deadline`; -1 when none could be made in time.
int ConnectBefore(const std::string& host, const std::string& port, Clock::time_point deadline) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (::getaddrinfo(host.c_str(), port.c_str(), &hints, &found) != 0) return -1;
  std::unique_ptr<addrinfo, decltype(&::freeaddrinfo)> addresses(found, &::freeaddrinfo);
  for (addrinfo* a = found; a != nullptr; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, a->ai_protocol);
    if (fd < 0) continue;
    bool connected = ::connect(fd, a->ai_addr, a->ai_addrlen) == 0;
    if (!connected && errno == EINPROGRESS) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      pollfd p{fd, POLLOUT, 0};
      int error = 0;
      socklen_t len = sizeof(error);
      connected = left > 0 && ::poll(&p, 1, static_cast<int>(left)) == 1 &&
                  ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &error, &len) == 0 && error == 0;
    }
    const auto left_us = std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now()).count();
    if (connected && left_us > 0) {
      ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
      const timeval tv{static_cast<time_t>(left_us / 1'000'000), static_cast<suseconds_t>(left_us % 1'000'000)};
      ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
      ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof(tv));
      return fd;
    }
    ::close(fd);
  }
  return -1;
}

bool IsIpAddress(const std::string& host) {
  unsigned char buf[sizeof(in6_addr)];
  return ::inet_pton(AF_INET, host.c_str(), buf) == 1 || ::inet_pton(AF_INET6, host.c_str(), buf) == 1;
}

std::string TimeOf(const ASN1_TIME* t) {
  std::tm tm{};
  if (t == nullptr || ASN1_TIME_to_tm(t, &tm) != 1) return "?";
  return FormatUtc(static_cast<int64_t>(::timegm(&tm)));
}

std::string IssuerOf(X509* cert) {
  std::unique_ptr<BIO, decltype(&BIO_free)> bio(BIO_new(BIO_s_mem()), &BIO_free);
  if (bio == nullptr || X509_NAME_print_ex(bio.get(), X509_get_issuer_name(cert), 0, XN_FLAG_RFC2253) < 0) return "?";
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  return std::string(data, static_cast<size_t>(std::max(0L, std::min(n, 200L))));
}

std::string Explain(long result, X509* peer, const std::string& name) {
  switch (result) {
    case X509_V_OK: return "";
    case X509_V_ERR_CERT_HAS_EXPIRED:
      return absl::StrCat("the server's certificate expired on ", TimeOf(X509_get0_notAfter(peer)),
                          "; it must be renewed on the server (--tls-cert, --tls-key)");
    case X509_V_ERR_CERT_NOT_YET_VALID:
      return absl::StrCat("the server's certificate is not valid until ", TimeOf(X509_get0_notBefore(peer)),
                          "; is this machine's clock (or the server's) right?");
    case X509_V_ERR_HOSTNAME_MISMATCH:
    case X509_V_ERR_IP_ADDRESS_MISMATCH:
      return absl::StrCat("the server's certificate does not carry the name ", name,
                          "; give the name it carries with --tls-server-name / tls_server_name");
    case X509_V_ERR_INVALID_PURPOSE:
      return "the server's certificate is not one for servers (its extendedKeyUsage lacks serverAuth)";
    case X509_V_ERR_UNABLE_TO_GET_ISSUER_CERT_LOCALLY:
    case X509_V_ERR_UNABLE_TO_GET_ISSUER_CERT:
    case X509_V_ERR_DEPTH_ZERO_SELF_SIGNED_CERT:
    case X509_V_ERR_SELF_SIGNED_CERT_IN_CHAIN:
    case X509_V_ERR_UNABLE_TO_VERIFY_LEAF_SIGNATURE:
    case X509_V_ERR_CERT_SIGNATURE_FAILURE:
      return absl::StrCat("the server's certificate (issuer ", IssuerOf(peer),
                          ") is not signed by the CA given (--tls-ca / tls_ca_file)");
    default:
      return absl::StrCat("the server's certificate does not verify: ", X509_verify_cert_error_string(result));
  }
}

}  // namespace

std::string DiagnoseServerCertificate(const std::string& address, const std::string& ca_pem,
                                      const std::string& server_name, double timeout_seconds) {
  std::string host, port;
  if (!SplitHostPort(address, &host, &port)) return "";
  const auto deadline = Clock::now() + std::chrono::microseconds(static_cast<int64_t>(timeout_seconds * 1e6));
  const int fd = ConnectBefore(host, port, deadline);
  if (fd < 0) return "";

  std::unique_ptr<SSL_CTX, decltype(&SSL_CTX_free)> ctx(SSL_CTX_new(TLS_client_method()), &SSL_CTX_free);
  std::string out;
  if (ctx != nullptr) {
    X509_STORE* store = SSL_CTX_get_cert_store(ctx.get());
    std::unique_ptr<BIO, decltype(&BIO_free)> bio(BIO_new_mem_buf(ca_pem.data(), static_cast<int>(ca_pem.size())),
                                                  &BIO_free);
    while (X509* ca = PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr)) {
      X509_STORE_add_cert(store, ca);
      X509_free(ca);
    }
    // Verification runs and its result is kept; the handshake goes on, so
    // the result can be read.
    SSL_CTX_set_verify(ctx.get(), SSL_VERIFY_NONE, nullptr);
    static const unsigned char kAlpnH2[] = {2, 'h', '2'};  // gRPC servers insist on HTTP/2
    SSL_CTX_set_alpn_protos(ctx.get(), kAlpnH2, sizeof(kAlpnH2));
    std::unique_ptr<SSL, decltype(&SSL_free)> ssl(SSL_new(ctx.get()), &SSL_free);
    if (ssl != nullptr && SSL_set_fd(ssl.get(), fd) == 1) {
      const std::string name = server_name.empty() ? host : server_name;
      X509_VERIFY_PARAM* param = SSL_get0_param(ssl.get());
      if (IsIpAddress(name)) {
        X509_VERIFY_PARAM_set1_ip_asc(param, name.c_str());
      } else {
        SSL_set_tlsext_host_name(ssl.get(), name.c_str());
        X509_VERIFY_PARAM_set1_host(param, name.c_str(), 0);
      }
      (void)SSL_connect(ssl.get());
      if (X509* peer = SSL_get1_peer_certificate(ssl.get())) {
        out = Explain(SSL_get_verify_result(ssl.get()), peer, name);
        X509_free(peer);
      }
    }
  }
  ERR_clear_error();
  ::close(fd);
  return out;
}

}  // namespace impostor
