#include "worker/scene/image_predecode.h"

#include <algorithm>
#include <future>
#include <optional>
#include <thread>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "worker/scene/texel_arena.h"

namespace impostor::gltf_internal {

bool FitsDecodingAtOnce(const LoadCost& cost, const GltfLoadLimits& limits) {
  if (cost.decodable_images.size() < 2) return false;  // nothing to overlap
  // (Each sum is checked for wrapping: the costs saturate at 2^64 - 1.)
  const uint64_t texels_and_peaks = cost.texture_bytes + cost.texture_peak_sum_bytes;
  if (texels_and_peaks < cost.texture_bytes || texels_and_peaks > limits.max_texture_bytes) return false;
  // total_bytes counts the largest single peak; all of them instead.
  const uint64_t without_peak = cost.total_bytes - cost.texture_peak_bytes;
  const uint64_t total = without_peak + cost.texture_peak_sum_bytes;
  return total >= without_peak && total <= limits.max_load_bytes;
}

PredecodedImages PredecodeImages(const tinygltf::Model& model, const std::vector<int>& images,
                                 const GltfLoadLimits& limits) {
  std::vector<std::optional<absl::StatusOr<DecodedImage>>> decoded(images.size());
  TexelArena* const arena = CurrentTexelArena();
  auto decode = [&](size_t i) {
    const ScopedTexelArena in_arena(arena);
    const tinygltf::Image& image = model.images[static_cast<size_t>(images[i])];
    decoded[i] = DecodeImageRgba8(image.image, limits.max_texture_dimension, limits.max_texture_bytes,
                                  ImageWhat(model, images[i]));
  };
  // The calling thread takes the first share itself: its heap is warm,
  // where a new thread's is new memory to fault in (in a fresh sandbox
  // process, most of what an image's decode costs).
  const size_t threads = std::min<size_t>(images.size(), std::clamp<size_t>(std::thread::hardware_concurrency(), 1, 16));
  std::vector<std::future<void>> helpers;
  try {
    for (size_t t = 1; t < threads; ++t) {
      helpers.push_back(std::async(std::launch::async, [&, t] {
        for (size_t i = t; i < images.size(); i += threads) decode(i);
      }));
    }
  } catch (const std::system_error&) {
    // No thread for some shares (RLIMIT_AS): their images are decoded in
    // use order, by the material table.
  }
  for (size_t i = 0; i < images.size(); i += threads) decode(i);
  for (auto& helper : helpers) helper.get();
  PredecodedImages out;
  for (size_t i = 0; i < images.size(); ++i) {
    if (decoded[i].has_value()) out.emplace(images[i], std::move(*decoded[i]));
  }
  return out;
}

std::string ImageWhat(const tinygltf::Model& model, int index) {
  const tinygltf::Image& image = model.images[static_cast<size_t>(index)];
  return absl::StrCat("image[", index, "] '", image.name.empty() ? image.uri : image.name, "'");
}

}  // namespace impostor::gltf_internal
