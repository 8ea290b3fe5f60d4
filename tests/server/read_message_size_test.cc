// ReadBlob's message size (server/rpc/read_message_size.h): 64 KiB until a
// stream has moved 1 MiB fast, 256 KiB then, and 64 KiB for good once a
// write was slow; a slow link never grows it.
#include "server/rpc/read_message_size.h"

#include <gtest/gtest.h>

namespace impostor {
namespace {

constexpr size_t kSmall = ReadMessageSize::kSmallBytes;
constexpr size_t kLarge = ReadMessageSize::kLargeBytes;

TEST(ReadMessageSize, GrowsOnlyAfterAFastMebibyte) {
  ReadMessageSize size;
  EXPECT_EQ(size.limit(), kSmall);
  // 15 messages of 64 KiB in 1 ms each: fast, but under 1 MiB.
  double t = 0;
  for (int i = 0; i < 15; ++i) {
    t += 0.001;
    size.Sent(kSmall, 0.001, t);
    EXPECT_EQ(size.limit(), kSmall) << "after " << i + 1 << " messages";
  }
  t += 0.001;
  size.Sent(kSmall, 0.001, t);  // the 16th: 1 MiB in 16 ms, 65 MB/s
  EXPECT_EQ(size.limit(), kLarge);
}

TEST(ReadMessageSize, ASlowLinkStaysSmall) {
  // 12 KB/s: each 64 KiB message takes ~5 s to hand over once the window
  // is full; the first few go at once into the window.
  ReadMessageSize size;
  double t = 0;
  for (int i = 0; i < 4; ++i) size.Sent(kSmall, 0.0001, t += 0.0001);
  for (int i = 0; i < 40; ++i) {
    t += 5.4;
    size.Sent(kSmall, 5.4, t);
    EXPECT_EQ(size.limit(), kSmall);
  }
}

TEST(ReadMessageSize, AMebibyteAtUnder16MBPerSecondStaysSmall) {
  ReadMessageSize size;
  double t = 0;
  for (int i = 0; i < 64; ++i) {  // 4 MiB at 10 MB/s, every write quick
    t += 65536.0 / 10e6;
    size.Sent(kSmall, 0.001, t);
  }
  EXPECT_EQ(size.limit(), kSmall);
}

TEST(ReadMessageSize, ASlowWriteShrinksItForTheRestOfTheStream) {
  ReadMessageSize size;
  double t = 0;
  for (int i = 0; i < 16; ++i) size.Sent(kSmall, 0.0005, t += 0.0005);
  ASSERT_EQ(size.limit(), kLarge);
  size.Sent(kLarge, 0.2, t += 0.2);  // the link slowed
  EXPECT_EQ(size.limit(), kSmall);
  for (int i = 0; i < 100; ++i) size.Sent(kSmall, 0.0005, t += 0.0005);  // fast again
  EXPECT_EQ(size.limit(), kSmall);
}

}  // namespace
}  // namespace impostor
