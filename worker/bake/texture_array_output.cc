#include "worker/bake/texture_array_output.h"

#include <algorithm>

#include "worker/output/map_writer.h"

namespace impostor {
namespace {

template <typename T>
std::vector<T> Stack(std::span<const T> atlas, int width, std::span<const TileRect> tiles) {
  if (tiles.empty()) return {};
  const int tile = tiles[0].width;
  std::vector<T> out(static_cast<size_t>(tile) * tile * tiles.size() * 4);
  for (size_t i = 0; i < tiles.size(); ++i) {
    const TileRect& t = tiles[i];
    for (int y = 0; y < tile; ++y) {
      const T* src = atlas.data() + (static_cast<size_t>(t.y + y) * width + t.x) * 4;
      T* dst = out.data() + ((i * tile + y) * static_cast<size_t>(tile)) * 4;
      std::copy(src, src + static_cast<size_t>(tile) * 4, dst);
    }
  }
  return out;
}

}  // namespace

std::vector<uint8_t> TilesToLayers(std::span<const uint8_t> atlas, int width, std::span<const TileRect> tiles) {
  return Stack(atlas, width, tiles);
}

std::vector<uint16_t> TilesToLayers(std::span<const uint16_t> atlas, int width, std::span<const TileRect> tiles) {
  return Stack(atlas, width, tiles);
}

absl::Status WriteTextureArrays(const std::filesystem::path& dir, const AtlasImages& atlas,
                                std::span<const TileRect> tiles, bool emissive) {
  if (tiles.empty()) return absl::OkStatus();
  const int tile = tiles[0].width;
  const int height = tile * static_cast<int>(tiles.size());
  if (auto s = WritePngRgba8(dir / "albedo_alpha.png", TilesToLayers(atlas.albedo_alpha, atlas.width, tiles), tile,
                             height);
      !s.ok()) {
    return s;
  }
  if (auto s = WritePngRgba16(dir / "normal_depth.png", TilesToLayers(atlas.normal_depth, atlas.width, tiles), tile,
                              height);
      !s.ok()) {
    return s;
  }
  if (auto s = WritePngRgba8(dir / "orm.png", TilesToLayers(atlas.orm, atlas.width, tiles), tile, height); !s.ok()) {
    return s;
  }
  if (emissive) {
    return WritePngRgba8(dir / "emissive.png", TilesToLayers(atlas.emissive, atlas.width, tiles), tile, height);
  }
  return absl::OkStatus();
}

}  // namespace impostor
