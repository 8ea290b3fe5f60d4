#include "tests/client/throttled_link.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>

namespace impostor::testing {
namespace {

using Clock = std::chrono::steady_clock;

// The pace is kept in slices of this long: smooth enough for a watchdog
// that counts seconds.
constexpr auto kSlice = std::chrono::milliseconds(20);

sockaddr_in Loopback(int port) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = htons(static_cast<uint16_t>(port));
  return addr;
}

bool WriteAll(int fd, const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::send(fd, data, size, MSG_NOSIGNAL);
    if (n <= 0) return false;
    data += n;
    size -= static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

ThrottledLink::ThrottledLink(std::string upstream, int64_t bytes_per_second)
    : upstream_(std::move(upstream)), bytes_per_second_(bytes_per_second) {
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr = Loopback(0);
  if (listen_fd_ < 0 || ::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      ::listen(listen_fd_, 64) != 0) {
    throw std::runtime_error("ThrottledLink: cannot listen on loopback");
  }
  socklen_t len = sizeof(addr);
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  address_ = "127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
  acceptor_ = std::thread([this] { AcceptLoop(); });
}

ThrottledLink::~ThrottledLink() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  ::shutdown(listen_fd_, SHUT_RDWR);
  acceptor_.join();
  std::vector<std::thread> pumps;
  {
    std::lock_guard lock(mu_);
    for (int fd : fds_) ::shutdown(fd, SHUT_RDWR);
    pumps.swap(pumps_);
  }
  for (std::thread& t : pumps) t.join();
  ::close(listen_fd_);
}

void ThrottledLink::AcceptLoop() {
  const int upstream_port = std::atoi(upstream_.substr(upstream_.rfind(':') + 1).c_str());
  while (true) {
    const int client = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0) {
      std::lock_guard lock(mu_);
      if (stopping_) return;
      continue;
    }
    const int server = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr = Loopback(upstream_port);
    if (server < 0 || ::connect(server, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
      if (server >= 0) ::close(server);
      ::close(client);
      continue;
    }
    const int one = 1;
    ::setsockopt(client, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    ::setsockopt(server, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    std::lock_guard lock(mu_);
    if (stopping_) {
      ::close(client);
      ::close(server);
      return;
    }
    fds_.push_back(client);
    fds_.push_back(server);
    // The connection's sockets are closed when both of its pumps are done.
    auto connection = std::shared_ptr<void>(nullptr, [this, client, server](void*) {
      {
        std::lock_guard lock(mu_);
        fds_.erase(std::remove_if(fds_.begin(), fds_.end(), [&](int fd) { return fd == client || fd == server; }),
                   fds_.end());
      }
      ::close(client);
      ::close(server);
    });
    auto queue = std::make_shared<LinkQueue>();
    pumps_.emplace_back([this, client, queue, connection] { Receive(client, *queue); });
    pumps_.emplace_back([this, server, queue, connection] { Send(*queue, server); });
    pumps_.emplace_back([this, client, server, connection] { Pump(server, client); });
  }
}

void ThrottledLink::Pump(int from, int to) {
  char buffer[16384];
  while (true) {
    const ssize_t n = ::recv(from, buffer, sizeof(buffer), 0);
    if (n <= 0 || !WriteAll(to, buffer, static_cast<size_t>(n))) break;
  }
  ::shutdown(from, SHUT_RDWR);
  ::shutdown(to, SHUT_RDWR);
}

void ThrottledLink::Receive(int from, LinkQueue& queue) {
  char buffer[16384];
  while (true) {
    const ssize_t n = ::recv(from, buffer, sizeof(buffer), 0);
    std::lock_guard lock(queue.mu);
    if (n <= 0) {
      queue.closed = true;
      queue.changed.notify_all();
      return;
    }
    queue.chunks.emplace_back(buffer, static_cast<size_t>(n));
    queue.changed.notify_all();
  }
}

void ThrottledLink::Send(LinkQueue& queue, int to) {
  // What one slice may carry, at least one byte.
  const size_t slice_bytes = static_cast<size_t>(std::max<int64_t>(
      1, bytes_per_second_ * std::chrono::duration_cast<std::chrono::microseconds>(kSlice).count() / 1'000'000));
  Clock::time_point link_free = Clock::now();  // when the link has carried what was sent so far
  while (true) {
    std::string chunk;
    {
      std::unique_lock lock(queue.mu);
      queue.changed.wait(lock, [&] { return !queue.chunks.empty() || queue.closed; });
      if (queue.chunks.empty()) break;  // closed and carried
      chunk = std::move(queue.chunks.front());
      queue.chunks.pop_front();
    }
    bool ok = true;
    for (size_t at = 0; ok && at < chunk.size(); at += slice_bytes) {
      const size_t n = std::min(slice_bytes, chunk.size() - at);
      // The bytes leave once the link has carried the earlier ones: the
      // pace of a slow link, which is what this proxy is for.
      link_free = std::max(link_free, Clock::now()) +
                  std::chrono::duration_cast<Clock::duration>(
                      std::chrono::duration<double>(static_cast<double>(n) / static_cast<double>(bytes_per_second_)));
      std::this_thread::sleep_until(link_free);
      ok = WriteAll(to, chunk.data() + at, n);
      if (ok) bytes_to_server_ += static_cast<int64_t>(n);
    }
    if (!ok) break;
  }
  ::shutdown(to, SHUT_RDWR);
}

}  // namespace impostor::testing
