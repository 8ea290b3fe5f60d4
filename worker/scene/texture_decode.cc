#include "worker/scene/texture_decode.h"

#include <cstring>
#include <limits>
#include <string>

#include "absl/strings/str_cat.h"

// stb_image, compiled privately into this file (static functions) so that it
// cannot clash with the copy inside libtinygltf. 2^16 matches the largest
// limit GltfLoadLimits allows.
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_NO_STDIO
#define STBI_NO_HDR
#define STBI_MAX_DIMENSIONS (1 << 16)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

namespace impostor::gltf_internal {
namespace {

// Names a valid image container stb_image cannot decode, or nullptr.
const char* UnsupportedFormat(std::span<const uint8_t> b) {
  auto starts = [&](const char* magic, size_t n, size_t at = 0) {
    return b.size() >= at + n && std::memcmp(b.data() + at, magic, n) == 0;
  };
  if (starts("\xABKTX 20\xBB\r\n\x1A\n", 12)) return "KTX2";
  if (starts("\xABKTX 11\xBB\r\n\x1A\n", 12)) return "KTX";
  if (starts("RIFF", 4) && starts("WEBP", 4, 8)) return "WebP";
  if (starts("DDS ", 4)) return "DDS";
  if (starts("\x76\x2F\x31\x01", 4)) return "OpenEXR";
  return nullptr;
}

}  // namespace

absl::StatusOr<DecodedImage> DecodeImageRgba8(std::span<const uint8_t> bytes, int max_dimension,
                                              uint64_t max_bytes, std::string_view what) {
  if (bytes.empty() || bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": encoded image has ", bytes.size(), " bytes"));
  }
  const int size = static_cast<int>(bytes.size());
  int width = 0, height = 0, channels = 0;
  if (const char* format = UnsupportedFormat(bytes)) {
    return absl::UnimplementedError(
        absl::StrCat(std::string(what), ": ", format, " images are not supported"));
  }
  if (!stbi_info_from_memory(bytes.data(), size, &width, &height, &channels)) {
    return absl::InvalidArgumentError(absl::StrCat(std::string(what),
                                                   ": cannot decode image (unsupported format or "
                                                   "corrupt header: ",
                                                   stbi_failure_reason(), ")"));
  }
  if (width > max_dimension || height > max_dimension) {
    return absl::ResourceExhaustedError(
        absl::StrCat(std::string(what), ": image is ", width, "x", height,
                     ", over GltfLoadLimits::max_texture_dimension = ", max_dimension));
  }
  const uint64_t decoded_bytes = uint64_t{4} * width * height;
  if (decoded_bytes > max_bytes) {
    return absl::ResourceExhaustedError(
        absl::StrCat(std::string(what), ": decoding ", width, "x", height, " (", decoded_bytes,
                     " bytes) would exceed GltfLoadLimits::max_texture_bytes (", max_bytes,
                     " bytes left of the budget)"));
  }
  int w = 0, h = 0, n = 0;
  // stbi_load_* converts 16-bit data to 8 bits and expands to 4 channels.
  stbi_uc* pixels = stbi_load_from_memory(bytes.data(), size, &w, &h, &n, 4);
  if (pixels == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": cannot decode image: ", stbi_failure_reason()));
  }
  DecodedImage image;
  image.width = w;
  image.height = h;
  image.source_channels = channels;
  image.rgba8.assign(pixels, pixels + static_cast<size_t>(w) * h * 4);
  stbi_image_free(pixels);
  if (w != width || h != height) {  // header and data disagree: distrust both
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": image size changed while decoding"));
  }
  return image;
}

}  // namespace impostor::gltf_internal
