#include "common/net/keepalive.h"

#include <algorithm>
#include <string>

#include <grpc/grpc.h>
#include <grpcpp/server_builder.h>
#include <grpcpp/support/channel_arguments.h>

#include "absl/strings/str_cat.h"

namespace impostor {

absl::Status ValidateKeepaliveSeconds(std::string_view field, int seconds) {
  if (seconds < kMinKeepaliveSeconds || seconds > kMaxKeepaliveSeconds) {
    return absl::InvalidArgumentError(absl::StrCat(std::string(field), ": ", seconds, " is out of range ",
                                                   kMinKeepaliveSeconds, "..", kMaxKeepaliveSeconds, " (seconds)"));
  }
  return absl::OkStatus();
}

int KeepaliveTimeoutSeconds(int keepalive_seconds) { return std::clamp(keepalive_seconds, 1, 10); }

void ApplyClientKeepalive(int keepalive_seconds, grpc::ChannelArguments& args) {
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, keepalive_seconds * 1000);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, KeepaliveTimeoutSeconds(keepalive_seconds) * 1000);
  args.SetInt(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 0);
  // gRPC stops pinging after two pings with no data frame in between unless
  // this is 0; a quiet watch sends none, so it would go unwatched again.
  args.SetInt(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
}

void ApplyServerKeepalive(int keepalive_seconds, grpc::ServerBuilder& builder) {
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, keepalive_seconds * 1000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, KeepaliveTimeoutSeconds(keepalive_seconds) * 1000);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  // Accept client pings as often as once a second, with or without calls
  // (a ping a second per connection costs nothing worth refusing).
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, 1000);
}

}  // namespace impostor
