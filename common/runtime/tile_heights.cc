#include "common/runtime/tile_heights.h"

namespace impostor {

TileHeights::TileHeights(const ImpostorAtlas& atlas, const TileRect& tile)
    : tile_(tile), stride_(tile.width + 2) {
  texels_.resize(static_cast<size_t>(stride_) * (tile.height + 2));
  for (int py = 0; py < tile.height + 2; ++py) {
    const int y = std::clamp(py - 1, 0, tile.height - 1);
    for (int px = 0; px < stride_; ++px) {
      const int x = std::clamp(px - 1, 0, tile.width - 1);
      const size_t texel = (static_cast<size_t>(tile.y + y) * atlas.width + tile.x + x) * 4;
      texels_[static_cast<size_t>(py) * stride_ + px] = {
          static_cast<float>(atlas.albedo_alpha[texel + 3]) / 255.0f,
          static_cast<float>(atlas.normal_depth[texel + 3]) / 65535.0f};
    }
  }
}

}  // namespace impostor
