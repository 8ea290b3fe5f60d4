// mip_coverage: the alpha-tested coverage of a PNG bake's albedo at every
// level of the mip chain a KTX2 bake of the same request would build, with
// the plain box filter and with the chain KTX2 bakes ship (coverage kept
// per tile, worker/output/coverage_scale.h), as ratios to level 0: the
// "before and after" of docs/ktx2.md. The bake's tiles must be aligned for
// the chain (a resolution that a KTX2 request keeps, e.g. 1024 px with 8
// frames); `bake_stages --keep DIR` makes such a folder.
//
//   mip_coverage BAKE_DIR
//
// Not a test: prints figures.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "bench/bench_args.h"
#include "common/atlas/frame_camera.h"
#include "common/manifest/manifest_json.h"
#include "worker/output/map_writer.h"
#include "worker/output/tile_mip_chain.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  std::vector<std::string> dirs;
  impostor::bench::BenchArgs("mip_coverage",
                             "A PNG bake's alpha-tested coverage per mip level: box filter against kept coverage.")
      .Positional("BAKE_DIR", &dirs, "a PNG bake's folder (manifest.json, albedo_alpha.png)")
      .ParseOrExit(argc, argv);
  if (dirs.size() != 1) {
    std::fprintf(stderr, "mip_coverage: give one BAKE_DIR\n");
    return 2;
  }
  const fs::path dir = dirs[0];
  std::ifstream in(dir / "manifest.json");
  std::stringstream text;
  text << in.rdbuf();
  auto manifest = impostor::ManifestFromJson(text.str());
  if (!manifest.ok()) {
    std::fprintf(stderr, "mip_coverage: %s: %s\n", (dir / "manifest.json").c_str(),
                 std::string(manifest.status().message()).c_str());
    return 1;
  }
  auto albedo = impostor::ReadPng(dir / "albedo_alpha.png");
  if (!albedo.ok() || albedo->channels != 4 || albedo->bit_depth != 8) {
    std::fprintf(stderr, "mip_coverage: %s: not an RGBA8 PNG (%s)\n", (dir / "albedo_alpha.png").c_str(),
                 albedo.ok() ? "wrong format" : std::string(albedo.status().message()).c_str());
    return 1;
  }
  std::vector<impostor::TileRect> tiles;
  for (const auto& v : manifest->views()) {
    tiles.push_back({static_cast<int>(v.tile().x()), static_cast<int>(v.tile().y()),
                     static_cast<int>(v.tile().width()), static_cast<int>(v.tile().height())});
  }
  // The levels a KTX2 bake stores: down to the 16 px tile.
  const int levels = impostor::MipSafeLevels(static_cast<int>(manifest->resolution()),
                                             static_cast<int>(manifest->frames())) + 1;
  std::printf("mip_coverage: %s, %d levels (%u px tiles down to %u px)\n", dir.c_str(), levels,
              manifest->tile_size(), manifest->tile_size() >> (levels - 1));
  for (auto mode : {impostor::MipCoverage::kBoxFilter, impostor::MipCoverage::kPreserveAlphaTest}) {
    auto chain = impostor::BuildCoverageMipChain(albedo->pixels8, albedo->width, albedo->height, tiles, levels, mode);
    if (!chain.ok()) {
      std::fprintf(stderr, "mip_coverage: %s\n", std::string(chain.status().message()).c_str());
      return 1;
    }
    auto ratios = impostor::CoverageByLevel(*chain, tiles);
    if (!ratios.ok()) {
      std::fprintf(stderr, "mip_coverage: %s\n", std::string(ratios.status().message()).c_str());
      return 1;
    }
    std::string line;
    for (double r : *ratios) {
      char figure[32];
      std::snprintf(figure, sizeof(figure), "%.4f", r);
      absl::StrAppend(&line, line.empty() ? "" : ", ", figure);
    }
    std::printf("  %-22s [%s]\n", mode == impostor::MipCoverage::kBoxFilter ? "box filter:" : "coverage kept (ktx2):",
                line.c_str());
  }
  return 0;
}
