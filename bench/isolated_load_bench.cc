// isolated_load_bench: what loading an input in the isolated loader
// (worker/scene/isolated_load.h) adds to a bake's load stage, beside the
// same load in process. The loader's process is kept between loads
// (worker/scene/load_sandbox.h): "fresh" is a load in a new process (a
// worker's first bake, or the one after a refused file), "reused" one in a
// process that loaded before (every other bake). Medians of 5 each, all in
// one run. Issue 45's target: reused / in-process <= 1.15. Not a test:
// prints figures.
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
  impostor::bench::BenchArgs("isolated_load_bench", "Times loading inputs in process and in the isolated loader.")
      .Positional("FILE.glb", &file_args, "inputs to load (default DamagedHelmet and Duck)")
      .ParseOrExit(argc, argv);
  for (const std::string& f : file_args) files.emplace_back(f);
  if (files.empty()) {
    files = {assets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb",
             assets / "props_pbr/Duck/glTF-Binary/Duck.glb"};
  }
  std::printf("| asset | in-process load s | isolated, fresh process s | isolated, reused process s | "
              "fresh / in-process | reused / in-process |\n|---|---|---|---|---|---|\n");
  uint64_t distinct = 0;
  for (const auto& f : files) {
    bool ok = true;
    const double in_process = impostor::bench::MedianSeconds(5, [&] { ok &= impostor::LoadGltfScene(f).ok(); });
    // The pool keeps processes per address-space setting: a setting never
    // used before gets a fresh process.
    const double fresh = impostor::bench::MedianSeconds(5, [&] {
      impostor::LoadIsolation isolation;
      isolation.address_space_bytes += 4096 * ++distinct;
      ok &= impostor::LoadSceneInChild(f, {}, isolation).ok();
    });
    ok &= impostor::LoadSceneInChild(f, {}, {}).ok();  // the reused process has loaded this file before
    const double reused = impostor::bench::MedianSeconds(5, [&] { ok &= impostor::LoadSceneInChild(f, {}, {}).ok(); });
    std::printf("| %s | %.3f | %.3f | %.3f | %.2f | %.2f |%s\n", f.filename().string().c_str(), in_process, fresh,
                reused, fresh / in_process, reused / in_process, ok ? "" : " (a load failed)");
  }
  return 0;
}
