// What a game does with the SDK, in one file: fetch a baked impostor by its
// cache key through the local cache (downloaded once, from disk afterwards),
// then pick the atlas frames to blend for a few view directions with the
// runtime math (and, for a LOD chain, list its levels).
//
//   fetch_and_pick SERVER CACHE_DIR KEY
//
// Prints one line per file ("file SEMANTIC SHA256 SIZE") and one per view
// ("pick X Y Z: FRAME:WEIGHT ..."). Exit status 0 on success, 1 when the
// result cannot be had (the reason is printed), 2 on bad usage.
#include <cstdio>

#include "impostor/cache.h"
#include "impostor/lod.h"
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

  // A LOD chain: its levels, nearest first (the last is the atlas impostor,
  // described by the same manifest fields as an atlas result).
  if (result->product() == "lod-chain") {
    const absl::StatusOr<impostor::sdk::LodChain> chain = impostor::sdk::LoadLodChain(result->manifest_path());
    if (!chain.ok()) {
      std::printf("lod chain: %s\n", chain.status().ToString().c_str());
      return 1;
    }
    for (const impostor::sdk::LodLevelInfo& level : chain->levels) {
      std::printf("lod %d %s %s threshold %g\n", level.level,
                  level.kind == impostor::sdk::LodLevelInfo::Kind::kMesh ? "mesh" : "impostor", level.file.c_str(),
                  level.threshold);
    }
  }
  // Cards and surfels have no frames to pick.
  if (result->product() != "atlas" && result->product() != "lod-chain") {
    std::printf("product \"%s\" has no atlas frames to pick\n", result->product().c_str());
    return 1;
  }
  const auto layout = impostor::sdk::AtlasLayoutFromManifest(
      result->layout(), static_cast<int>(result->frames()), static_cast<int>(result->view_count()));
  if (!layout) {
    std::printf("layout \"%s\" with %u frames and %u views is not one this runtime draws\n",
                result->layout().c_str(), result->frames(), result->view_count());
    return 1;
  }
  std::printf("layout %s frames %d views %d\n", result->layout().c_str(), layout->frames,
              impostor::sdk::FrameCount(*layout));
  const float views[][3] = {{0, 1, 0}, {1, 0, 0}, {1, 1, 1}, {0, -0.2f, -1}};
  for (const auto& view : views) {
    const impostor::sdk::FrameBlend blend =
        impostor::sdk::BlendFrames(*layout, view, impostor::sdk::BlendMode::kTriangle3);
    std::printf("pick %g %g %g:", view[0], view[1], view[2]);
    for (int i = 0; i < blend.count; ++i) {
      std::printf(" %d:%.4f", blend.entries[i].frame, blend.entries[i].weight);
    }
    std::printf("\n");
  }
  return 0;
}
