#include "worker/surfels/point_buffer.h"

#include <bit>
#include <cstdint>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

// Host float bits <-> little-endian bytes.
uint32_t ToLittleEndian(uint32_t v) {
  if constexpr (std::endian::native == std::endian::little) return v;
  return (v >> 24) | ((v >> 8) & 0xff00u) | ((v << 8) & 0xff0000u) | (v << 24);
}

}  // namespace

std::string EncodePointBuffer(const std::vector<Surfel>& points) {
  std::string bytes(points.size() * kPointStrideBytes, '\0');
  if constexpr (std::endian::native == std::endian::little) {
    if (!points.empty()) std::memcpy(bytes.data(), points.data(), bytes.size());
    return bytes;
  }
  const float* f = reinterpret_cast<const float*>(points.data());
  for (size_t i = 0; i < points.size() * 12; ++i) {
    const uint32_t le = ToLittleEndian(std::bit_cast<uint32_t>(f[i]));
    std::memcpy(bytes.data() + i * 4, &le, 4);
  }
  return bytes;
}

absl::StatusOr<std::vector<Surfel>> DecodePointBuffer(std::string_view bytes) {
  if (bytes.size() % kPointStrideBytes != 0) {
    return absl::InvalidArgumentError(absl::StrCat("point buffer: ", bytes.size(),
                                                   " bytes is not a multiple of the 48-byte point record"));
  }
  std::vector<Surfel> points(bytes.size() / kPointStrideBytes);
  float* f = reinterpret_cast<float*>(points.data());
  for (size_t i = 0; i < points.size() * 12; ++i) {
    uint32_t v;
    std::memcpy(&v, bytes.data() + i * 4, 4);
    f[i] = std::bit_cast<float>(ToLittleEndian(v));
  }
  return points;
}

}  // namespace impostor
