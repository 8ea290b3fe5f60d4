#include "worker/output/map_writer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "tests/output/png_stream.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

fs::path Scratch(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("impostor_output_test_" + std::to_string(getpid()));
  fs::create_directories(dir);
  return dir / name;
}

// Removes the scratch directory after each test.
class MapWriterTest : public ::testing::Test {
 protected:
  void TearDown() override { fs::remove_all(Scratch("").parent_path()); }
};

std::string Bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST_F(MapWriterTest, Rgba8RoundTripKeepsColourUnderZeroAlpha) {
  const int w = 37, h = 11;
  std::vector<uint8_t> pixels(w * h * 4);
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<uint8_t>(i * 31 + 7);
  for (size_t i = 3; i < pixels.size(); i += 16) pixels[i] = 0;  // dilated texels
  const fs::path path = Scratch("albedo.png");
  ASSERT_TRUE(WritePngRgba8(path, pixels, w, h).ok());
  const absl::StatusOr<PngImage> read = ReadPng(path);
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(read->width, w);
  EXPECT_EQ(read->height, h);
  EXPECT_EQ(read->channels, 4);
  EXPECT_EQ(read->bit_depth, 8);
  EXPECT_EQ(read->pixels8, pixels);
  // Same input, same bytes (outputs are content-addressed).
  const std::string first = Bytes(path);
  ASSERT_TRUE(WritePngRgba8(path, pixels, w, h).ok());
  EXPECT_EQ(Bytes(path), first);
}

TEST_F(MapWriterTest, Rgba16RoundTripKeepsFullPrecision) {
  const int w = 19, h = 23;
  std::vector<uint16_t> pixels(w * h * 4);
  for (size_t i = 0; i < pixels.size(); ++i)
    pixels[i] = static_cast<uint16_t>(i * 2654435761u >> 7);
  for (size_t i = 3; i < pixels.size(); i += 12) pixels[i] = 0;
  const fs::path path = Scratch("normal_depth.png");
  ASSERT_TRUE(WritePngRgba16(path, pixels, w, h).ok());
  const absl::StatusOr<PngImage> read = ReadPng(path);
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(read->bit_depth, 16);
  EXPECT_EQ(read->channels, 4);
  EXPECT_EQ(read->pixels16, pixels);
}

TEST_F(MapWriterTest, ErrorsAreStatuses) {
  std::vector<uint8_t> pixels(4 * 4 * 4, 0);
  const absl::Status bad_dir = WritePngRgba8("/nonexistent_dir_xyz/out.png", pixels, 4, 4);
  EXPECT_FALSE(bad_dir.ok());
  EXPECT_FALSE(bad_dir.message().empty());
  EXPECT_EQ(WritePngRgba8(Scratch("x.png"), pixels, 5, 4).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ReadPng(Scratch("does_not_exist.png")).status().code(), absl::StatusCode::kNotFound);
  const fs::path junk = Scratch("junk.png");
  std::ofstream(junk) << "not a png";
  EXPECT_FALSE(ReadPng(junk).ok());
}

// The maps are written at kPngCompressionLevel, not libpng's default 6: the
// zlib stream header of the first IDAT chunk records the level class
// (FLEVEL, RFC 1950: 1 = levels 2..5, 2 = level 6).
TEST_F(MapWriterTest, MapsUseTheFasterCompressionLevel) {
  static_assert(kPngCompressionLevel >= 2 && kPngCompressionLevel <= 5, "FLEVEL 1 below");
  const int w = 64, h = 64;
  std::vector<uint16_t> pixels(w * h * 4);
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<uint16_t>(i * 977);
  const fs::path path = Scratch("normal_depth.png");
  ASSERT_TRUE(WritePngRgba16(path, pixels, w, h).ok());
  const std::string bytes = Bytes(path);
  const size_t idat = bytes.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  ASSERT_GT(bytes.size(), idat + 6);
  const auto cmf = static_cast<uint8_t>(bytes[idat + 4]), flg = static_cast<uint8_t>(bytes[idat + 5]);
  EXPECT_EQ(cmf & 0x0f, 8) << "deflate";
  EXPECT_EQ((cmf * 256 + flg) % 31, 0) << "a zlib header";
  EXPECT_EQ(flg >> 6, 1) << "FLEVEL of zlib levels 2..5";
  const absl::StatusOr<PngImage> read = ReadPng(path);
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(read->pixels16, pixels);
}

// Every row is Up-filtered (kPngRowFilter): the byte before each inflated
// row is the row's filter type, 2 = Up (PNG spec 9.2).
TEST_F(MapWriterTest, EveryRowIsUpFiltered) {
  static_assert(kPngRowFilter == 0x20, "PNG_FILTER_UP");
  const int w = 40, h = 24;
  std::vector<uint16_t> pixels(w * h * 4);
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<uint16_t>(i * 7919);
  const fs::path path = Scratch("up.png");
  ASSERT_TRUE(WritePngRgba16(path, pixels, w, h).ok());
  const std::vector<uint8_t> filters = testing::RowFilterTypes(Bytes(path), static_cast<size_t>(w) * 8, h);
  ASSERT_EQ(filters.size(), static_cast<size_t>(h)) << "the IDAT stream does not inflate to the rows";
  for (int y = 0; y < h; ++y) EXPECT_EQ(filters[y], 2) << "row " << y;
  const absl::StatusOr<PngImage> read = ReadPng(path);
  ASSERT_TRUE(read.ok()) << read.status();
  EXPECT_EQ(read->pixels16, pixels);
}

}  // namespace
}  // namespace impostor
