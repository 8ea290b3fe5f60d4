// --texture-format ktx2: the atlas maps as KTX2 files (UASTC, our mip chain
// per tile; worker/output/ktx2_encoder.h) and their manifest entries.
// Thread-safe on distinct output folders.
#ifndef IMPOSTOR_WORKER_BAKE_KTX2_MAPS_H_
#define IMPOSTOR_WORKER_BAKE_KTX2_MAPS_H_

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "common/atlas/frame_camera.h"
#include "impostor/v1/types.pb.h"

namespace impostor {

// The dilated level-0 maps of one bake (sizes width x height, RGBA).
struct Ktx2MapsInput {
  int width = 0;
  int height = 0;
  std::span<const uint8_t> albedo_alpha;
  std::span<const uint16_t> normal_depth;
  std::span<const uint8_t> orm;
  std::span<const uint8_t> emissive;  // empty: no emissive map
  std::span<const TileRect> tiles;
  int levels = 1;  // MipSafeLevels + 1: down to the 16 px tile
  v1::AlbedoCodec albedo_codec = v1::ALBEDO_CODEC_UASTC;
  // The job's cancel flag (may be null): ends the encoders at once.
  const std::atomic<bool>* cancelled = nullptr;
};

// The precision each KTX2 map keeps, as the manifest states it (measured by
// tests/output/ktx2_encoder_test.cc on the test assets).
extern const char* const kKtx2AlbedoPrecision;
extern const char* const kKtx2NormalDepthPrecision;
extern const char* const kKtx2OrmPrecision;
extern const char* const kKtx2DepthPrecision;

// Writes dir/albedo_alpha.ktx2, normal_depth.ktx2, depth.ktx2 (depth alone,
// for the pixel depth offset), orm.ktx2 (and emissive.ktx2) and returns
// their MapFile entries (semantic, file, digest, size, format "ktx2_uastc",
// codec, levels, precision, and coverage_by_level for the maps whose A is
// coverage; channels are the caller's but for "depth"). The coverage maps'
// levels keep level 0's alpha-tested area per tile (MipCoverage::
// kPreserveAlphaTest), the same alpha in all three. Errors of the mip chain
// and encoder (ktx2_encoder.h).
absl::StatusOr<std::vector<v1::MapFile>> WriteKtx2Maps(const std::filesystem::path& dir,
                                                       const Ktx2MapsInput& maps);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_KTX2_MAPS_H_
