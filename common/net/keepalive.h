// HTTP/2 keepalive between the farm's clients and servers (issue 15): how a
// long, quiet call (a WatchJob while a bake waits in the queue) notices a
// link that died without a reset (a pulled cable, a replica's host cut off,
// a NAT that dropped the flow), so the call fails over to another replica
// in seconds instead of after TCP's retransmission timeout (~15 min).
//
// The client pings while it has calls in flight: every `seconds` of quiet,
// and gives up on the connection when no answer comes within
// min(seconds, 10) s. It does not ping an idle channel (a game's SDK
// client between fetches stays silent); a new call on a dead connection is
// caught by the same pings once it is in flight.
//
// The server pings every connection quiet for its own --keepalive-seconds
// (dropping a dead client's calls), and accepts client pings as often as
// once a second; gRPC's default (one every 5 min) would answer a client's
// 20 s pings with GOAWAY "too_many_pings". A server older than this policy
// does that; gRPC then doubles the client's interval on its own.
#ifndef IMPOSTOR_COMMON_NET_KEEPALIVE_H_
#define IMPOSTOR_COMMON_NET_KEEPALIVE_H_

#include <string_view>

#include "absl/status/status.h"

namespace grpc {
class ChannelArguments;
class ServerBuilder;
}  // namespace grpc

namespace impostor {

inline constexpr int kDefaultKeepaliveSeconds = 20;
inline constexpr int kMinKeepaliveSeconds = 1;
inline constexpr int kMaxKeepaliveSeconds = 7200;

// INVALID_ARGUMENT naming `field` and the range unless seconds is in
// kMinKeepaliveSeconds..kMaxKeepaliveSeconds.
absl::Status ValidateKeepaliveSeconds(std::string_view field, int seconds);

// How long a ping may go unanswered before the connection is given up.
int KeepaliveTimeoutSeconds(int keepalive_seconds);

// The client side of the policy above, on a channel's arguments.
void ApplyClientKeepalive(int keepalive_seconds, grpc::ChannelArguments& args);

// The server side of the policy above.
void ApplyServerKeepalive(int keepalive_seconds, grpc::ServerBuilder& builder);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_KEEPALIVE_H_
