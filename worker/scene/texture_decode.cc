#include "worker/scene/texture_decode.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"

// stb_image, compiled privately into this file (static functions) so that it
// cannot clash with the copy inside libtinygltf. 2^16 matches the largest
// limit GltfLoadLimits allows.
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STBI_NO_STDIO
#define STBI_NO_HDR
// glTF images are PNG or JPEG (image.mimeType); no other decoder is built.
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
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

bool StartsWith(std::span<const uint8_t> b, const char* magic, size_t n, size_t at = 0) {
  return b.size() >= at + n && std::memcmp(b.data() + at, magic, n) == 0;
}

// Names a recognised image container that is not PNG or JPEG, or nullptr.
// Debian 12's stb_image builds a Huffman table from the 16 code-length
// counts of a DHT segment without checking that they total at most 256, the
// size of its symbol array (upstream stb added the check later): a hostile
// JPEG overflows it (found by fuzz/run.sh). This walks every DHT segment the
// way stb's stbi__process_marker reads it (a byte past the end reads as 0, as
// stbi__get8 does) and refuses a table stb would overflow. Every FF C4 pair is
// checked, not only those a marker walk reaches: entropy-coded data never
// holds one (its FF bytes are stuffed), so this can only be stricter than stb.
bool HasOversizedHuffmanTable(std::span<const uint8_t> b) {
  auto at = [&](size_t i) -> int { return i < b.size() ? b[i] : 0; };
  for (size_t pos = 0; pos + 1 < b.size(); ++pos) {
    if (b[pos] != 0xFF || b[pos + 1] != 0xC4) continue;
    size_t i = pos + 2;
    long remaining = (static_cast<long>(at(i)) << 8 | at(i + 1)) - 2;
    i += 2;
    while (remaining > 0 && i < b.size()) {
      const int q = at(i++);
      if ((q >> 4) > 1 || (q & 15) > 3) break;  // stb refuses this table itself
      int n = 0;
      for (int k = 0; k < 16; ++k) n += at(i++);
      if (n > 256) return true;
      i += static_cast<size_t>(n);
      remaining -= 17 + n;
    }
  }
  return false;
}

// stb_image grows its buffer of compressed data to each IDAT chunk's declared
// length before it reads the chunk, doubling as it goes, so one chunk header
// claiming a gigabyte allocates a gigabyte even in a 200-byte file (found by
// fuzz/run.sh). Decoding from memory, a chunk can never be longer than the
// bytes left, so this walks the chunks up to IEND the way stb does and names
// the first that runs past the end: stricter than stb, never looser.
// Returns the byte offset of that chunk, or -1 when every chunk fits.
long FirstPngChunkPastEnd(std::span<const uint8_t> b) {
  size_t pos = 8;  // after the signature
  while (pos + 8 <= b.size()) {
    const uint32_t length = uint32_t(b[pos]) << 24 | uint32_t(b[pos + 1]) << 16 |
                            uint32_t(b[pos + 2]) << 8 | uint32_t(b[pos + 3]);
    const bool iend = std::memcmp(b.data() + pos + 4, "IEND", 4) == 0;
    // length + type + data + CRC must fit; IEND's CRC may be missing, as stb
    // never reads it.
    const uint64_t need = uint64_t(8) + length + (iend ? 0 : 4);
    if (need > b.size() - pos) return static_cast<long>(pos);
    if (iend) return -1;
    pos += static_cast<size_t>(need);
  }
  return -1;  // truncated before a chunk header: stb reports it itself
}

const char* OtherFormat(std::span<const uint8_t> b) {
  if (StartsWith(b, "\xABKTX 20\xBB\r\n\x1A\n", 12)) return "KTX2";
  if (StartsWith(b, "\xABKTX 11\xBB\r\n\x1A\n", 12)) return "KTX";
  if (StartsWith(b, "RIFF", 4) && StartsWith(b, "WEBP", 4, 8)) return "WebP";
  if (StartsWith(b, "DDS ", 4)) return "DDS";
  if (StartsWith(b, "\x76\x2F\x31\x01", 4)) return "OpenEXR";
  if (StartsWith(b, "GIF8", 4)) return "GIF";
  if (StartsWith(b, "BM", 2)) return "BMP";
  if (StartsWith(b, "8BPS", 4)) return "PSD";
  if (StartsWith(b, "#?RADIANCE", 10) || StartsWith(b, "#?RGBE", 6)) return "Radiance HDR";
  if (StartsWith(b, "\x53\x80\xF6\x34", 4)) return "PIC";
  if (b.size() >= 2 && b[0] == 'P' && b[1] >= '1' && b[1] <= '7') return "PNM";
  return nullptr;
}

constexpr char kPngMagic[] = "\x89PNG\r\n\x1A\n";

}  // namespace

absl::StatusOr<ImageHeader> ProbeImage(std::span<const uint8_t> bytes, std::string_view what) {
  if (bytes.empty() || bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": encoded image has ", bytes.size(), " bytes"));
  }
  ImageHeader header;
  if (StartsWith(bytes, kPngMagic, 8)) {
    header.format = ImageHeader::Format::kPng;
    if (const long at = FirstPngChunkPastEnd(bytes); at >= 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          std::string(what), ": corrupt PNG: the chunk at byte ", at,
          " declares more data than the ", bytes.size(), "-byte image holds"));
    }
  } else if (StartsWith(bytes, "\xFF\xD8\xFF", 3)) {
    header.format = ImageHeader::Format::kJpeg;
    if (HasOversizedHuffmanTable(bytes)) {
      return absl::InvalidArgumentError(absl::StrCat(
          std::string(what), ": corrupt JPEG: a Huffman table (DHT) defines more than 256 codes"));
    }
  } else if (const char* format = OtherFormat(bytes)) {
    return absl::UnimplementedError(absl::StrCat(
        std::string(what), ": ", format, " images are not supported (glTF allows PNG and JPEG)"));
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": not a PNG or JPEG image (unrecognised header)"));
  }
  if (!stbi_info_from_memory(bytes.data(), static_cast<int>(bytes.size()), &header.width,
                             &header.height, &header.channels)) {
    return absl::InvalidArgumentError(absl::StrCat(std::string(what),
                                                   ": cannot decode image (corrupt header: ",
                                                   stbi_failure_reason(), ")"));
  }
  header.bit_depth =
      stbi_is_16_bit_from_memory(bytes.data(), static_cast<int>(bytes.size())) ? 16 : 8;
  return header;
}

uint64_t PeakDecodeBytes(const ImageHeader& header) {
  const uint64_t pixels = uint64_t(std::max(header.width, 0)) * uint64_t(std::max(header.height, 0));
  const uint64_t c = static_cast<uint64_t>(std::clamp(header.channels, 1, 4));
  if (header.format == ImageHeader::Format::kJpeg) return pixels * (3 * c + 8);
  const uint64_t b = header.bit_depth == 16 ? 2 : 1;
  return pixels * (3 * c * b + 4 * b + 8);
}


absl::StatusOr<DecodedImage> DecodeImageRgba8(std::span<const uint8_t> bytes, int max_dimension,
                                              uint64_t max_bytes, std::string_view what) {
  absl::StatusOr<ImageHeader> header = ProbeImage(bytes, what);
  if (!header.ok()) return header.status();
  const int size = static_cast<int>(bytes.size());
  const int width = header->width, height = header->height, channels = header->channels;
  if (width > max_dimension || height > max_dimension) {
    return absl::ResourceExhaustedError(
        absl::StrCat(std::string(what), ": image is ", width, "x", height,
                     ", over GltfLoadLimits::max_texture_dimension = ", max_dimension));
  }
  const uint64_t peak_bytes = PeakDecodeBytes(*header);
  if (peak_bytes > max_bytes) {
    return absl::ResourceExhaustedError(absl::StrCat(
        std::string(what), ": decoding ", width, "x", height, " ",
        header->format == ImageHeader::Format::kPng ? "PNG" : "JPEG", " (", channels,
        " channels, ", header->bit_depth, "-bit) peaks at ", peak_bytes,
        " bytes, over GltfLoadLimits::max_texture_bytes (", max_bytes,
        " bytes left of the budget)"));
  }
  int w = 0, h = 0, n = 0;
  // stbi_load_* converts 16-bit data to 8 bits and expands to 4 channels.
  stbi_uc* pixels = stbi_load_from_memory(bytes.data(), size, &w, &h, &n, 4);
  if (pixels == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": cannot decode image: ", stbi_failure_reason()));
  }
  const std::unique_ptr<stbi_uc, void (*)(void*)> owned(pixels, stbi_image_free);
  DecodedImage image;
  image.width = w;
  image.height = h;
  image.source_channels = channels;
  // Into the isolated loader's shared memory when loading there.
  image.rgba8 = TexelBuffer::CopyOf(std::span<const uint8_t>(pixels, static_cast<size_t>(w) * h * 4));
  if (w != width || h != height) {  // header and data disagree: distrust both
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": image size changed while decoding"));
  }
  return image;
}

}  // namespace impostor::gltf_internal
