// A minimal KTX 2.0 container reader and writer (Khronos KTX File Format
// Specification 2.0, sections 3-4): enough to take single-level files the
// Basis Universal encoder writes and join their levels into one file with
// our own mip chain (worker/output/ktx2_encoder.h). There is no KTX2 library
// in Debian 12 (libktx is not packaged) and basisu's command line cannot
// take user mipmaps, so the container is written here; the level payloads,
// the Data Format Descriptor and the key/value data are the encoder's, byte
// for byte. Format notes: docs/ktx2.md.
//
// Pure functions, thread-safe.
#ifndef IMPOSTOR_WORKER_OUTPUT_KTX2_FILE_H_
#define IMPOSTOR_WORKER_OUTPUT_KTX2_FILE_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor {

inline constexpr uint32_t kKtx2SupercompressionNone = 0;
inline constexpr uint32_t kKtx2SupercompressionBasisLz = 1;
inline constexpr uint32_t kKtx2SupercompressionZstd = 2;
// Data Format Descriptor: KHR_DF_MODEL_UASTC, KHR_DF_TRANSFER_SRGB/LINEAR.
inline constexpr uint32_t kKtx2ColorModelUastc = 166;
inline constexpr uint32_t kKtx2TransferLinear = 1;
inline constexpr uint32_t kKtx2TransferSrgb = 2;

struct Ktx2Level {
  std::string data;                     // as stored (supercompressed or not)
  uint64_t uncompressed_byte_length = 0;
};

struct Ktx2Texture {
  uint32_t vk_format = 0;  // 0 (VK_FORMAT_UNDEFINED) for Basis Universal
  uint32_t type_size = 1;
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t supercompression = kKtx2SupercompressionNone;
  std::string dfd;  // the whole Data Format Descriptor, dfdTotalSize first
  std::string kvd;  // key/value data as stored
  std::string sgd;  // supercompression global data (empty but for BasisLZ)
  std::vector<Ktx2Level> levels;  // level 0 (largest) first

  // From the DFD's basic descriptor block.
  uint32_t ColorModel() const;
  uint32_t Transfer() const;
};

// Parses a 2D, single-layer, single-face KTX2 file. INVALID_ARGUMENT naming
// the field when the identifier is wrong, an offset or length points outside
// the file, or the texture is 3D, an array or a cube map.
absl::StatusOr<Ktx2Texture> ParseKtx2(std::string_view bytes);

// Writes `texture` as a KTX2 file: header, level index, DFD, key/value
// data, SGD, then the levels smallest first, each aligned as the spec asks
// (16 bytes for uncompressed UASTC, 1 when supercompressed).
// INVALID_ARGUMENT if there are no levels or the DFD is shorter than its
// basic block.
absl::StatusOr<std::string> SerializeKtx2(const Ktx2Texture& texture);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_KTX2_FILE_H_
