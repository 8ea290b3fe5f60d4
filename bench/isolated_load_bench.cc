// isolated_load_bench: what loading an input first in a child process
// (worker/scene/isolated_load.h) adds to a bake's load stage. Loads each
// asset in process and in the child a few times and prints the medians.
// Not a test: prints figures.
//
//   build/bin/isolated_load_bench [ASSET...]   (default: DamagedHelmet and Duck)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "worker/scene/gltf_loader.h"
#include "worker/scene/isolated_load.h"

namespace {

using Clock = std::chrono::steady_clock;

template <typename F>
double MedianSeconds(int runs, F f) {
  std::vector<double> s;
  for (int i = 0; i < runs; ++i) {
    const auto t = Clock::now();
    f();
    s.push_back(std::chrono::duration<double>(Clock::now() - t).count());
  }
  std::sort(s.begin(), s.end());
  return s[s.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const std::filesystem::path assets = IMPOSTOR_BENCH_ASSETS_DIR;
  std::vector<std::filesystem::path> files;
  for (int i = 1; i < argc; ++i) files.emplace_back(argv[i]);
  if (files.empty()) {
    files = {assets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb",
             assets / "props_pbr/Duck/glTF-Binary/Duck.glb"};
  }
  // The worker loads in the child first and then again in process, so the
  // isolation adds the child's whole time (fork, load, exit) to the job.
  std::printf("| asset | in-process load s | load in a child s | child / in-process |\n|---|---|---|---|\n");
  for (const auto& f : files) {
    bool ok = true;
    const double in_process = MedianSeconds(5, [&] { ok &= impostor::LoadGltfScene(f).ok(); });
    const double child = MedianSeconds(5, [&] { ok &= impostor::CheckLoadInChild(f, {}, {}).ok(); });
    std::printf("| %s | %.3f | %.3f | %.2f |%s\n", f.filename().string().c_str(), in_process, child,
                child / in_process, ok ? "" : " (a load failed)");
  }
  return 0;
}
