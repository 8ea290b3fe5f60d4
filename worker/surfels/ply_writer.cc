#include "worker/surfels/ply_writer.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

void PutFloat(std::string* out, float f) {
  uint32_t v = std::bit_cast<uint32_t>(f);
  if constexpr (std::endian::native != std::endian::little) {
    v = (v >> 24) | ((v >> 8) & 0xff00u) | ((v << 8) & 0xff0000u) | (v << 24);
  }
  char b[4];
  std::memcpy(b, &v, 4);
  out->append(b, 4);
}

}  // namespace

uint8_t LinearToSrgbByte(float linear) {
  const double c = std::clamp(static_cast<double>(linear), 0.0, 1.0);
  const double s = c <= 0.0031308 ? c * 12.92 : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
  return static_cast<uint8_t>(std::lround(s * 255.0));
}

std::string EncodePly(const std::vector<Surfel>& points, const std::vector<std::string>& comments) {
  std::string out = "ply\nformat binary_little_endian 1.0\n";
  for (const std::string& c : comments) absl::StrAppend(&out, "comment ", c, "\n");
  absl::StrAppend(&out, "element vertex ", points.size(), "\n",
                  "property float x\nproperty float y\nproperty float z\n"
                  "property float nx\nproperty float ny\nproperty float nz\n"
                  "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                  "property float occlusion\nproperty float roughness\nproperty float metalness\n"
                  "end_header\n");
  out.reserve(out.size() + points.size() * 39);
  for (const Surfel& p : points) {
    for (int a = 0; a < 3; ++a) PutFloat(&out, p.position[a]);
    for (int a = 0; a < 3; ++a) PutFloat(&out, p.normal[a]);
    for (int a = 0; a < 3; ++a) out.push_back(static_cast<char>(LinearToSrgbByte(p.albedo[a])));
    for (int a = 0; a < 3; ++a) PutFloat(&out, p.orm[a]);
  }
  return out;
}

}  // namespace impostor
