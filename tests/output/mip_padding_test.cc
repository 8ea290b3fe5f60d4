// Padding for mipmaps: with tiles sized by TileSize and dilated to their
// edges, a box-filtered mip chain of the whole atlas keeps every frame's
// colour to itself down to the documented level (tiles of 16 px).
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/atlas/frame_camera.h"
#include "worker/output/atlas_dilation.h"

namespace impostor {
namespace {

struct Image {
  int size = 0;
  std::vector<uint8_t> rgba;
};

// One level down: each texel the mean of its 2x2 block (sizes rounded down,
// as GPUs do for odd sizes after the first levels).
Image Downsample(const Image& in) {
  Image out;
  out.size = in.size / 2;
  out.rgba.assign(static_cast<size_t>(out.size) * out.size * 4, 0);
  for (int y = 0; y < out.size; ++y) {
    for (int x = 0; x < out.size; ++x) {
      for (int c = 0; c < 4; ++c) {
        int sum = 0;
        for (int k = 0; k < 4; ++k) {
          sum += in.rgba[(static_cast<size_t>(2 * y + k / 2) * in.size + 2 * x + k % 2) * 4 + c];
        }
        out.rgba[(static_cast<size_t>(y) * out.size + x) * 4 + c] = static_cast<uint8_t>((sum + 2) / 4);
      }
    }
  }
  return out;
}

TEST(MipPadding, TilesAreAlignedSoNoMipLevelDownToSixteenPixelsMixesFrames) {
  struct Case {
    int resolution, frames;
  } cases[] = {{2048, 12}, {2048, 8}, {1024, 12}, {1024, 10}, {512, 5}, {4096, 24}, {2000, 7}, {768, 3}};
  for (const Case& c : cases) {
    const std::string name = std::to_string(c.resolution) + "/" + std::to_string(c.frames);
    const int tile = TileSize(c.resolution, c.frames);
    const int levels = MipSafeLevels(c.resolution, c.frames);
    ASSERT_GE(tile, c.resolution / c.frames - (1 << levels) + 1) << name;
    ASSERT_EQ(tile % (1 << levels), 0) << name;
    ASSERT_GE(tile >> levels, kMipSafeTilePixels) << name;

    // Each frame: one covered texel somewhere inside with its own colour,
    // dilated over the whole tile as the baker does.
    Image image{c.resolution, std::vector<uint8_t>(static_cast<size_t>(c.resolution) * c.resolution * 4, 0)};
    std::vector<TileRect> tiles;
    auto colour = [](int frame, int channel) { return static_cast<uint8_t>((frame * 37 + channel * 91 + 11) % 251); };
    for (int row = 0; row < c.frames; ++row) {
      for (int col = 0; col < c.frames; ++col) {
        const TileRect t{col * tile, row * tile, tile, tile};
        tiles.push_back(t);
        const int frame = row * c.frames + col;
        const size_t px = (static_cast<size_t>(t.y + tile / 3) * c.resolution + t.x + tile / 2) * 4;
        for (int ch = 0; ch < 3; ++ch) image.rgba[px + ch] = colour(frame, ch);
        image.rgba[px + 3] = 255;
      }
    }
    ASSERT_TRUE(DilateRgba8(image.rgba, c.resolution, c.resolution, tiles).ok());

    Image level = image;
    for (int l = 1; l <= levels; ++l) {
      level = Downsample(level);
      const int t = tile >> l;
      for (int row = 0; row < c.frames; ++row) {
        for (int col = 0; col < c.frames; ++col) {
          const int frame = row * c.frames + col;
          for (int y = 0; y < t; ++y) {
            for (int x = 0; x < t; ++x) {
              const size_t px = (static_cast<size_t>(row * t + y) * level.size + col * t + x) * 4;
              for (int ch = 0; ch < 3; ++ch) {
                ASSERT_EQ(level.rgba[px + ch], colour(frame, ch))
                    << name << " mip " << l << " frame " << frame << " texel " << x << "," << y;
              }
            }
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace impostor
