// quality_table: the public quality claim. Bakes the props and vegetation of
// ../shared/assets at 8, 12 and 16 frames in the octahedral layouts, and
// azimuth-elevation 13 x 13, ring-top (24 + 1) and billboard, with the worker's
// own pipeline in process (BakeAtlas, whose quality pass renders the mesh
// from held-out views and reconstructs the impostor with the reference
// renderer), and writes a Markdown table of the measured figures.
//
//   build/bin/quality_table [--out docs/quality.md] [--resolution 1024]
//                           [--frames 8,12,16] [--only SUBSTRING]
//                           [--layouts hemi-octahedral,billboard]
//                           [--view-pixels 256] [--on-frames]
//
// Held-out directions are seeded from "<asset> <layout> <frames>
// <resolution>" (the quality pass takes any key), so the table is the same
// on every run on the same device; a farm bake seeds them from its cache key
// and measures other, equally valid, views.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"
#include "bench/bench_args.h"
#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"
#include "worker/bake/atlas_bake.h"
#ifdef IMPOSTOR_BENCH_PROCEDURAL_TREE
#include "tests/support/procedural_tree.h"
#endif

namespace {

namespace fs = std::filesystem;
using impostor::v1::BakeParameters;

struct Asset {
  const char* name;
  const char* kind;  // "prop" or "vegetation"
  const char* path;  // relative to the assets directory; nullptr: the procedural tree
};

// Every textured prop and every plant of MANIFEST.md's (a) and (b) that is
// a single object, and BoxTextured, a 12-triangle cube that issue 17's
// targets name (Box is the same cube untextured; the AlphaBlendModeTest is a
// test chart, not a plant).
const Asset kAssets[] = {
    {"DamagedHelmet", "prop", "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb"},
    {"TreeLowPoly (MASK)", "vegetation", "vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf"},
    {"WaterBottle", "prop", "props_pbr/WaterBottle/glTF/WaterBottle.gltf"},
    {"StylizedTree", "vegetation", "vegetation/StylizedTree_ChrisCLP/jungletree.glb"},
    {"Duck", "prop", "props_pbr/Duck/glTF-Binary/Duck.glb"},
    {"CommonTree_1", "vegetation", "vegetation/Quaternius_CommonTree_1/CommonTree_1.glb"},
    {"Avocado", "prop", "props_pbr/Avocado/glTF/Avocado.gltf"},
    {"GlassVaseFlowers", "vegetation", "vegetation/GlassVaseFlowers/glTF-Binary/GlassVaseFlowers.glb"},
    {"Fox", "prop", "props_pbr/Fox/glTF-Binary/Fox.glb"},
    {"BoxTextured", "prop", "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb"},
#ifdef IMPOSTOR_BENCH_PROCEDURAL_TREE
    // Issue 43's tree with thin branches, generated here (tests/support/
    // procedural_tree.h): twigs about a third of a texel wide at 12 x 12,
    // 2048 px.
    {"ProceduralTree (generated)", "vegetation", nullptr},
#endif
};

struct Row {
  std::string asset, kind, layout;
  uint32_t frames = 0;
  impostor::v1::AtlasQuality quality;
  double seconds = 0;
  double pass_seconds = 0;  // the quality pass's share (its event=quality_pass log line)
  // --pass-cost N: the medians of N bakes with the pass and N without,
  // interleaved (the pass overlaps the maps' encoding, so its own seconds
  // overstate what it adds to the bake's wall time); 0 when not measured.
  double with_pass_seconds = 0, without_pass_seconds = 0;
  // --pop-references: the pass's pop references (quality_pass.h), else -1.
  double pop_antialiased_mesh = -1, pop_antialiased = -1;
  // --pop-references: the mesh's own one-sample held-out views against its
  // 3 x 3 ones (quality_pass.h's IoU reference), else -1.
  double one_sample_mesh_iou_mean = -1, one_sample_mesh_iou_min = -1;
  std::string error;
};

// The value of ` field=` on the last `event=NAME ` line of `log`, or
// `missing` when there is no such line or field.
double LastEventField(const std::string& log, const std::string& event_name, const std::string& field,
                      double missing) {
  const size_t event = log.rfind("event=" + event_name + " ");
  if (event == std::string::npos) return missing;
  const size_t line_end = log.find('\n', event);
  const std::string key = " " + field + "=";
  const size_t at = log.find(key, event);
  if (at == std::string::npos || at > line_end) return missing;
  return std::atof(log.c_str() + at + key.size());
}

// The middle value (the mean of the two middle ones for an even count); 0 for none.
double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t mid = v.size() / 2;
  return v.size() % 2 == 1 ? v[mid] : (v[mid - 1] + v[mid]) / 2;
}

// "8,12,16"; false if any item is not a whole number.
bool ParseList(const std::string& s, std::vector<uint32_t>* out) {
  out->clear();
  for (const absl::string_view item : absl::StrSplit(s, ',')) {
    uint32_t n = 0;
    if (!absl::SimpleAtoi(item, &n)) return false;
    out->push_back(n);
  }
  return !out->empty();
}

}  // namespace

int main(int argc, char** argv) {
  // The quality pass logs its own time at info; capture it per bake.
  std::ostringstream log;
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("quality_table", std::make_shared<spdlog::sinks::ostream_sink_mt>(log)));
  spdlog::set_level(spdlog::level::info);
  std::string out_flag = IMPOSTOR_BENCH_SOURCE_DIR "/docs/quality.md";
  uint32_t resolution = 1024;
  std::string frames_flag = "8,12,16";
  std::string only;
  std::string layouts;  // manifest names, comma separated; empty = all
  int view_pixels = 0;
  bool on_frames = false;
  bool pop_references = false;
  int pass_cost_rounds = 0;
  impostor::bench::BenchArgs("quality_table", "Bakes the quality table's assets in process and writes the table.")
      .Text("--out", &out_flag, "the Markdown file to write (default docs/quality.md)")
      .Uint("--resolution", &resolution, "atlas size in pixels (default 1024)")
      .Text("--frames", &frames_flag, "frame counts, comma separated (default 8,12,16)")
      .Text("--only", &only, "assets whose name contains one of these, comma separated (default all)")
      .Text("--layouts", &layouts, "layouts by manifest name, comma separated (default all)")
      .Int("--view-pixels", &view_pixels, "held-out view size (default 0: the pass's own, min(128, resolution / 8))")
      .Switch("--on-frames", &on_frames, "put the views on baked frames' own directions (the atlas's ceiling)")
      .Switch("--pop-references", &pop_references,
              "also measure the pop of smoother renderings (the mesh antialiased; both sides antialiased)")
      .Int("--pass-cost", &pass_cost_rounds,
           "also bake each row N more times with and N without the pass, interleaved, after one warm-up bake, and "
           "report the medians' difference (default 0: off)")
      .ParseOrExit(argc, argv);
  if (pass_cost_rounds < 0 || pass_cost_rounds > 50) {
    std::fprintf(stderr, "quality_table: --pass-cost %d is out of range 0..50\n", pass_cost_rounds);
    return 2;
  }
  std::vector<uint32_t> frame_counts;
  if (!ParseList(frames_flag, &frame_counts)) {
    std::fprintf(stderr, "quality_table: --frames: '%s' is not a comma-separated list of whole numbers\n",
                 frames_flag.c_str());
    return 2;
  }
  const fs::path out_path = out_flag;
  const fs::path assets = std::getenv("IMPOSTOR_ASSETS_DIR") != nullptr ? fs::path(std::getenv("IMPOSTOR_ASSETS_DIR"))
                                                                         : fs::path(IMPOSTOR_BENCH_ASSETS_DIR);

  auto renderer = impostor::AtlasRenderer::Create();
  if (!renderer.ok()) {
    std::fprintf(stderr, "quality_table: %s\n", std::string(renderer.status().message()).c_str());
    return 1;
  }
  const fs::path scratch = fs::temp_directory_path() / absl::StrCat("impostor_quality_table_", getpid());
  const fs::path generated = fs::temp_directory_path() / absl::StrCat("impostor_quality_table_", getpid(), "_assets");
  std::vector<Row> rows;
  const std::atomic<bool> cancelled{false};
  // Written after every row, so a long run leaves a table of what it did.
  auto write_table = [&](const std::vector<Row>& rows, bool complete) -> bool {
    std::string md;
    absl::StrAppend(&md, "# Impostor quality\n\n",
                    "Measured by `build/bin/quality_table` (bench/quality_table.cc) on `", (*renderer)->device().name,
                    "`, baker ", std::string(impostor::BakerVersion()), ", atlas ", resolution, " px.\n\n",
                    on_frames ? "**--on-frames: every view is on a baked frame's own direction, not held out** (the "
                                "atlas's ceiling: every reconstruction returns the frame itself there).\n\n"
                              : "",
                    "Every row is one bake by the worker's own pipeline. The quality pass renders the mesh from 16 "
                    "held-out view directions that are not baked frames (spread over the layout's domain) and the "
                    "impostor for the same cameras with ",
                    (*renderer)->device().type == "cpu"
                        ? "the CPU reference renderer"
                        : "the runtime shader on the device (the CPU reference renderer's pixels up to float ties)",
                    " (3-frame triangle blend) in both "
                    "runtime reconstructions (docs/runtime.md): **depth** (the default; every blended frame samples "
                    "the common surface point, frames that did not see it drop out) and **plain** (flat virtual "
                    "planes), both unlit, each view ",
                    rows.empty() ? 0u : rows.front().quality.view_pixels(),
                    " px; the mesh's held-out views are supersampled 3 x 3 (each pixel its area, "
                    "worker/bake/quality_pass.h), the pop orbit's are one sample per pixel like the impostor's (filtered by mip level, no anisotropic filtering on a CPU device). "
                    "Each cell is depth / plain. IoU: silhouette intersection over union. PSNR and SSIM: albedo "
                    "over the pixels both renders cover (colour fidelity; silhouette misses are IoU's and the "
                    "boundary error's). Boundary: mean distance in view pixels between the two silhouettes' "
                    "boundaries. Union PSNR: the format-1 figure, over the union of both silhouettes composited over "
                    "black. Normal: mean angle between the normals where both cover. Pop: the largest change of the "
                    "impostor between neighbouring 1 degree steps of an orbit at 20 degrees elevation relative to "
                    "the mesh's own change (1.0 = as smooth as the mesh). Pass share: the quality pass's own seconds "
                    "over the bake's wall time (both modes and both orbits); the pass runs beside the maps' PNG "
                    "encoders, so this overstates what it adds. ",
                    pass_cost_rounds > 0
                        ? absl::StrCat("Pass cost: what the pass adds to the bake's wall time, (median with - median "
                                       "without) / median with, over ", pass_cost_rounds,
                                       " bakes each way, interleaved, after a warm-up bake (the process's first bake "
                                       "also compiles the device's shaders); the bake's seconds and the pass share "
                                       "are then those bakes' medians too. ")
                        : std::string(),
                    "Format of every figure: manifest_format.md (`quality`).\n\n",
                    "| asset | kind | layout | frames | IoU mean | IoU min | PSNR mean (dB) | PSNR min (dB) | SSIM mean "
                    "| boundary (px) | union PSNR (dB) | normal mean (deg) | pop | bake + pass (s) | pass share |",
                    pass_cost_rounds > 0 ? " bake without pass (s) | pass cost |\n" : "\n",
                    "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
                    pass_cost_rounds > 0 ? "---:|---:|\n" : "\n");
    for (const Row& r : rows) {
      const auto& q = r.quality;
      if (!r.error.empty()) {
        absl::StrAppend(&md, "| ", r.asset, " | ", r.kind, " | ", r.layout, " | ", r.frames, " | failed: ", r.error,
                        " | | | | | | | | | | |", pass_cost_rounds > 0 ? " | |\n" : "\n");
        continue;
      }
      const auto& p = q.plain();
      absl::StrAppend(
          &md, absl::StrFormat("| %s | %s | %s | %u | %.3f / %.3f | %.3f / %.3f | %.1f / %.1f | %.1f / %.1f | "
                               "%.3f / %.3f | %.2f / %.2f | %.1f / %.1f | %.1f / %.1f | %.2f / %.2f | %.1f | %.0f %% |",
                               r.asset, r.kind, r.layout, r.frames, q.silhouette_iou_mean(), p.silhouette_iou_mean(),
                               q.silhouette_iou_min(), p.silhouette_iou_min(), q.albedo_psnr_shared_db_mean(),
                               p.albedo_psnr_shared_db_mean(), q.albedo_psnr_shared_db_min(),
                               p.albedo_psnr_shared_db_min(), q.albedo_ssim_shared_mean(), p.albedo_ssim_shared_mean(),
                               q.boundary_error_px_mean(), p.boundary_error_px_mean(), q.albedo_psnr_union_db_mean(),
                               p.albedo_psnr_union_db_mean(), q.normal_error_deg_mean(), p.normal_error_deg_mean(),
                               q.pop(), p.pop(), r.seconds, r.seconds > 0 ? 100.0 * r.pass_seconds / r.seconds : 0.0));
      if (pass_cost_rounds > 0) {
        absl::StrAppend(&md, absl::StrFormat(" %.2f | %.0f %% |", r.without_pass_seconds,
                                             r.with_pass_seconds > 0
                                                 ? 100.0 * (r.with_pass_seconds - r.without_pass_seconds) /
                                                       r.with_pass_seconds
                                                 : 0.0));
      }
      absl::StrAppend(&md, "\n");
    }
    // Issue 43: pop as a player sees it and the on-screen size each bake is
    // good for, with the figures at the ladder's sizes nearest 32, 64, 128
    // and 256 px.
    absl::StrAppend(
        &md, "\nPop antialiased and good-for size (issue 43, quality_pass.h, good_for_size.h): **pop AA** is the pop "
             "formula with both orbits supersampled 3 x 3 (the figure targets use; the mesh scores 1.0), beside the "
             "one-sample **pop**. **Good up to**: the largest on-screen size at which the impostor (depth mode) still "
             "meets the good-for targets (IoU mean >= 0.95 outside the mesh's own antialiased edge, and PSNR where both "
             "cover >= 28 dB, means over the held-out views) at every size of the ladder up to it; each size cell is "
             "IoU (IoU outside the mesh's edge) / PSNR (dB).\n\n"
             "| asset | layout | frames | pop | pop AA | good up to (px) | 32 px | 64 px | 128 px | 256 px |\n"
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (const Row& r : rows) {
      if (!r.error.empty()) continue;
      const auto& q = r.quality;
      std::string cells;
      for (uint32_t want : {32u, 64u, 128u, 256u}) {
        const impostor::v1::SizeQuality* at = nullptr;
        for (const auto& sq : q.sizes()) {
          if (sq.pixels() == want) at = &sq;
        }
        absl::StrAppend(&cells, at ? absl::StrFormat(" %.3f (%.3f) / %.1f%s |", at->silhouette_iou_mean(),
                                                     at->silhouette_iou_firm_mean(), at->albedo_psnr_shared_db_mean(),
                                                     at->meets() ? "" : " ✗")
                                   : std::string(" |"));
      }
      absl::StrAppend(&md, absl::StrFormat("| %s | %s | %u | %.2f | %.2f | %u |%s\n", r.asset, r.layout, r.frames,
                                           q.pop(), q.pop_antialiased(), q.good_up_to_pixels(), cells));
    }
    if (pop_references) {
      absl::StrAppend(
          &md, "\nPop references (`--pop-references`, quality_pass.h): the same pop formula applied to smoother "
               "renderings. **Antialiased mesh**: the mesh's own orbit supersampled 3 x 3 against its one-sample "
               "orbit, a rendering without any reconstruction error that only changes more evenly from step to "
               "step. **Antialiased**: the depth reconstruction against the mesh with both orbits supersampled "
               "3 x 3. **One-sample mesh IoU**: the mesh's own held-out views drawn with one sample per pixel, "
               "as the impostor's are, against its 3 x 3 views (mean / worst view), beside the impostor's IoU "
               "(depth): what sampling alone costs a silhouette.\n\n"
               "| asset | layout | frames | pop (depth) | antialiased mesh | antialiased (depth) | one-sample mesh "
               "IoU | IoU (depth) |\n|---|---|---:|---:|---:|---:|---:|---:|\n");
      for (const Row& r : rows) {
        if (!r.error.empty()) continue;
        absl::StrAppend(&md, absl::StrFormat("| %s | %s | %u | %.2f | %.2f | %.2f | %.3f / %.3f | %.3f / %.3f |\n",
                                             r.asset, r.layout, r.frames, r.quality.pop(), r.pop_antialiased_mesh,
                                             r.pop_antialiased, r.one_sample_mesh_iou_mean,
                                             r.one_sample_mesh_iou_min, r.quality.silhouette_iou_mean(),
                                             r.quality.silhouette_iou_min()));
      }
    }
    if (!complete) absl::StrAppend(&md, "\n(incomplete: the run is still going or was stopped)\n");
    absl::StrAppend(&md, "\nReproduce: `cmake --build build --target quality_table && build/bin/quality_table --resolution ",
                    resolution, "` (writes this file; `--frames 8,12,16`, `--only NAME` and `--layouts a,b` narrow it; "
                    "`--view-pixels N` sets the held-out views' size, `--on-frames` measures on the frames' own "
                    "directions instead, `--pop-references` adds the pop references, `--pass-cost N` the pass's "
                    "cost over N bakes each way).\n");
    std::ofstream out(out_path, std::ios::trunc);
    out << md;
    out.close();
    return static_cast<bool>(out);
  };
  for (const Asset& asset : kAssets) {
    // --only A,B: assets whose name contains any of the substrings.
    if (!only.empty() && [&] {
          for (absl::string_view part : absl::StrSplit(only, ',')) {
            if (!part.empty() && absl::StrContains(asset.name, part)) return false;
          }
          return true;
        }()) {
      continue;
    }
    // The octahedral layouts at every count of the ladder; the others once,
    // at their defaults (azimuth-elevation 13 x 13 ~ 12 x 12, ring-top 24 + 1,
    // billboard 3 x 3).
    struct Config {
      impostor::v1::Layout layout;
      uint32_t frames;  // 0 = derived
    };
    std::vector<Config> configs;
    for (auto layout : {impostor::v1::LAYOUT_OCTAHEDRAL, impostor::v1::LAYOUT_HEMI_OCTAHEDRAL}) {
      for (uint32_t frames : frame_counts) configs.push_back({layout, frames});
    }
    configs.push_back({impostor::v1::LAYOUT_AZIMUTH_ELEVATION, 13});
    configs.push_back({impostor::v1::LAYOUT_RING_TOP, 0});
    configs.push_back({impostor::v1::LAYOUT_BILLBOARD, 0});
    fs::path entry_file = asset.path != nullptr ? assets / asset.path : fs::path();
#ifdef IMPOSTOR_BENCH_PROCEDURAL_TREE
    if (asset.path == nullptr) {
      fs::create_directories(generated);
      entry_file = generated / "procedural_tree.glb";
      auto tree = impostor::testing::WriteProceduralTree(entry_file);
      if (!tree.ok()) {
        std::fprintf(stderr, "quality_table: %s\n", std::string(tree.status().message()).c_str());
        return 1;
      }
    }
#endif
    for (const Config& config : configs) {
      const auto layout = config.layout;
      const std::string name(impostor::LayoutJsonName(layout));
      if (!layouts.empty() && absl::StrCat(",", layouts, ",").find(absl::StrCat(",", name, ",")) == std::string::npos) {
        continue;
      }
      {
        BakeParameters in;
        in.set_layout(layout);
        in.set_frames(config.frames);
        in.set_resolution(resolution);
        Row row;
        row.asset = asset.name;
        row.kind = asset.kind;
        row.layout = std::string(impostor::LayoutJsonName(layout));
        auto p = impostor::NormalizeParameters(in);
        if (!p.ok()) {
          std::fprintf(stderr, "quality_table: %s\n", std::string(p.status().message()).c_str());
          return 2;
        }
        const uint32_t frames = p->frames();
        row.frames = frames;
        fs::remove_all(scratch);
        fs::create_directories(scratch);
        impostor::AtlasBakeRequest request{
            .entry_file = entry_file,
            .parameters = *p,
            .cache_key = absl::StrCat(asset.path != nullptr ? asset.path : "procedural_tree", " ", row.layout, " ",
                                      frames, " ", resolution),
            .output_dir = scratch,
            .load_limits = {},
            .scene = nullptr,
            .serial_encode = false,
            .quality_overrides = {
                .view_pixels = view_pixels, .on_frame_directions = on_frames, .pop_references = pop_references}};
        const auto start = std::chrono::steady_clock::now();
        auto baked = impostor::BakeAtlas(request, **renderer, [](std::string_view, double) {}, cancelled);
        row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        row.pass_seconds = LastEventField(log.str(), "quality_pass", "seconds", 0);
        row.pop_antialiased_mesh =
            LastEventField(log.str(), "quality_pass_pop_references", "pop_antialiased_mesh", -1);
        row.pop_antialiased = LastEventField(log.str(), "quality_pass_pop_references", "pop_antialiased", -1);
        row.one_sample_mesh_iou_mean =
            LastEventField(log.str(), "quality_pass_pop_references", "one_sample_mesh_iou_mean", -1);
        row.one_sample_mesh_iou_min =
            LastEventField(log.str(), "quality_pass_pop_references", "one_sample_mesh_iou_min", -1);
        log.str("");
        if (baked.ok()) {
          row.quality = baked->manifest.quality();
        } else {
          row.error = std::string(baked.status().message());
        }
        if (pass_cost_rounds > 0 && row.error.empty()) {
          // The bake above was this row's warm-up; now the two kinds in turn.
          impostor::AtlasBakeRequest without = request;
          without.parameters.set_quality_views(0);
          std::vector<double> with_seconds, without_seconds, pass_seconds;
          for (int round = 0; round < pass_cost_rounds && row.error.empty(); ++round) {
            for (impostor::AtlasBakeRequest* r : {&without, &request}) {
              fs::remove_all(scratch);
              fs::create_directories(scratch);
              const auto t = std::chrono::steady_clock::now();
              auto again = impostor::BakeAtlas(*r, **renderer, [](std::string_view, double) {}, cancelled);
              const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
              if (!again.ok()) row.error = std::string(again.status().message());
              (r == &request ? with_seconds : without_seconds).push_back(seconds);
              if (r == &request) pass_seconds.push_back(LastEventField(log.str(), "quality_pass", "seconds", 0));
              log.str("");
            }
          }
          row.with_pass_seconds = Median(with_seconds);
          row.without_pass_seconds = Median(without_seconds);
          // The share too from the measured bakes, not the warm-up.
          row.seconds = row.with_pass_seconds;
          row.pass_seconds = Median(pass_seconds);
        }
        const auto& q = row.quality;
        std::fprintf(stderr,
                     "%-20s %-16s %2u frames: depth IoU %.4f PSNR %.2f dB SSIM %.3f pop %.2f | plain IoU %.4f PSNR "
                     "%.2f dB pop %.2f (%.1f s, pass %.1f s%s)%s%s\n",
                     asset.name, row.layout.c_str(), frames, q.silhouette_iou_mean(), q.albedo_psnr_shared_db_mean(),
                     q.albedo_ssim_shared_mean(), q.pop(), q.plain().silhouette_iou_mean(),
                     q.plain().albedo_psnr_shared_db_mean(), q.plain().pop(), row.seconds, row.pass_seconds,
                     row.with_pass_seconds > 0
                         ? absl::StrFormat("; median %.2f s with, %.2f s without", row.with_pass_seconds,
                                           row.without_pass_seconds)
                               .c_str()
                         : "",
                     row.error.empty() ? "" : " error: ", row.error.c_str());
        rows.push_back(std::move(row));
        write_table(rows, false);
      }
    }
  }
  fs::remove_all(scratch);
  fs::remove_all(generated);

  if (!write_table(rows, true)) {
    std::fprintf(stderr, "quality_table: cannot write %s\n", out_path.string().c_str());
    return 4;
  }
  std::printf("%s\n", out_path.string().c_str());
  return 0;
}
