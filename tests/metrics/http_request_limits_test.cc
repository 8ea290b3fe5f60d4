// The HTTP side bounds every request (server/http/bounded_http_server.h):
// a request line without an end, sent by anyone who can reach the port, is
// cut off after a few hundred kilobytes instead of growing the server until
// it dies, and a request body over the API's largest is refused with 413
// before it is read; requests pipelined on one connection are each
// answered.
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"
#include "tests/metrics/http_test_client.h"

namespace impostor {
namespace {

using testing::ConnectTo;
using testing::HttpPort;
using testing::HttpTestClient;
using testing::ServerProcess;

TEST(HttpRequestLimits, ARequestLineWithoutEndIsCutOffAndTheServerLives) {
  ServerProcess server(/*local_workers=*/0, {"--http-listen=127.0.0.1:0"});
  const int port = HttpPort(server);
  const int sock = ConnectTo(port);
  ASSERT_GE(sock, 0);
  const std::string chunk(64 * 1024, 'A');
  ASSERT_EQ(::send(sock, "GET /", 5, MSG_NOSIGNAL), 5);
  // The server reads at most 256 KiB of one request; the socket buffers take
  // a few megabytes more before the reset reaches this side.
  constexpr size_t kOffered = size_t{64} << 20;
  size_t sent = 0;
  while (sent < kOffered) {
    const ssize_t n = ::send(sock, chunk.data(), chunk.size(), MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += static_cast<size_t>(n);
  }
  ::close(sock);
  EXPECT_LT(sent, size_t{16} << 20) << "the server kept reading an endless request line";
  HttpTestClient http(port);
  EXPECT_EQ(http.Status("/healthz"), 200);
  EXPECT_TRUE(server.process().Running()) << server.process().Stderr();
}

TEST(HttpRequestLimits, ABodyOverTheLimitIsRefusedWith413) {
  ServerProcess server(/*local_workers=*/0, {"--http-listen=127.0.0.1:0"});
  HttpTestClient http(HttpPort(server));
  const std::string body = "token=" + std::string(1 << 20, 'x');
  // Not form-encoded: the library caps only those bodies (8 KiB) by itself.
  auto res = http.client.Post("/login", body, "text/plain");
  ASSERT_TRUE(res) << "no answer";
  EXPECT_EQ(res->status, 413);
  EXPECT_EQ(http.Status("/healthz"), 200);
}

// The server reads a connection 4 KiB at a time (bounded_http_server.cc):
// a request that arrived together with the one before it is already in the
// server's buffer, not in the socket, and must be answered all the same,
// not left waiting for bytes that will never come. And a connection serves
// more than cpp-httplib's default of 5 requests (http_frontend.cc).
TEST(HttpRequestLimits, PipelinedRequestsOnOneConnectionAreEachAnswered) {
  ServerProcess server(/*local_workers=*/0, {"--http-listen=127.0.0.1:0"});
  const int sock = ConnectTo(HttpPort(server));
  ASSERT_GE(sock, 0);
  timeval timeout{.tv_sec = 30, .tv_usec = 0};  // a missing answer fails the test, never hangs it
  ASSERT_EQ(::setsockopt(sock, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout), 0);
  const std::string one = "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  constexpr size_t kRequests = 12;
  std::string requests;
  for (size_t i = 1; i < kRequests; ++i) requests += one;
  requests += "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  ASSERT_EQ(::send(sock, requests.data(), requests.size(), MSG_NOSIGNAL), static_cast<ssize_t>(requests.size()));
  std::string answers;
  char buf[4096];
  while (true) {
    const ssize_t n = ::recv(sock, buf, sizeof buf, 0);
    if (n <= 0) {
      EXPECT_EQ(n, 0) << "recv: " << std::strerror(errno);
      break;
    }
    answers.append(buf, static_cast<size_t>(n));
  }
  ::close(sock);
  size_t ok = 0;
  for (size_t at = answers.find("HTTP/1.1 200"); at != std::string::npos; at = answers.find("HTTP/1.1 200", at + 1)) {
    ++ok;
  }
  EXPECT_EQ(ok, kRequests) << answers;
}

}  // namespace
}  // namespace impostor
