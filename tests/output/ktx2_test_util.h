// Test helpers for KTX2 maps: decoding through the encoder's own
// transcoder (`basisu -unpack`, UASTC -> ASTC 4x4, which is lossless) and
// image error measures.
#ifndef IMPOSTOR_TESTS_OUTPUT_KTX2_TEST_UTIL_H_
#define IMPOSTOR_TESTS_OUTPUT_KTX2_TEST_UTIL_H_

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "worker/output/ktx2_encoder.h"
#include "worker/output/map_writer.h"
#include "worker/output/run_tool.h"

namespace impostor::testing_ktx2 {

// Every level of `ktx2` decoded to RGBA8, level 0 first.
inline absl::StatusOr<std::vector<MipLevel<uint8_t>>> DecodeKtx2(const std::filesystem::path& ktx2, int levels) {
  const std::filesystem::path dir = ktx2.parent_path() / (ktx2.stem().string() + "_unpacked");
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  // basisu writes into the current folder: run it there through sh.
  auto ran = RunTool({"/bin/sh", "-c",
                      absl::StrCat("cd '", dir.string(), "' && '", DefaultBasisuPath().string(),
                                   "' -unpack -no_ktx -file '", std::filesystem::absolute(ktx2).string(), "'")},
                     dir / "unpack.log");
  if (!ran.ok()) return ran.status();
  std::vector<MipLevel<uint8_t>> out;
  for (int i = 0; i < levels; ++i) {
    const std::filesystem::path png =
        dir / absl::StrCat(ktx2.stem().string(), "_unpacked_rgba_ASTC_RGBA_", i, "_0000.png");
    auto image = ReadPng(png);
    if (!image.ok()) return image.status();
    if (image->channels < 1 || image->channels > 4 || image->bit_depth != 8) {
      return absl::InternalError(absl::StrCat(png.string(), ": not an 8-bit image"));
    }
    if (image->channels != 4) {  // grey, grey + alpha or RGB (no alpha: A = 255)
      const int n = image->channels;
      std::vector<uint8_t> rgba;
      rgba.reserve(image->pixels8.size() / n * 4);
      for (size_t i = 0; i < image->pixels8.size(); i += n) {
        const uint8_t* p = &image->pixels8[i];
        if (n <= 2) rgba.insert(rgba.end(), {p[0], p[0], p[0], n == 2 ? p[1] : uint8_t{255}});
        else rgba.insert(rgba.end(), {p[0], p[1], p[2], uint8_t{255}});
      }
      image->pixels8 = std::move(rgba);
    }
    out.push_back({image->width, image->height, std::move(image->pixels8)});
  }
  return out;
}

// RMS difference of channel `c` (0..3) over texels where `mask` (if given,
// same layout) has alpha > 0, in 8-bit steps.
inline double RmsChannel(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int c,
                         const std::vector<uint8_t>* mask = nullptr) {
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i + 3 < a.size() && i + 3 < b.size(); i += 4) {
    if (mask != nullptr && (*mask)[i + 3] == 0) continue;
    const double d = static_cast<double>(a[i + c]) - b[i + c];
    sum += d * d;
    ++n;
  }
  return n == 0 ? 0.0 : std::sqrt(sum / static_cast<double>(n));
}

}  // namespace impostor::testing_ktx2

#endif  // IMPOSTOR_TESTS_OUTPUT_KTX2_TEST_UTIL_H_
