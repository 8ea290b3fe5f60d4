#include "common/net/transfer_window.h"

#include <grpc/grpc.h>
#include <grpcpp/support/channel_arguments.h>

namespace impostor {

void ApplyClientTransferWindow(grpc::ChannelArguments& args) {
  // Without BDP probing the stream window is the lookahead, from the first
  // byte on (chttp2's flow control targets it instead of the estimate).
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, kStreamReceiveWindowBytes);
}

}  // namespace impostor
