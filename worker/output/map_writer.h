// PNG output of the baked atlas maps (OpenImageIO), and a reader for tests
// and tools. albedo_alpha and orm are written as 8-bit RGBA, normal_depth as
// 16-bit RGBA (depth needs the precision). Channel values are written as
// given: the fourth channel is never treated as associated alpha (no
// premultiplication on read, no division on write), because dilated colour
// under alpha 0 and depth in A must survive unchanged.
#ifndef IMPOSTOR_WORKER_OUTPUT_MAP_WRITER_H_
#define IMPOSTOR_WORKER_OUTPUT_MAP_WRITER_H_

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor {

// zlib level of every map written here. Measured on DamagedHelmet's
// 2048 px maps (albedo, normal_depth, orm; CPU seconds, one core): level 6
// (libpng's default) 2.67 s for 22.5 MB, 4: 1.71 s / 22.9 MB, 3: 1.48 s /
// 23.7 MB, 1: 1.46 s / 24.2 MB. Level 3 encodes 45% faster for 5% more bytes;
// below it the bytes grow with no time saved.
inline constexpr int kPngCompressionLevel = 3;

// PNG row filter of every map written here: Up on every row (libpng's
// PNG_FILTER_UP) instead of libpng's default, which tries all five filters
// on each row and keeps the one its heuristic prefers. Measured on
// DamagedHelmet's 2048 px maps at level 3 (albedo + normal_depth + orm, CPU
// seconds, one core, two rounds): default 1.55 s for 22.20 MB, Up 1.03 s for
// 22.14 MB; None is no faster and normal_depth grows 12%; Sub costs more for
// more bytes (Average and Paeth alone not measured). Up costs a third less
// and writes no more bytes.
inline constexpr int kPngRowFilter = 0x20;  // PNG_FILTER_UP

// Writes `pixels` (width * height * 4 values, rows top to bottom) as an
// 8-bit RGBA PNG at `path` (overwritten), deflated on several threads
// (png_encoder.h). INVALID_ARGUMENT if the sizes do not match or
// width/height < 1; INTERNAL with the system's reason if the file cannot be
// created or written.
absl::Status WritePngRgba8(const std::filesystem::path& path, std::span<const uint8_t> pixels,
                           int width, int height);

// The same, 16 bits per channel.
absl::Status WritePngRgba16(const std::filesystem::path& path, std::span<const uint16_t> pixels,
                            int width, int height);

struct PngImage {
  int width = 0;
  int height = 0;
  int channels = 0;
  int bit_depth = 0;               // 8 or 16
  std::vector<uint8_t> pixels8;    // filled when bit_depth == 8
  std::vector<uint16_t> pixels16;  // filled when bit_depth == 16
};

// Reads a PNG in its stored bit depth (8 or 16) and channel count.
// NOT_FOUND if the file does not exist; INVALID_ARGUMENT with OpenImageIO's
// message if it is not a readable PNG or has another bit depth.
absl::StatusOr<PngImage> ReadPng(const std::filesystem::path& path);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_MAP_WRITER_H_
