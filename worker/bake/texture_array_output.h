// `--array` output: each map written as a texture array instead of an atlas,
// for engines that prefer arrays (no mip bleeding between frames at any
// level, no tile arithmetic in the shader). A PNG holds one image, so the
// array is a vertical strip: layer i (= view i) is rows
// [i * tile, (i + 1) * tile) of a tile-wide image, which every engine's
// texture-array importer accepts as "N rows of 1 column". The manifest's
// views give each layer's rectangle as their `tile`.
#ifndef IMPOSTOR_WORKER_BAKE_TEXTURE_ARRAY_OUTPUT_H_
#define IMPOSTOR_WORKER_BAKE_TEXTURE_ARRAY_OUTPUT_H_

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "common/atlas/frame_camera.h"
#include "worker/gpu/atlas_renderer.h"

namespace impostor {

// The tiles of `atlas` (RGBA, width x height) stacked top to bottom in the
// order of `tiles` (all the same size, inside the image).
std::vector<uint8_t> TilesToLayers(std::span<const uint8_t> atlas, int width, std::span<const TileRect> tiles);
std::vector<uint16_t> TilesToLayers(std::span<const uint16_t> atlas, int width, std::span<const TileRect> tiles);

// Overwrites albedo_alpha.png, normal_depth.png, orm.png (and emissive.png
// when `emissive`) in `dir` with their layer strips. INTERNAL when a file
// cannot be written.
absl::Status WriteTextureArrays(const std::filesystem::path& dir, const AtlasImages& atlas,
                                std::span<const TileRect> tiles, bool emissive);

// The rectangle of layer `index` in a strip of `tile`-sized layers.
inline TileRect LayerRect(int index, int tile) { return {0, index * tile, tile, tile}; }

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_TEXTURE_ARRAY_OUTPUT_H_
