// The banded PNG encoder (worker/output/png_encoder.h): whatever the bands
// and threads, libpng (through ReadPng) decodes exactly the pixels written,
// the bytes do not depend on the thread count, cutting into bands costs
// almost no size, and bad sizes are refused.
#include "worker/output/png_encoder.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "worker/output/map_writer.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

class PngEncoderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("png_encoder_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes `png` and decodes it with libpng.
  PngImage Decode(const std::string& png, const std::string& name) {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << png;
    absl::StatusOr<PngImage> read = ReadPng(path);
    EXPECT_TRUE(read.ok()) << read.status();
    return read.ok() ? *read : PngImage{};
  }

  fs::path dir_;
};

// Smooth with some noise, as a baked map: compressible, not constant.
std::vector<uint16_t> Map16(int w, int h) {
  std::vector<uint16_t> p(static_cast<size_t>(w) * h * 4);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 4; ++c) {
        const double v = 0.5 + 0.45 * std::sin(0.05 * x * (c + 1) + 0.031 * y);
        p[(static_cast<size_t>(y) * w + x) * 4 + c] = static_cast<uint16_t>(v * 65535.0) ^ ((x * 7 + y * 13) & 3);
      }
    }
  }
  return p;
}

std::vector<uint8_t> Map8(int w, int h) {
  std::vector<uint8_t> p(static_cast<size_t>(w) * h * 4);
  for (size_t i = 0; i < p.size(); ++i) p[i] = static_cast<uint8_t>((i * 2654435761u) >> 13 & 0x0f) + (i / 4 % 97);
  return p;
}

TEST_F(PngEncoderTest, EveryBandingDecodesToTheSamePixels) {
  for (const auto& [w, h] : {std::pair{1, 1}, {3, 5}, {37, 64}, {130, 300}}) {
    const std::vector<uint16_t> p16 = Map16(w, h);
    const std::vector<uint8_t> p8 = Map8(w, h);
    // One row a band, a few rows a band (the dictionary then spans several
    // bands' rows), and the whole image in one band.
    for (const size_t band_bytes : {size_t{1}, size_t{4096}, size_t{1} << 30}) {
      for (const int threads : {1, 3}) {
        const PngEncodeOptions options{.threads = threads, .band_bytes = band_bytes};
        const absl::StatusOr<std::string> png16 = EncodePngRgba16(p16, w, h, options);
        const absl::StatusOr<std::string> png8 = EncodePngRgba8(p8, w, h, options);
        ASSERT_TRUE(png16.ok() && png8.ok()) << png16.status() << png8.status();
        const PngImage d16 = Decode(*png16, "a16.png");
        EXPECT_EQ(d16.bit_depth, 16);
        EXPECT_EQ(d16.pixels16, p16) << w << "x" << h << " bands of " << band_bytes << " bytes, " << threads << " threads";
        const PngImage d8 = Decode(*png8, "a8.png");
        EXPECT_EQ(d8.bit_depth, 8);
        EXPECT_EQ(d8.pixels8, p8) << w << "x" << h << " bands of " << band_bytes << " bytes, " << threads << " threads";
      }
    }
  }
}

TEST_F(PngEncoderTest, BytesDoNotDependOnTheThreadCount) {
  const std::vector<uint16_t> p = Map16(256, 256);
  const absl::StatusOr<std::string> one = EncodePngRgba16(p, 256, 256, {.threads = 1, .band_bytes = 20000});
  const absl::StatusOr<std::string> five = EncodePngRgba16(p, 256, 256, {.threads = 5, .band_bytes = 20000});
  ASSERT_TRUE(one.ok() && five.ok());
  EXPECT_EQ(*one, *five);
}

// Each band's compressor starts from the rows before it, so a cut loses
// almost nothing: 26 bands of a 512 px 16-bit map within 1% of one band.
TEST_F(PngEncoderTest, BandsCostAlmostNoSize) {
  const int w = 512, h = 512;
  const std::vector<uint16_t> p = Map16(w, h);
  const absl::StatusOr<std::string> whole = EncodePngRgba16(p, w, h, {.threads = 1, .band_bytes = size_t{1} << 30});
  const absl::StatusOr<std::string> banded = EncodePngRgba16(p, w, h, {.threads = 2, .band_bytes = 80000});
  ASSERT_TRUE(whole.ok() && banded.ok());
  EXPECT_LT(static_cast<double>(banded->size()), 1.01 * static_cast<double>(whole->size()))
      << banded->size() << " bytes banded, " << whole->size() << " in one band";
  EXPECT_LT(whole->size(), p.size() * 2) << "the test map should compress";
}

// Rows that repeat every second row but are noise within a row: only the
// rows before a band can compress its first rows. With one row a band, each
// band compresses to a back-reference into its dictionary; without the
// dictionary every band would be stored almost raw.
TEST_F(PngEncoderTest, EachBandSeesTheRowsBeforeIt) {
  const int w = 256, h = 64;
  std::vector<uint8_t> p(static_cast<size_t>(w) * h * 4);
  uint32_t state = 12345;
  for (size_t i = 0; i < static_cast<size_t>(w) * 4 * 2; ++i) {
    state = state * 1664525u + 1013904223u;
    p[i] = static_cast<uint8_t>(state >> 24);
  }
  for (size_t i = static_cast<size_t>(w) * 4 * 2; i < p.size(); ++i) p[i] = p[i - static_cast<size_t>(w) * 4 * 2];
  const absl::StatusOr<std::string> banded = EncodePngRgba8(p, w, h, {.threads = 2, .band_bytes = 1});
  ASSERT_TRUE(banded.ok());
  EXPECT_LT(banded->size(), p.size() / 8) << banded->size() << " bytes for " << p.size() << " bytes of pixels";
  EXPECT_EQ(Decode(*banded, "repeat.png").pixels8, p);
}

TEST_F(PngEncoderTest, BadSizesAreInvalidArguments) {
  const std::vector<uint8_t> p(4 * 4 * 4, 0);
  EXPECT_EQ(EncodePngRgba8(p, 5, 4).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodePngRgba8(p, 0, 16).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodePngRgba8(p, 16, -1).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EncodePngRgba8({}, 1, 1).status().code(), absl::StatusCode::kInvalidArgument);
  // width * height * 4 wraps around to the given count.
  const int side = 1 << 30;
  const std::vector<uint8_t> none;
  EXPECT_EQ(EncodePngRgba8(none, side, side).status().code(), absl::StatusCode::kInvalidArgument);
  const absl::StatusOr<std::string> message = EncodePngRgba16(std::vector<uint16_t>(12), 2, 2);
  EXPECT_NE(message.status().message().find("12 values as a 2x2 RGBA image"), std::string::npos) << message.status();
}

}  // namespace
}  // namespace impostor
