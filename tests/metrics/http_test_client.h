// Test helpers for the server's HTTP side (--http-listen): the port the
// server announced and a small GET client (bearer token, cookie).
#ifndef IMPOSTOR_TESTS_METRICS_HTTP_TEST_CLIENT_H_
#define IMPOSTOR_TESTS_METRICS_HTTP_TEST_CLIENT_H_

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <httplib.h>

#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor::testing {

// A plain TCP connection to 127.0.0.1:`port` (for bytes no HTTP client
// would send); -1 when it cannot connect.
inline int ConnectTo(int port) {
  const int sock = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (sock < 0) return -1;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(sock, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(sock);
    return -1;
  }
  return sock;
}

// The HTTP port the server printed after its gRPC line; 0 after failing the
// test when there is none.
inline int HttpPort(ServerProcess& server) {
  const std::string line = server.process().ReadLineContaining("http listening on");
  EXPECT_FALSE(line.empty()) << "no \"http listening on\" line";
  return line.empty() ? 0 : std::stoi(line.substr(line.rfind(':') + 1));
}

// GETs from 127.0.0.1:`port`, 30 s read timeout.
struct HttpTestClient {
  explicit HttpTestClient(int port) : client("127.0.0.1", port) { client.set_read_timeout(30, 0); }
  // GET with "Authorization: Bearer <token>" ("" = none) and a Cookie header
  // ("" = none).
  httplib::Result Get(const std::string& path, const std::string& token = "", const std::string& cookie = "") {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
    if (!cookie.empty()) headers.emplace("Cookie", cookie);
    return client.Get(path.c_str(), headers);
  }
  // The response's status, -1 when none came.
  int Status(const std::string& path, const std::string& token = "") {
    auto res = Get(path, token);
    return res ? res->status : -1;
  }
  httplib::Client client;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_METRICS_HTTP_TEST_CLIENT_H_
