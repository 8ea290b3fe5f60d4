// How a PNG file was deflated and filtered, for tests that check the
// encoder's settings rather than the pixels: the zlib stream of its IDAT
// chunks, and each row's filter type (PNG spec 9.2) once inflated.
#ifndef IMPOSTOR_TESTS_OUTPUT_PNG_STREAM_H_
#define IMPOSTOR_TESTS_OUTPUT_PNG_STREAM_H_

#include <zlib.h>

#include <cstdint>
#include <string>
#include <vector>

namespace impostor::testing {

// The IDAT chunks' data of a PNG file's bytes, concatenated: one zlib stream.
inline std::string IdatStream(const std::string& png) {
  std::string stream;
  for (size_t at = 8; at + 12 <= png.size();) {
    const auto u8 = [&](size_t i) { return static_cast<uint32_t>(static_cast<uint8_t>(png[i])); };
    const uint32_t length = u8(at) << 24 | u8(at + 1) << 16 | u8(at + 2) << 8 | u8(at + 3);
    if (png.compare(at + 4, 4, "IDAT") == 0) stream += png.substr(at + 8, length);
    at += 12 + length;
  }
  return stream;
}

// The filter type byte of each of the `height` rows of an image whose rows
// hold `row_bytes` bytes of pixels; empty when the stream does not inflate
// to exactly that many bytes.
inline std::vector<uint8_t> RowFilterTypes(const std::string& png, size_t row_bytes, int height) {
  const std::string stream = IdatStream(png);
  std::vector<uint8_t> raw((row_bytes + 1) * static_cast<size_t>(height));
  uLongf raw_size = static_cast<uLongf>(raw.size());
  if (uncompress(raw.data(), &raw_size, reinterpret_cast<const Bytef*>(stream.data()),
                 static_cast<uLong>(stream.size())) != Z_OK ||
      raw_size != raw.size()) {
    return {};
  }
  std::vector<uint8_t> types;
  for (int y = 0; y < height; ++y) types.push_back(raw[static_cast<size_t>(y) * (row_bytes + 1)]);
  return types;
}

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_OUTPUT_PNG_STREAM_H_
