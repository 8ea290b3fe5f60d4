#include "worker/output/contact_sheet.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/output/png_stream.h"
#include "worker/output/map_writer.h"

namespace impostor {
namespace {

TEST(ContactSheet, PanelsShowTheMapsAndAreLabelled) {
  // A 64x64 atlas whose left half is covered, red, facing +Z, near.
  const int size = 64;
  std::vector<uint8_t> albedo(size * size * 4, 0), orm(size * size * 4, 0);
  std::vector<uint16_t> normal(size * size * 4, 32768);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size / 2; ++x) {
      const size_t i = static_cast<size_t>(y) * size + x;
      albedo[i * 4] = 255;
      albedo[i * 4 + 3] = 255;
      normal[i * 4 + 2] = 65535;
      normal[i * 4 + 3] = 0;
      orm[i * 4 + 1] = 200;
      orm[i * 4 + 3] = 255;
    }
  }
  const auto path = std::filesystem::temp_directory_path() / ("contact_sheet_test_" + std::to_string(::getpid()) + ".png");
  auto info = WriteContactSheet(path, {size, size, albedo, normal, orm, {}}, 32);
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_TRUE(info->labelled) << "no TrueType font found (deploy/install-deps.sh installs fonts-dejavu-core)";
  auto png = ReadPng(path);
  ASSERT_TRUE(png.ok()) << png.status();
  ASSERT_EQ(png->width, info->width);
  ASSERT_EQ(png->height, info->height);
  EXPECT_EQ(png->width, 5 * (32 + 4) + 4);
  auto pixel = [&](int panel, int x, int y, int c) {
    const int px = 4 + panel * 36 + x, py = 22 + y;
    return static_cast<int>(png->pixels8[(static_cast<size_t>(py) * png->width + px) * png->channels + c]);
  };
  // albedo: red where covered, checker grey where not.
  EXPECT_GT(pixel(0, 4, 16, 0), 240);
  EXPECT_LT(pixel(0, 4, 16, 1), 15);
  EXPECT_NEAR(pixel(0, 28, 16, 0), pixel(0, 28, 16, 1), 1);
  // coverage: white / black.
  EXPECT_GT(pixel(1, 4, 16, 0), 250);
  EXPECT_LT(pixel(1, 28, 16, 0), 5);
  // normal +Z: blue.
  EXPECT_GT(pixel(2, 4, 16, 2), 250);
  // depth: near = white.
  EXPECT_GT(pixel(3, 4, 16, 0), 250);
  // ORM roughness 200.
  EXPECT_NEAR(pixel(4, 4, 16, 1), 200, 2);
  // The label band has some bright text pixels above each panel.
  int bright = 0;
  for (int y = 0; y < 22; ++y)
    for (int x = 0; x < png->width; ++x) bright += png->pixels8[(static_cast<size_t>(y) * png->width + x) * png->channels] > 128;
  EXPECT_GT(bright, 20);
  std::filesystem::remove(path);
}

// The sheet is deflated as the maps are (map_writer.h: zlib level 3, the Up
// filter on every row), not at libpng's level 6 with its per-row filter
// search, which made its write the slowest step of a GPU bake's encoding.
TEST(ContactSheet, IsDeflatedLikeTheMaps) {
  static_assert(kPngCompressionLevel == 3 && kPngRowFilter == 0x20, "level 3, PNG_FILTER_UP");
  const int size = 128;
  std::vector<uint8_t> albedo(size * size * 4), orm(size * size * 4);
  std::vector<uint16_t> normal(size * size * 4);
  for (size_t i = 0; i < albedo.size(); ++i) albedo[i] = orm[i] = static_cast<uint8_t>(i * 131 % 251);
  for (size_t i = 0; i < normal.size(); ++i) normal[i] = static_cast<uint16_t>(i * 7919);
  const auto path = std::filesystem::temp_directory_path() / ("contact_sheet_deflate_" + std::to_string(::getpid()) + ".png");
  auto info = WriteContactSheet(path, {size, size, albedo, normal, orm, {}}, 64);
  ASSERT_TRUE(info.ok()) << info.status();
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::filesystem::remove(path);
  const std::string stream = testing::IdatStream(bytes);
  ASSERT_GE(stream.size(), 2u);
  EXPECT_EQ(static_cast<uint8_t>(stream[1]) >> 6, 1) << "FLEVEL of zlib levels 2..5 (libpng's default 6 is 2)";
  const std::vector<uint8_t> filters = testing::RowFilterTypes(bytes, static_cast<size_t>(info->width) * 3, info->height);
  ASSERT_EQ(filters.size(), static_cast<size_t>(info->height)) << "the IDAT stream does not inflate to RGB8 rows";
  for (int y = 0; y < info->height; ++y) EXPECT_EQ(filters[y], 2) << "row " << y;
}

TEST(ContactSheet, BadInputIsRefused) {
  std::vector<uint8_t> a(16 * 16 * 4), o(16 * 16 * 4);
  std::vector<uint16_t> n(16 * 16 * 4);
  const auto path = std::filesystem::temp_directory_path() / "contact_sheet_bad.png";
  EXPECT_EQ(WriteContactSheet(path, {16, 15, a, n, o, {}}).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(WriteContactSheet(path, {16, 16, a, n, o, {}}, 8).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(WriteContactSheet("/nonexistent-dir/x.png", {16, 16, a, n, o, {}}, 16).status().code(),
            absl::StatusCode::kInternal);
}

}  // namespace
}  // namespace impostor
