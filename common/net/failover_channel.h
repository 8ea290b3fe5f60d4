// One logical connection to a farm whose head node runs as several
// replicas: a gRPC channel per address of a server list (server_list.h),
// and which of them calls go to now.
//
// Why channels of our own rather than one gRPC channel over all addresses:
// gRPC's comma lists (ipv4:a,b) take IP literals of one family only, and its
// DNS resolver takes one name; host names, mixed families and a TLS name
// per address need a channel each. Each channel still uses pick_first, so
// one entry that is a DNS name with several records fails over inside gRPC.
//
// Calls stick to the current address while it answers. A call that fails
// with UNAVAILABLE (refused, reset, the replica was killed) moves every
// later call on to the next address. With several addresses a
// DEADLINE_EXCEEDED does too, and the channel that timed out is replaced by
// a fresh one: a connection into a cut network link looks READY to gRPC
// until keepalive gives up, minutes later, and a new channel has to connect
// again (each channel has its own subchannel pool, so a fresh one never
// inherits the dead connection).
//
// Thread-safety: every method may be called from any thread; Current()
// hands out shared channel pointers, so a replaced channel lives on until
// the calls using it finish.
#ifndef IMPOSTOR_COMMON_NET_FAILOVER_CHANNEL_H_
#define IMPOSTOR_COMMON_NET_FAILOVER_CHANNEL_H_

#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "absl/base/thread_annotations.h"

namespace impostor {

class FailoverChannel {
 public:
  // Makes the channel for one target (credentials, arguments, interceptors
  // are the caller's business). Called at construction for each target and
  // again when a channel is replaced. Should set
  // GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL to 1 (see the file comment).
  using MakeChannel = std::function<std::shared_ptr<grpc::Channel>(const std::string& target)>;

  // How a move to the next address is logged ("event=server_failover"):
  // info for the worker's log, debug inside the SDK (a game's log).
  enum class LogMoves { kDebug, kInfo };

  // `targets`: at least one (ParseServerList's answer).
  FailoverChannel(std::vector<std::string> targets, MakeChannel make, LogMoves log_moves = LogMoves::kDebug);

  // Where a call goes: the address's position and its channel.
  struct Route {
    size_t index = 0;
    std::shared_ptr<grpc::Channel> channel;
  };
  Route Current() const;

  // A call made on `route` answered (any code but UNAVAILABLE, or a stream
  // message): every address counts as untried again.
  void NoteAnswer(const Route& route);

  // A call made on `route` failed with `code`. UNAVAILABLE, and
  // DEADLINE_EXCEEDED when there are several addresses, mark the address as
  // failed and move calls on to the next one, unless another call already
  // has. Returns true when the current address has not failed since the last
  // answer: the caller may try again at once, without backoff. Other codes
  // change nothing and return false.
  bool NoteFailure(const Route& route, grpc::StatusCode code);

  size_t size() const { return targets_.size(); }
  const std::string& target(size_t index) const { return targets_[index]; }

 private:
  const std::vector<std::string> targets_;
  const MakeChannel make_;
  const LogMoves log_moves_;
  mutable std::mutex mu_;
  std::vector<std::shared_ptr<grpc::Channel>> channels_ ABSL_GUARDED_BY(mu_);
  size_t current_ ABSL_GUARDED_BY(mu_) = 0;
  // Addresses that failed since the last answer.
  std::vector<bool> failed_ ABSL_GUARDED_BY(mu_);
};

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_FAILOVER_CHANNEL_H_
