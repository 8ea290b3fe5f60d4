// Decodes an encoded image (PNG, JPEG, BMP, TGA, GIF first frame, ...) to
// 8-bit RGBA with stb_image, after checking its size against the limits.
// Internal to the glTF loader.
#ifndef IMPOSTOR_WORKER_SCENE_TEXTURE_DECODE_H_
#define IMPOSTOR_WORKER_SCENE_TEXTURE_DECODE_H_

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor::gltf_internal {

struct DecodedImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgba8;  // width * height * 4, rows top to bottom
  int source_channels = 4;     // channels in the file: 2 and 4 carry alpha
};

// Decodes `bytes`. 1-, 2- and 3-channel images are expanded to RGBA (grey
// to R=G=B, missing alpha = 255); 16-bit images are reduced to 8 bits.
// The header is read first: RESOURCE_EXHAUSTED (naming the limit) if width
// or height exceeds `max_dimension` or width * height * 4 exceeds
// `max_bytes`, before any pixel memory is allocated. INVALID_ARGUMENT
// (starting with `what`, with stb_image's reason) if the data cannot be
// decoded; UNIMPLEMENTED for well-formed containers stb_image cannot decode
// (KTX/KTX2, WebP, DDS, OpenEXR).
absl::StatusOr<DecodedImage> DecodeImageRgba8(std::span<const uint8_t> bytes, int max_dimension,
                                              uint64_t max_bytes, std::string_view what);

}  // namespace impostor::gltf_internal

#endif  // IMPOSTOR_WORKER_SCENE_TEXTURE_DECODE_H_
