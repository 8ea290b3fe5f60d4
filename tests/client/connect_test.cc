#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "impostor/client.h"

namespace impostor::sdk {
namespace {

// A localhost port on which nothing listens: bound by the kernel's choice,
// then closed.
int UnusedPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  EXPECT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  socklen_t len = sizeof(addr);
  EXPECT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  ::close(fd);
  return ntohs(addr.sin_port);
}

TEST(Connect, NothingListeningIsUnavailableNamingTheAddress) {
  ClientOptions options;
  options.server = "127.0.0.1:" + std::to_string(UnusedPort());
  // A long timeout and an outage budget: Connect must still give up because
  // the connection is refused (its message says so), not wait for either.
  options.connect_timeout_seconds = 600;
  options.max_outage_seconds = 600;
  absl::StatusOr<std::unique_ptr<Client>> client = Client::Connect(options);
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable) << client.status();
  EXPECT_NE(client.status().message().find(options.server), std::string::npos) << client.status();
  EXPECT_NE(client.status().message().find("connection refused"), std::string::npos) << client.status();
  std::optional<RpcErrorInfo> info = GetRpcErrorInfo(client.status());
  ASSERT_TRUE(info.has_value());
  EXPECT_EQ(info->server, options.server);
}

// A loopback TCP listener that is not a gRPC server: it either answers
// every connection as an HTTP/1.1 server would (and closes it) or never
// accepts at all (the kernel still completes the TCP handshake, as for a
// stopped server).
class NotGrpcListener {
 public:
  enum class Mode { kHttp1, kSilent };
  explicit NotGrpcListener(Mode mode) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    EXPECT_GE(fd_, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
    EXPECT_EQ(::listen(fd_, 16), 0);
    socklen_t len = sizeof(addr);
    EXPECT_EQ(::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len), 0);
    port_ = ntohs(addr.sin_port);
    if (mode == Mode::kHttp1) {
      thread_ = std::thread([fd = fd_] {
        // accept() fails once the destructor shuts the socket down.
        for (int c; (c = ::accept(fd, nullptr, nullptr)) >= 0;) {
          static constexpr char kAnswer[] = "HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n";
          (void)!::write(c, kAnswer, sizeof(kAnswer) - 1);
          ::close(c);
        }
      });
    }
  }
  ~NotGrpcListener() {
    ::shutdown(fd_, SHUT_RDWR);
    if (thread_.joinable()) thread_.join();
    ::close(fd_);
  }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }

 private:
  int fd_ = -1;
  int port_ = 0;
  std::thread thread_;
};

TEST(Connect, AnHttp1ServerIsNamedAsNotGrpcAtOnce) {
  NotGrpcListener http(NotGrpcListener::Mode::kHttp1);
  ClientOptions options;
  options.server = http.address();
  options.connect_timeout_seconds = 600;  // must not be waited out
  absl::StatusOr<std::unique_ptr<Client>> client = Client::Connect(options);
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable) << client.status();
  EXPECT_NE(client.status().message().find("not a gRPC server"), std::string::npos) << client.status();
  EXPECT_EQ(client.status().message().find("refused"), std::string::npos) << client.status();
}

TEST(Connect, AServerThatAcceptsButNeverAnswersIsNotCalledRefused) {
  NotGrpcListener silent(NotGrpcListener::Mode::kSilent);
  ClientOptions options;
  options.server = silent.address();
  options.connect_timeout_seconds = 3;
  absl::StatusOr<std::unique_ptr<Client>> client = Client::Connect(options);
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable) << client.status();
  EXPECT_EQ(client.status().message().find("refused"), std::string::npos) << client.status();
  EXPECT_TRUE(client.status().message().find("no gRPC server answered") != std::string::npos ||
              client.status().message().find("no impostor server answered within 3 s") != std::string::npos)
      << client.status();
}

TEST(Connect, AHostNameThatDoesNotResolveIsNamedSo) {
  ClientOptions options;
  options.server = "no-such-host.invalid:50051";  // RFC 2606: never resolves
  options.connect_timeout_seconds = 600;
  absl::StatusOr<std::unique_ptr<Client>> client = Client::Connect(options);
  ASSERT_FALSE(client.ok());
  EXPECT_EQ(client.status().code(), absl::StatusCode::kUnavailable) << client.status();
  EXPECT_NE(client.status().message().find("does not resolve"), std::string::npos) << client.status();
}

TEST(Connect, RejectsBadOptions) {
  ClientOptions options;
  options.max_attempts = 0;
  EXPECT_EQ(Client::Connect(options).status().code(), absl::StatusCode::kInvalidArgument);
  options = ClientOptions();
  options.rpc_timeout_seconds = -1;
  EXPECT_EQ(Client::Connect(options).status().code(), absl::StatusCode::kInvalidArgument);
  options = ClientOptions();
  options.server = "";
  EXPECT_EQ(Client::Connect(options).status().code(), absl::StatusCode::kInvalidArgument);
  for (int keepalive : {0, -5, 7201}) {
    options = ClientOptions();
    options.keepalive_seconds = keepalive;
    absl::Status s = Client::Connect(options).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << keepalive;
    EXPECT_NE(s.message().find("ClientOptions.keepalive_seconds: " + std::to_string(keepalive) +
                               " is out of range 1..7200"),
              std::string::npos)
        << s;
  }
  for (double outage : {-1.0, 86401.0, std::nan("")}) {
    options = ClientOptions();
    options.max_outage_seconds = outage;
    absl::Status s = Client::Connect(options).status();
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << outage;
    EXPECT_NE(s.message().find("max_outage_seconds"), std::string::npos) << s;
  }
}

TEST(GetRpcErrorInfo, LocalErrorsHaveNone) {
  EXPECT_FALSE(GetRpcErrorInfo(absl::NotFoundError("model x not found")).has_value());
  EXPECT_FALSE(GetRpcErrorInfo(absl::OkStatus()).has_value());
}

}  // namespace
}  // namespace impostor::sdk
