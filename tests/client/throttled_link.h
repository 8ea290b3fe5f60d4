// A loopback TCP proxy whose way towards the server carries at most a set
// number of bytes per second, and the way back any amount: the slow uplink
// of a studio that uploads to a farm across the internet.
//
// The proxy takes what the client sends at once and queues it, as a deep
// router queue does, so the client's kernel hands over a blob of a few
// MiB before its first byte reaches the server: the worst case of a real
// uplink, where the sender cannot see its bytes cross. (Reading only at the
// pace instead makes loopback TCP, with its 64 KiB segments, close the
// window for seconds at a time below ~20 KB/s, and the client's kernel
// then aborts the connection after its TCP_USER_TIMEOUT of 10 s, which no
// real link does.)
//
// Thread-safety: every method may be called from any thread. Each accepted
// connection gets three forwarding threads; the destructor closes and joins
// them.
#ifndef IMPOSTOR_TESTS_CLIENT_THROTTLED_LINK_H_
#define IMPOSTOR_TESTS_CLIENT_THROTTLED_LINK_H_

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace impostor::testing {

class ThrottledLink {
 public:
  // Listens on 127.0.0.1:<kernel's choice> and forwards to `upstream`
  // ("127.0.0.1:PORT"), at most `bytes_per_second` towards it.
  ThrottledLink(std::string upstream, int64_t bytes_per_second);
  ~ThrottledLink();
  ThrottledLink(const ThrottledLink&) = delete;
  ThrottledLink& operator=(const ThrottledLink&) = delete;

  // "127.0.0.1:PORT" to give clients.
  const std::string& address() const { return address_; }

  // Bytes forwarded towards the server so far, over all connections.
  int64_t bytes_to_server() const { return bytes_to_server_.load(); }

 private:
  // What one connection's client has sent and the link not carried yet.
  struct LinkQueue {
    std::mutex mu;
    std::condition_variable changed;
    std::deque<std::string> chunks;  // guarded by mu
    bool closed = false;             // guarded by mu: the client's side ended
  };

  void AcceptLoop();
  // Forwards `from` to `to` as fast as they go (the way back).
  void Pump(int from, int to);
  // Queues what `from` sends, at once, until it ends.
  void Receive(int from, LinkQueue& queue);
  // Sends the queue on to `to`, at most bytes_per_second_.
  void Send(LinkQueue& queue, int to);

  const std::string upstream_;
  const int64_t bytes_per_second_;
  std::string address_;
  int listen_fd_ = -1;
  std::thread acceptor_;
  std::atomic<int64_t> bytes_to_server_{0};

  std::mutex mu_;
  bool stopping_ = false;      // guarded by mu_
  std::vector<int> fds_;       // guarded by mu_: sockets of open connections
  std::vector<std::thread> pumps_;  // guarded by mu_
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_CLIENT_THROTTLED_LINK_H_
