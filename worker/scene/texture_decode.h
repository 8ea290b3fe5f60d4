// Decodes an encoded glTF image to 8-bit RGBA with stb_image, after checking
// its header against the limits. Only the formats glTF 2.0 allows for
// `image.mimeType` are decoded (PNG and JPEG); stb_image is compiled with
// its other decoders (GIF, BMP, TGA, PSD, PIC, PNM) left out, so their
// parsers never see untrusted bytes. Internal to the glTF loader.
#ifndef IMPOSTOR_WORKER_SCENE_TEXTURE_DECODE_H_
#define IMPOSTOR_WORKER_SCENE_TEXTURE_DECODE_H_

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/scene/texel_buffer.h"

namespace impostor::gltf_internal {

// What an image header says, read without decoding any pixel.
struct ImageHeader {
  enum class Format { kPng, kJpeg };
  Format format = Format::kPng;
  int width = 0;
  int height = 0;
  int channels = 0;   // in the file: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA
  int bit_depth = 8;  // bits per channel: 16 only for 16-bit PNGs
};

// Reads the header of a PNG or JPEG. UNIMPLEMENTED (naming the format) for
// a recognised container glTF does not allow or stb_image cannot decode
// (KTX/KTX2, WebP, DDS, OpenEXR, GIF, BMP, PSD, PIC, PNM); INVALID_ARGUMENT
// (starting with `what`) for anything else that is not a readable PNG/JPEG
// header.
absl::StatusOr<ImageHeader> ProbeImage(std::span<const uint8_t> bytes, std::string_view what);

// Upper bound of the heap stb_image and DecodeImageRgba8 hold at once while
// decoding an image with this header, bytes. Per format, per pixel:
//  PNG: zlib output growing by doubling up to 2x the raw scanlines
//       (channels * bit_depth / 8 bytes) plus the raw scanlines being
//       unfiltered into a 4-channel image at the file's depth, then the
//       8-bit RGBA result and its copy into DecodedImage: 3 * c * b + 4 * b
//       + 8 with b = bytes per channel (a 16-bit RGBA PNG: 40 bytes/pixel,
//       ten times the 4 of the decoded texture);
//  JPEG: progressive coefficients (2 bytes per channel), component planes
//       (1 per channel), the RGBA result and its copy: 3 * c + 8.
uint64_t PeakDecodeBytes(const ImageHeader& header);

struct DecodedImage {
  int width = 0;
  int height = 0;
  TexelBuffer rgba8;  // width * height * 4, rows top to bottom
  int source_channels = 4;     // channels in the file: 2 and 4 carry alpha
};

// Decodes `bytes`. 1-, 2- and 3-channel images are expanded to RGBA (grey
// to R=G=B, missing alpha = 255); 16-bit images are reduced to 8 bits.
// The header is read first (ProbeImage): RESOURCE_EXHAUSTED (naming the
// limit) if width or height exceeds `max_dimension` or the decode's peak
// (PeakDecodeBytes, which names the per-pixel cost of the format) exceeds
// `max_bytes`, before any pixel memory is allocated. INVALID_ARGUMENT
// (starting with `what`, with stb_image's reason) if the data cannot be
// decoded; UNIMPLEMENTED as ProbeImage for formats other than PNG/JPEG.
absl::StatusOr<DecodedImage> DecodeImageRgba8(std::span<const uint8_t> bytes, int max_dimension,
                                              uint64_t max_bytes, std::string_view what);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_TEXTURE_DECODE_H_
