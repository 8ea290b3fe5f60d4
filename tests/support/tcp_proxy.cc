#include "tests/support/tcp_proxy.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <stdexcept>

namespace impostor::testing {
namespace {

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

TcpProxy::TcpProxy(std::string upstream) : upstream_(std::move(upstream)) {
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr = Loopback(0);
  if (listen_fd_ < 0 || ::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      ::listen(listen_fd_, 64) != 0) {
    throw std::runtime_error("TcpProxy: cannot listen on loopback");
  }
  socklen_t len = sizeof(addr);
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  address_ = "127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
  acceptor_ = std::thread([this] { AcceptLoop(); });
}

TcpProxy::~TcpProxy() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  ::shutdown(listen_fd_, SHUT_RDWR);
  acceptor_.join();
  CutAll();
  std::vector<std::thread> pumps;
  {
    std::lock_guard lock(mu_);
    pumps.swap(pumps_);
  }
  for (std::thread& t : pumps) t.join();
  ::close(listen_fd_);
}

void TcpProxy::FreezeAfter(int64_t bytes, Direction direction) { Arm(bytes, direction, /*dark=*/false); }

void TcpProxy::GoDarkAfter(int64_t bytes, Direction direction) { Arm(bytes, direction, /*dark=*/true); }

void TcpProxy::Arm(int64_t bytes, Direction direction, bool dark) {
  std::lock_guard lock(mu_);
  freeze_budget_ = bytes;
  freeze_direction_ = direction;
  frozen_ = false;
  go_dark_ = dark;
}

bool TcpProxy::WaitFrozen(std::chrono::seconds timeout) {
  std::unique_lock lock(mu_);
  return changed_.wait_for(lock, timeout, [&] { return frozen_; });
}

void TcpProxy::CutAll() {
  std::lock_guard lock(mu_);
  for (int fd : fds_) ::shutdown(fd, SHUT_RDWR);
  fds_.clear();
  freeze_budget_ = -1;
  frozen_ = false;
  go_dark_ = false;
  dark_ = false;
  ++generation_;
  changed_.notify_all();
}

void TcpProxy::AcceptLoop() {
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
      // Upstream is down: the client sees its connection closed at once.
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
    pumps_.emplace_back([this, client, server, connection] { Pump(client, server, Direction::kToServer); });
    pumps_.emplace_back([this, client, server, connection] { Pump(server, client, Direction::kToClient); });
  }
}

int64_t TcpProxy::bytes_forwarded(Direction direction) {
  std::lock_guard lock(mu_);
  return direction == Direction::kToServer ? forwarded_to_server_ : forwarded_to_client_;
}

void TcpProxy::Pump(int from, int to, Direction direction) {
  char buffer[16384];
  while (true) {
    ssize_t n = ::recv(from, buffer, sizeof(buffer), 0);
    if (n <= 0) {
      // A dark link carries no close either: the other side keeps waiting
      // until CutAll.
      std::unique_lock lock(mu_);
      const uint64_t generation = generation_;
      if (dark_) changed_.wait(lock, [&] { return generation_ != generation || stopping_; });
      break;
    }
    {
      std::unique_lock lock(mu_);
      if (dark_) continue;  // dropped
      if (freeze_budget_ >= 0 && freeze_direction_ == direction) {
        const int64_t allowed = std::min<int64_t>(n, freeze_budget_);
        freeze_budget_ -= allowed;
        if (freeze_budget_ == 0) {
          lock.unlock();
          if (allowed > 0 && !WriteAll(to, buffer, static_cast<size_t>(allowed))) break;
          lock.lock();
          (direction == Direction::kToServer ? forwarded_to_server_ : forwarded_to_client_) += allowed;
          if (go_dark_) {
            // The rest of this read, and everything after it, is dropped.
            dark_ = true;
            frozen_ = true;
            changed_.notify_all();
            continue;
          }
          // Hold the rest (and everything after it) until CutAll.
          frozen_ = true;
          changed_.notify_all();
          const uint64_t generation = generation_;
          changed_.wait(lock, [&] { return generation_ != generation || stopping_; });
          break;
        }
      }
    }
    if (!WriteAll(to, buffer, static_cast<size_t>(n))) break;
    std::lock_guard lock(mu_);
    (direction == Direction::kToServer ? forwarded_to_server_ : forwarded_to_client_) += n;
  }
  ::shutdown(from, SHUT_RDWR);
  ::shutdown(to, SHUT_RDWR);
}

}  // namespace impostor::testing
