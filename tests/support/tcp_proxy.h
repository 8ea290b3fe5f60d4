// A loopback TCP proxy for tests that need a client stopped at a known point
// of a transfer: it forwards every connection to `upstream`, can freeze one
// direction once a given number of bytes has passed in it, or go dark as a
// pulled cable would, then cut every connection (as a killed server's
// kernel would). While upstream is down, a new connection is accepted and
// closed at once.
//
// Thread-safety: every method may be called from any thread. Each accepted
// connection gets two forwarding threads; the destructor cuts and joins
// them.
#ifndef IMPOSTOR_TESTS_SUPPORT_TCP_PROXY_H_
#define IMPOSTOR_TESTS_SUPPORT_TCP_PROXY_H_

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace impostor::testing {

class TcpProxy {
 public:
  // Listens on 127.0.0.1:<kernel's choice> and forwards to `upstream`
  // ("127.0.0.1:PORT").
  explicit TcpProxy(std::string upstream);
  ~TcpProxy();
  TcpProxy(const TcpProxy&) = delete;
  TcpProxy& operator=(const TcpProxy&) = delete;

  // "127.0.0.1:PORT" to give clients.
  const std::string& address() const { return address_; }

  enum class Direction { kToClient, kToServer };

  // Once `bytes` more bytes have gone in `direction` (over all
  // connections), stop forwarding in that direction until CutAll.
  void FreezeAfter(int64_t bytes, Direction direction);
  // Once `bytes` more bytes have gone in `direction`, the link goes dark
  // until CutAll, as behind a pulled cable: every byte in either direction,
  // on every connection (new ones too), is read and dropped, and neither
  // side hears of the other's close. Unlike FreezeAfter, nobody's send
  // buffer fills up, so neither kernel gives up on the connection by
  // itself: only the endpoints' own keepalives notice. WaitFrozen waits
  // for it too.
  void GoDarkAfter(int64_t bytes, Direction direction);
  // Waits until the freeze is in effect; false if `timeout` passes first.
  bool WaitFrozen(std::chrono::seconds timeout);
  // Closes every current connection (both sides) and lifts the freeze; new
  // connections are forwarded again.
  void CutAll();
  // Bytes forwarded so far in `direction`, over all connections (TCP
  // payload: HTTP/2 and gRPC framing included).
  int64_t bytes_forwarded(Direction direction);

 private:
  void Arm(int64_t bytes, Direction direction, bool dark);
  void AcceptLoop();
  void Pump(int from, int to, Direction direction);

  std::string upstream_;
  std::string address_;
  int listen_fd_ = -1;
  std::thread acceptor_;

  std::mutex mu_;
  std::condition_variable changed_;
  bool stopping_ = false;
  int64_t freeze_budget_ = -1;  // bytes still allowed; < 0: no freeze
  Direction freeze_direction_ = Direction::kToClient;
  bool frozen_ = false;
  bool go_dark_ = false;  // the pending freeze is a GoDarkAfter
  bool dark_ = false;     // dropping everything until CutAll
  uint64_t generation_ = 0;     // bumped by CutAll; frozen pumps wait for it
  int64_t forwarded_to_server_ = 0;
  int64_t forwarded_to_client_ = 0;
  std::vector<int> fds_;        // open sockets of current connections
  std::vector<std::thread> pumps_;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_TCP_PROXY_H_
