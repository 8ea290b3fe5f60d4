// Helpers shared by the scene tests: the shared asset folder and scratch
// directories.
#ifndef IMPOSTOR_TESTS_SCENE_TEST_ASSETS_H_
#define IMPOSTOR_TESTS_SCENE_TEST_ASSETS_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace impostor::testing {

// IMPOSTOR_ASSETS_DIR (compile definition), overridable by the environment
// variable of the same name.
std::filesystem::path AssetsDir();

// AssetsDir() / relative.
std::filesystem::path Asset(std::string_view relative);

// A fresh empty directory under the system temp dir, unique per call.
std::filesystem::path MakeScratchDir(std::string_view tag);

void WriteFile(const std::filesystem::path& path, std::string_view contents);

std::string Base64(const std::vector<uint8_t>& bytes);

// A one-triangle glTF (positions (0,0,0) (1,0,0) (0,1,0), ushort indices) in
// one buffer. `buffer_uri` empty = embedded data: uri.
struct TriangleOptions {
  std::string buffer_uri;
  std::vector<uint16_t> indices = {0, 1, 2};
  std::string nodes = R"([{"mesh": 0}])";
  std::string scene_nodes = "[0]";
  std::string extra_top_level;  // JSON members ending in ',', e.g. materials
  std::string primitive_extra;  // JSON members starting with ',', e.g. material
};
std::string TriangleGltf(const TriangleOptions& options);

// A PNG of `width` x `height` with `channels` (1 grey, 2 grey+alpha, 3 RGB,
// 4 RGBA) of `bit_depth` 8 or 16; `samples` holds width*height*channels
// values (only the low 8 bits used at depth 8). Uncompressed (stored
// deflate blocks), which every decoder accepts.
std::vector<uint8_t> MakePng(int width, int height, int channels, int bit_depth,
                             const std::vector<uint16_t>& samples);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SCENE_TEST_ASSETS_H_
