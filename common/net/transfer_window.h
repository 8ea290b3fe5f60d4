// The HTTP/2 receive window of the farm's client channels (issue 45): a
// fixed 8 MiB stream lookahead instead of gRPC's BDP probing, which starts
// each connection at 64 KiB and grows the window while the transfer runs.
//
// Why: a CLI fetch is a short-lived process on a new connection, so the
// ramp is much of its life, and once the probed window has grown each read
// takes megabytes into freshly allocated buffers (recvmsg returned up to
// 4 MB with probing, at most 64 KiB without). `impostor fetch` of the
// quickstart's DamagedHelmet result (39 files, 26.4 MB) from a local farm,
// medians of 15 alternated runs: 0.183 s wall / 0.149 s CPU with probing,
// 0.164 s / 0.110 s without (page faults 3,967 -> 1,393). 8 MiB keeps a
// 100 ms link at ~670 Mbit/s per stream, more than a farm's clients reach
// over a WAN; the sender stops at the window, so a slow reader holds at
// most that much in flight per stream.
#ifndef IMPOSTOR_COMMON_NET_TRANSFER_WINDOW_H_
#define IMPOSTOR_COMMON_NET_TRANSFER_WINDOW_H_

namespace grpc {
class ChannelArguments;
}  // namespace grpc

namespace impostor {

inline constexpr int kStreamReceiveWindowBytes = 8 << 20;

// Sets the fixed window (and turns BDP probing off) on a client channel's
// arguments.
void ApplyClientTransferWindow(grpc::ChannelArguments& args);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_TRANSFER_WINDOW_H_
