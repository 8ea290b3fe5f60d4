// What a game does with the SDK, in one file: fetch a baked impostor by its
// cache key through the local cache (downloaded once, from disk afterwards),
// then pick the atlas frames to blend for a few view directions with the
// runtime math.
//
//   fetch_and_pick SERVER CACHE_DIR KEY
//
// Prints one line per file ("file SEMANTIC SHA256 SIZE") and one per view
// ("pick X Y Z: FRAME:WEIGHT ..."). Exit status 0 on success, 1 when the
// result cannot be had (the reason is printed), 2 on bad usage.
#include <cstdio>

#include "impostor/cache.h"
#include "impostor/runtime.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s SERVER CACHE_DIR KEY\n", argv[0]);
    return 2;
  }
  impostor::sdk::CacheOptions options;
  options.server = argv[1];
  options.dir = argv[2];
  auto cache = impostor::sdk::Cache::Open(options);
  if (!cache.ok()) {
    std::printf("open: %s\n", cache.status().ToString().c_str());
    return 1;
  }
  absl::StatusOr<impostor::sdk::CachedResult> result = (*cache)->Get(argv[3]);
  if (!result.ok()) {
    std::printf("get: %s\n", result.status().ToString().c_str());
    return 1;
  }
  std::printf("key %s %s\n", result->key().c_str(), result->downloaded() ? "downloaded" : "from-disk");
  for (const impostor::sdk::CachedFile& file : result->files()) {
    std::printf("file %s %s %lld\n", file.semantic.c_str(), file.sha256.c_str(),
                static_cast<long long>(file.size_bytes));
  }

  const auto layout = impostor::sdk::LayoutFromName(result->layout());
  if (!layout) {
    std::printf("unknown layout \"%s\"\n", result->layout().c_str());
    return 1;
  }
  const int frames = static_cast<int>(result->frames());
  std::printf("layout %s frames %d\n", result->layout().c_str(), frames);
  const float views[][3] = {{0, 1, 0}, {1, 0, 0}, {1, 1, 1}, {0, -0.2f, -1}};
  for (const auto& view : views) {
    const impostor::sdk::FrameBlend blend =
        impostor::sdk::BlendFrames(*layout, frames, view, impostor::sdk::BlendMode::kTriangle3);
    std::printf("pick %g %g %g:", view[0], view[1], view[2]);
    for (int i = 0; i < blend.count; ++i) {
      std::printf(" %d:%.4f", blend.entries[i].frame, blend.entries[i].weight);
    }
    std::printf("\n");
  }
  return 0;
}
