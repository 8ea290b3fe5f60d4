#include "server/http/bounded_http_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>

namespace impostor {
namespace {

// Waits up to sec + usec for `events` on `sock`; true when ready.
bool WaitFor(socket_t sock, short events, time_t sec, time_t usec) {
  pollfd p{.fd = sock, .events = events, .revents = 0};
  const int timeout_ms = static_cast<int>(sec * 1000 + usec / 1000);
  int r;
  do {
    r = ::poll(&p, 1, timeout_ms);
  } while (r < 0 && errno == EINTR);
  return r > 0 && (p.revents & (events | POLLHUP | POLLERR)) != 0;
}

void AddressOf(const sockaddr_storage& addr, std::string& ip, int& port) {
  char text[INET6_ADDRSTRLEN] = {0};
  if (addr.ss_family == AF_INET) {
    const auto* in = reinterpret_cast<const sockaddr_in*>(&addr);
    ::inet_ntop(AF_INET, &in->sin_addr, text, sizeof text);
    port = ntohs(in->sin_port);
  } else if (addr.ss_family == AF_INET6) {
    const auto* in6 = reinterpret_cast<const sockaddr_in6*>(&addr);
    ::inet_ntop(AF_INET6, &in6->sin6_addr, text, sizeof text);
    port = ntohs(in6->sin6_port);
  }
  ip = text;
}

// A connected socket as httplib::Stream (the library's SocketStream is not
// in its public header), reading at most `budget` bytes until Renew().
//
// Reads are buffered, as the library's own stream's are: its line reader
// asks for one byte at a time, which unbuffered cost a poll and a recv per
// byte of every request's head (~250 of each for a curl GET with a token).
// The budget counts the bytes handed to the library, so bytes of a next
// (pipelined) request that arrived with this one are charged to that one.
class BoundedSocketStream final : public httplib::Stream {
 public:
  BoundedSocketStream(socket_t sock, time_t read_sec, time_t read_usec, time_t write_sec, time_t write_usec)
      : sock_(sock), read_sec_(read_sec), read_usec_(read_usec), write_sec_(write_sec), write_usec_(write_usec) {}

  // A new request starts: its own budget.
  void Renew() { left_ = BoundedHttpServer::kMaxRequestBytes; }
  // Bytes received and not yet read.
  size_t buffered() const { return end_ - begin_; }

  bool is_readable() const override { return buffered() > 0 || WaitFor(sock_, POLLIN, read_sec_, read_usec_); }
  bool is_writable() const override { return WaitFor(sock_, POLLOUT, write_sec_, write_usec_); }

  ssize_t read(char* ptr, size_t size) override {
    if (left_ == 0) return -1;  // the request is over its size: the library ends the connection
    size = std::min(size, left_);
    if (buffered() == 0) {
      if (!WaitFor(sock_, POLLIN, read_sec_, read_usec_)) return -1;
      // A read as large as the buffer goes straight to the caller.
      const bool direct = size >= sizeof buffer_;
      ssize_t n;
      do {
        n = ::recv(sock_, direct ? ptr : buffer_, direct ? size : sizeof buffer_, 0);
      } while (n < 0 && errno == EINTR);
      if (n <= 0) return n;
      if (direct) {
        left_ -= static_cast<size_t>(n);
        return n;
      }
      begin_ = 0;
      end_ = static_cast<size_t>(n);
    }
    const size_t n = std::min(size, buffered());
    std::memcpy(ptr, buffer_ + begin_, n);
    begin_ += n;
    left_ -= n;
    return static_cast<ssize_t>(n);
  }

  ssize_t write(const char* ptr, size_t size) override {
    if (!is_writable()) return -1;
    ssize_t n;
    do {
      n = ::send(sock_, ptr, size, MSG_NOSIGNAL);
    } while (n < 0 && errno == EINTR);
    return n;
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    if (::getpeername(sock_, reinterpret_cast<sockaddr*>(&addr), &len) == 0) AddressOf(addr, ip, port);
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    if (::getsockname(sock_, reinterpret_cast<sockaddr*>(&addr), &len) == 0) AddressOf(addr, ip, port);
  }
  socket_t socket() const override { return sock_; }

 private:
  const socket_t sock_;
  const time_t read_sec_, read_usec_, write_sec_, write_usec_;
  size_t left_ = BoundedHttpServer::kMaxRequestBytes;
  char buffer_[4096];  // the library's own stream reads 4 KiB at a time too
  size_t begin_ = 0, end_ = 0;
};

}  // namespace

BoundedHttpServer::BoundedHttpServer() { set_payload_max_length(kMaxBodyBytes); }

// The library's keep-alive loop (detail::process_server_socket_core), over
// the bounded stream.
bool BoundedHttpServer::process_and_close_socket(socket_t sock) {
  BoundedSocketStream stream(sock, read_timeout_sec_, read_timeout_usec_, write_timeout_sec_, write_timeout_usec_);
  bool ok = false;
  for (size_t left = keep_alive_max_count_; left > 0 && svr_sock_ != INVALID_SOCKET; --left) {
    // A next request that came with the last one is read at once.
    if (stream.buffered() == 0 && !WaitFor(sock, POLLIN, keep_alive_timeout_sec_, 0)) break;
    stream.Renew();
    bool connection_closed = false;
    ok = process_request(stream, /*close_connection=*/left == 1, connection_closed, nullptr);
    if (!ok || connection_closed) break;
  }
  ::shutdown(sock, SHUT_RDWR);
  ::close(sock);
  return ok;
}

}  // namespace impostor
