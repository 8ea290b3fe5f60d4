// runtime_bench: the CPU reference renderer (common/runtime/reference_renderer.h)
// drawing an impostor, per mode, on one thread. The quality pass draws its
// held-out views and pop orbit with it, so its speed is much of the pass's
// cost. The atlas is rendered here by the bake's renderer (one sample, no
// dilation: enough for timing).
//
//   runtime_bench [--frames N] [--resolution R] [--views K] [--pixels P] [ASSET.glb]
//
// Prints milliseconds per view and nanoseconds per pixel for plain and
// depth, and a digest of the pixels so a change meant to be exact can be
// checked to be so. Figures on a shared machine are noisy: compare within
// one run.
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/bench_args.h"
#include "common/atlas/atlas_layout.h"
#include "common/runtime/reference_renderer.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/bake/bake_outputs.h"
#include "worker/scene/gltf_loader.h"

namespace fs = std::filesystem;

namespace {

// FNV-1a over the views' bytes.
uint64_t Digest(const std::vector<impostor::ViewImages>& views) {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const auto& bytes) {
    for (auto v : bytes) {
      h ^= static_cast<uint64_t>(v);
      h *= 1099511628211ull;
    }
  };
  for (const auto& v : views) {
    mix(v.albedo_alpha);
    mix(v.normal_depth);
  }
  return h;
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 12, resolution = 2048, views = 16, pixels = 128;
  fs::path asset = fs::path(IMPOSTOR_BENCH_ASSETS_DIR) / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  std::vector<std::string> assets;
  impostor::bench::BenchArgs("runtime_bench", "Times the CPU reference renderer's views of a baked atlas.")
      .Int("--frames", &frames, "frames per side (default 12)")
      .Int("--resolution", &resolution, "atlas size in pixels (default 2048)")
      .Int("--views", &views, "views to render (default 16)")
      .Int("--pixels", &pixels, "view size in pixels (default 128)")
      .Positional("ASSET.glb", &assets, "the asset (default DamagedHelmet)")
      .ParseOrExit(argc, argv);
  if (!assets.empty()) asset = assets.back();
  auto scene = impostor::LoadGltfScene(asset, {});
  if (!scene.ok()) {
    std::fprintf(stderr, "runtime_bench: %s\n", scene.status().ToString().c_str());
    return 1;
  }
  auto sphere = impostor::FramingSphere(*scene);
  auto renderer = impostor::AtlasRenderer::Create();
  if (!sphere.ok() || !renderer.ok()) {
    std::fprintf(stderr, "runtime_bench: %s\n",
                 (!sphere.ok() ? sphere.status() : renderer.status()).ToString().c_str());
    return 1;
  }
  impostor::ImpostorAtlas atlas;
  atlas.layout = impostor::LayoutKind::kHemiOctahedral;
  atlas.frames = frames;
  atlas.resolution = resolution;
  atlas.sphere = *sphere;
  atlas.cameras = impostor::AtlasCameras(impostor::AtlasViewLayout(atlas), resolution);
  auto maps = (*renderer)->Render(*scene, atlas.sphere, atlas.cameras, resolution, {}, nullptr);
  if (!maps.ok()) {
    std::fprintf(stderr, "runtime_bench: %s\n", maps.status().ToString().c_str());
    return 1;
  }
  atlas.width = maps->width;
  atlas.height = maps->height;
  atlas.albedo_alpha = std::move(maps->albedo_alpha);
  atlas.normal_depth = std::move(maps->normal_depth);
  atlas.orm = std::move(maps->orm);

  // Views spread over the upper hemisphere, off the frames' directions.
  std::vector<impostor::FrameCamera> cameras;
  for (int i = 0; i < views; ++i) {
    const double t = (i + 0.5) / views, y = 0.05 + 0.9 * t, r = std::sqrt(1.0 - y * y), phi = 2.39996 * i + 0.1;
    const glm::vec3 direction(static_cast<float>(r * std::sin(phi)), static_cast<float>(y),
                              static_cast<float>(r * std::cos(phi)));
    cameras.push_back(impostor::ViewCameraFor(direction));
    cameras.back().tile = {0, 0, pixels, pixels};
  }
  std::printf("runtime_bench: %s, hemi-octahedral %dx%d at %d px, %d views of %d px, one thread\n",
              asset.filename().c_str(), frames, frames, resolution, views, pixels);
  std::printf("%-6s %10s %10s %18s\n", "mode", "ms/view", "ns/pixel", "digest");
  for (impostor::Reconstruction mode : {impostor::Reconstruction::kPlain, impostor::Reconstruction::kDepth}) {
    const impostor::ReferenceRenderOptions options{.reconstruction = mode};
    std::vector<impostor::ViewImages> out;
    const auto start = std::chrono::steady_clock::now();
    for (const auto& camera : cameras) out.push_back(impostor::RenderImpostorView(atlas, camera, pixels, options));
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("%-6s %10.2f %10.1f %18llx\n", std::string(impostor::ReconstructionName(mode)).c_str(),
                1e3 * seconds / views, 1e9 * seconds / (static_cast<double>(views) * pixels * pixels),
                static_cast<unsigned long long>(Digest(out)));
  }
  return 0;
}
