// PNG encoding of the baked maps, with the deflate spread over threads.
//
// libpng (under OpenImageIO) deflates a whole image on one thread. On a GPU
// that made PNG encoding six to seven times the render + readback of a
// 2048 px bake (README, "On a real GPU"). This writes the PNG the maps
// always were (RGBA, 8 or 16 bits a channel, the Up row filter on every row,
// zlib level kPngCompressionLevel with strategy Z_FILTERED as libpng uses
// for filtered rows, no ancillary chunks) with its rows cut into bands that
// are deflated side by side. That is pigz's method:
// - each band's compressor is primed with the 32 KiB of filtered rows before
//   the band (deflateSetDictionary), so matches across a cut are kept;
// - each band but the last ends on a byte boundary (Z_SYNC_FLUSH), so the
//   bands concatenate into one zlib stream;
// - the stream's Adler-32 is combined from the bands' (adler32_combine).
// Any PNG reader decodes it. The bands are a fixed number of rows, whatever
// the thread count, so the same map is the same bytes on every machine.
//
// Hand-written because no library Debian ships does this (libpng and
// OpenImageIO deflate on one thread): zlib compresses and checksums, this
// file only frames what zlib produces.
#ifndef IMPOSTOR_WORKER_OUTPUT_PNG_ENCODER_H_
#define IMPOSTOR_WORKER_OUTPUT_PNG_ENCODER_H_

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "absl/status/statusor.h"

namespace impostor {

struct PngEncodeOptions {
  // Threads that deflate bands; 0 = the machine's hardware threads, at most 16.
  int threads = 0;
  // A band is as many whole rows as fill this many filtered bytes (at least
  // one row). Fixed, so the bytes do not depend on the thread count; tests
  // make it small to cut small images into many bands.
  size_t band_bytes = size_t{1} << 20;
};

// `pixels` holds width * height * 4 values, rows top to bottom.
// INVALID_ARGUMENT if the count does not match, width or height is below 1,
// or the image is larger than PNG allows (2^31 - 1 a side); INTERNAL if zlib
// fails.
absl::StatusOr<std::string> EncodePngRgba8(std::span<const uint8_t> pixels, int width, int height,
                                           const PngEncodeOptions& options = {});
absl::StatusOr<std::string> EncodePngRgba16(std::span<const uint16_t> pixels, int width, int height,
                                            const PngEncodeOptions& options = {});

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_OUTPUT_PNG_ENCODER_H_
