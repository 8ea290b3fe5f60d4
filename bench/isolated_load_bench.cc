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

#include "bench/bench_args.h"
#include "bench/median_time.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/isolated_load.h"

int main(int argc, char** argv) {
  const std::filesystem::path assets = IMPOSTOR_BENCH_ASSETS_DIR;
  std::vector<std::filesystem::path> files;
  std::vector<std::string> file_args;
  impostor::bench::BenchArgs("isolated_load_bench", "Times loading inputs in process and in an isolated child.")
      .Positional("FILE.glb", &file_args, "inputs to load (default DamagedHelmet and Duck)")
      .ParseOrExit(argc, argv);
  for (const std::string& f : file_args) files.emplace_back(f);
  if (files.empty()) {
    files = {assets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb",
             assets / "props_pbr/Duck/glTF-Binary/Duck.glb"};
  }
  // Before: the worker checked the file in a child, then loaded it again
  // itself (check + in-process). Now the child hands its scene back
  // (scene from child): the isolation costs the hand-over, not a load.
  std::printf("| asset | in-process load s | check in a child + load s | scene from child s | "
              "(check + load) / in-process | scene from child / in-process |\n|---|---|---|---|---|---|\n");
  for (const auto& f : files) {
    bool ok = true;
    const double in_process = impostor::bench::MedianSeconds(5, [&] { ok &= impostor::LoadGltfScene(f).ok(); });
    const double check = impostor::bench::MedianSeconds(5, [&] { ok &= impostor::CheckLoadInChild(f, {}, {}).ok(); });
    const double handed = impostor::bench::MedianSeconds(5, [&] { ok &= impostor::LoadSceneInChild(f, {}, {}).ok(); });
    std::printf("| %s | %.3f | %.3f | %.3f | %.2f | %.2f |%s\n", f.filename().string().c_str(), in_process,
                check + in_process, handed, (check + in_process) / in_process, handed / in_process,
                ok ? "" : " (a load failed)");
  }
  return 0;
}
