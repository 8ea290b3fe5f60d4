// bake_stages: one atlas bake in process (BakeAtlas, the worker's own
// pipeline, no server) with the stage timings the bake records, each as
// wall time and as process CPU time (all threads, lavapipe's included), so a
// profile on a busy machine can still be read: CPU seconds hardly move when
// other processes compete for the cores, wall seconds do.
//
//   bake_stages [--layout NAME] [--frames N] [--resolution R] [--supersampling S]
//               [--quality-views K] [--view-pixels P] [--repeat N] [--keep DIR]
//               [--impostor-views auto|cpu|device] [--texture-format png|ktx2] [ASSET.glb]
//
// A KTX2 bake also prints each coverage map's coverage_by_level (the
// alpha-tested area per mip level against level 0, docs/ktx2.md).
//
// Meant to run under `perf record -g`. Not a test: prints figures.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <spdlog/spdlog.h>

#include "bench/bench_args.h"
#include "absl/strings/str_cat.h"
#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"
#include "worker/bake/atlas_bake.h"

namespace fs = std::filesystem;

namespace {

double CpuSeconds() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

// Records when each stage starts (progress callback), in wall and CPU time.
struct StageClock {
  struct Mark {
    std::string stage;
    double wall, cpu;
  };
  std::vector<Mark> marks;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  double cpu_start = CpuSeconds();
  void Note(std::string_view stage) {
    if (!marks.empty() && marks.back().stage == stage) return;
    marks.push_back({std::string(stage), Wall(), CpuSeconds() - cpu_start});
  }
  double Wall() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }
};

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_level(std::getenv("BAKE_STAGES_DEBUG") ? spdlog::level::debug : spdlog::level::info);
  uint32_t frames = 12, resolution = 2048;
  int supersampling = -1, quality_views = -1, repeat = 1, view_pixels = 0;
  fs::path asset = fs::path(IMPOSTOR_BENCH_ASSETS_DIR) / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  fs::path keep;
  std::string keep_flag;
  std::string layout_name = "octahedral";
  std::vector<std::string> assets;
  bool on_frames = false;
  std::string impostor_views = "auto";
  std::string texture_format = "png";
  impostor::bench::BenchArgs("bake_stages", "One atlas bake in process with each stage's wall and CPU time.")
      .Text("--layout", &layout_name, "layout by manifest name, e.g. hemi-octahedral (default octahedral)")
      .Uint("--frames", &frames, "frames per side (default 12)")
      .Uint("--resolution", &resolution, "atlas size in pixels (default 2048)")
      .Int("--supersampling", &supersampling, "samples per side per pixel (default: the bake's own)")
      .Int("--quality-views", &quality_views, "held-out views of the quality pass; 0 skips it (default: the bake's own)")
      .Int("--repeat", &repeat, "bakes in a row (default 1)")
      .Int("--view-pixels", &view_pixels, "the quality pass's held-out view size (default 0: the bake's own)")
      .Text("--keep", &keep_flag, "copy the last bake's output folder here")
      .Switch("--on-frames", &on_frames,
              "put the quality pass's views on baked frames' own directions (the atlas's ceiling; with --keep, "
              "its view_NN files)")
      .Text("--impostor-views", &impostor_views,
            "who draws the quality pass's impostor views: auto, cpu or device (quality_pass.h; default auto)")
      .Text("--texture-format", &texture_format,
            "png or ktx2 (default png; ktx2 rounds the resolution down to block-aligned tiles)")
      .Positional("ASSET.glb", &assets, "the asset (default DamagedHelmet)")
      .ParseOrExit(argc, argv);
  impostor::ImpostorViewsOn views_on = impostor::ImpostorViewsOn::kAuto;
  if (impostor_views == "cpu") {
    views_on = impostor::ImpostorViewsOn::kCpu;
  } else if (impostor_views == "device") {
    views_on = impostor::ImpostorViewsOn::kDevice;
  } else if (impostor_views != "auto") {
    std::fprintf(stderr, "bake_stages: --impostor-views: '%s' is not auto, cpu or device\n", impostor_views.c_str());
    return 2;
  }
  if (!keep_flag.empty()) keep = keep_flag;
  if (!assets.empty()) asset = assets.back();
  impostor::v1::BakeParameters in;
  // By the manifest's own layout names (manifest_json.h).
  impostor::v1::Layout layout = impostor::v1::LAYOUT_UNSPECIFIED;
  for (impostor::v1::Layout l : {impostor::v1::LAYOUT_OCTAHEDRAL, impostor::v1::LAYOUT_HEMI_OCTAHEDRAL,
                                 impostor::v1::LAYOUT_AZIMUTH_ELEVATION, impostor::v1::LAYOUT_RING_TOP,
                                 impostor::v1::LAYOUT_BILLBOARD}) {
    if (impostor::LayoutJsonName(l) == layout_name) layout = l;
  }
  if (layout == impostor::v1::LAYOUT_UNSPECIFIED) {
    std::fprintf(stderr, "bake_stages: --layout: '%s' is not a layout (octahedral, hemi-octahedral, ...)\n",
                 layout_name.c_str());
    return 2;
  }
  in.set_layout(layout);
  in.set_frames(frames);
  in.set_resolution(resolution);
  if (supersampling >= 0) in.set_supersampling(static_cast<uint32_t>(supersampling));
  if (quality_views >= 0) in.set_quality_views(static_cast<uint32_t>(quality_views));
  if (texture_format == "ktx2") {
    in.set_texture_format(impostor::v1::TEXTURE_FORMAT_KTX2);
  } else if (texture_format != "png") {
    std::fprintf(stderr, "bake_stages: --texture-format: '%s' is not png or ktx2\n", texture_format.c_str());
    return 2;
  }
  auto p = impostor::NormalizeParameters(in);
  if (!p.ok()) {
    std::fprintf(stderr, "bake_stages: %s\n", std::string(p.status().message()).c_str());
    return 2;
  }
  auto renderer = impostor::AtlasRenderer::Create();
  if (!renderer.ok()) {
    std::fprintf(stderr, "bake_stages: %s\n", std::string(renderer.status().message()).c_str());
    return 1;
  }
  const fs::path scratch = keep.empty() ? fs::temp_directory_path() / absl::StrCat("impostor_bake_stages_", getpid())
                                        : keep;
  const std::atomic<bool> cancelled{false};
  std::printf("bake_stages: %s, %s %u x %u frames, %u px, supersampling %u, %u quality views, on %s\n",
              asset.filename().c_str(), layout_name.c_str(), frames, frames, p->resolution(), p->supersampling(),
              p->has_quality_views() ? p->quality_views() : 16u, (*renderer)->device().name.c_str());
  for (int r = 0; r < repeat; ++r) {
    fs::remove_all(scratch);
    fs::create_directories(scratch);
    impostor::AtlasBakeRequest request{.entry_file = asset,
                                       .parameters = *p,
                                       .cache_key = absl::StrCat("bake_stages ", asset.string()),
                                       .output_dir = scratch,
                                       .load_limits = {},
                                       .scene = nullptr,
                                       .serial_encode = false,
                                       .quality_overrides = {.view_pixels = view_pixels,
                                                             .on_frame_directions = on_frames,
                                                             .impostor_views_on = views_on}};
    StageClock clock;
    auto baked = impostor::BakeAtlas(
        request, **renderer, [&](std::string_view stage, double) { clock.Note(stage); }, cancelled);
    const double wall = clock.Wall(), cpu = CpuSeconds() - clock.cpu_start;
    if (!baked.ok()) {
      std::fprintf(stderr, "bake_stages: %s\n", baked.status().ToString().c_str());
      return 1;
    }
    const auto& t = baked->manifest.timings();
    std::printf("run %d: wall %.2f s (cpu %.2f s); recorded: load %.2f render %.2f readback %.2f encode %.2f\n", r,
                wall, cpu, t.load_seconds(), t.render_seconds(), t.readback_seconds(), t.encode_seconds());
    clock.marks.push_back({"end", wall, cpu});
    for (size_t i = 0; i + 1 < clock.marks.size(); ++i) {
      const auto& m = clock.marks[i];
      const auto& n = clock.marks[i + 1];
      std::printf("  from %-8s wall %6.2f s  cpu %6.2f s\n", m.stage.c_str(), n.wall - m.wall, n.cpu - m.cpu);
    }
    for (const auto& map : baked->manifest.maps()) {
      if (map.coverage_by_level_size() == 0) continue;
      std::string ratios;
      for (double r : map.coverage_by_level()) absl::StrAppend(&ratios, ratios.empty() ? "" : ", ", r);
      std::printf("  %s coverage_by_level: [%s]\n", map.semantic().c_str(), ratios.c_str());
    }
  }
  if (keep.empty()) fs::remove_all(scratch);
  return 0;
}
