// How large ReadBlob's next message may be, from how fast the stream has
// taken the ones before.
//
// Why two sizes: 64 KiB is what the slow-link promises rest on (a 12 KB/s
// link loses at most one ~5 s message at a cut, and the client's stall
// watchdog, which sees whole messages only, sees one every ~5 s:
// docs/explanation/promises.md); on a fast link 256 KiB messages cost less
// per byte (the gRPC fetch of a 26 MB result ~15 % faster on loopback, on
// two cores: docs/explanation/figures.md, 2026-12-05). So a stream starts
// at 64 KiB and grows to 256 KiB only once it has moved 1 MiB at 16 MB/s
// or more, which no slow link does; a write that then takes longer than
// 50 ms to hand over (the link slowed) shrinks it back for the rest of the
// stream.
#ifndef IMPOSTOR_SERVER_RPC_READ_MESSAGE_SIZE_H_
#define IMPOSTOR_SERVER_RPC_READ_MESSAGE_SIZE_H_

#include <cstddef>
#include <cstdint>

namespace impostor {

class ReadMessageSize {
 public:
  static constexpr size_t kSmallBytes = size_t{64} << 10;
  static constexpr size_t kLargeBytes = size_t{256} << 10;
  static constexpr int64_t kFastAfterBytes = int64_t{1} << 20;
  static constexpr double kFastBytesPerSecond = 16e6;
  static constexpr double kSlowWriteSeconds = 0.05;

  size_t limit() const { return large_ ? kLargeBytes : kSmallBytes; }

  // A message of `bytes` was handed over in `write_seconds`, `elapsed_seconds`
  // after the stream's first message began.
  void Sent(size_t bytes, double write_seconds, double elapsed_seconds) {
    sent_ += static_cast<int64_t>(bytes);
    if (write_seconds > kSlowWriteSeconds) {
      large_ = false;
      slowed_ = true;
      return;
    }
    if (!slowed_ && sent_ >= kFastAfterBytes && elapsed_seconds > 0 &&
        static_cast<double>(sent_) / elapsed_seconds >= kFastBytesPerSecond) {
      large_ = true;
    }
  }

 private:
  int64_t sent_ = 0;
  bool large_ = false;
  bool slowed_ = false;  // once slow, small for the rest of the stream
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_READ_MESSAGE_SIZE_H_
