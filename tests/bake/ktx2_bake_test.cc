// --texture-format ktx2 on a real bake (gpu; lavapipe suffices): the
// manifest lists KTX2 maps with codec, levels and precision, the files hold
// the full chain down to the 16 px tile, and decoded through the encoder's
// own transcoder they match the PNG bake of the same request within the
// stated error. The depth error that remains is measured and printed, and
// so is the alpha-tested coverage per mip level (coverage_by_level).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "common/atlas/frame_camera.h"
#include "tests/gpu/shared_renderer_test.h"
#include "tests/output/ktx2_test_util.h"
#include "worker/bake/atlas_bake.h"
#include "worker/output/ktx2_file.h"
#include "worker/output/map_writer.h"
#include "worker/output/tile_mip_chain.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing_ktx2::DecodeKtx2;
using testing_ktx2::RmsChannel;

const fs::path kAssets = IMPOSTOR_TEST_ASSETS_DIR;

// The bounds the manifest's `precision` states (worker/bake/ktx2_maps.cc),
// in 8-bit steps / fractions of the bounding-sphere diameter / degrees.
constexpr double kAlbedoRms = 7, kOrmRms = 14, kDepthRms = 1.0 / 255, kNormalMeanDegrees = 6;

fs::path ScratchDir(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_ktx2_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

const v1::MapFile* FindMap(const v1::Manifest& m, const std::string& semantic) {
  for (const v1::MapFile& map : m.maps()) {
    if (map.semantic() == semantic) return &map;
  }
  return nullptr;
}

class Ktx2BakeTest : public testing::SharedRendererTest {
 protected:
  static absl::StatusOr<AtlasBakeOutput> Bake(const fs::path& model, v1::BakeParameters in, const fs::path& dir) {
    in.set_quality_views(0);
    auto p = NormalizeParameters(in);
    if (!p.ok()) return p.status();
    const std::atomic<bool> cancelled{false};
    AtlasBakeRequest request{
        .entry_file = model, .parameters = *p, .cache_key = "ktx2-test", .output_dir = dir, .load_limits = {}};
    return BakeAtlas(request, *renderer_, [](std::string_view, double) {}, cancelled);
  }
};

TEST_F(Ktx2BakeTest, MapsDecodeBackToThePngBakeWithinTheStatedError) {
  const fs::path helmet = kAssets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  v1::BakeParameters params;
  params.set_frames(8);
  params.set_resolution(512);  // tiles of 64 px: levels 0..2 (64, 32, 16 px tiles)
  params.set_supersampling(1);
  const fs::path png_dir = ScratchDir("png"), ktx2_dir = ScratchDir("ktx2");
  auto png = Bake(helmet, params, png_dir);
  ASSERT_TRUE(png.ok()) << png.status();
  params.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  auto ktx2 = Bake(helmet, params, ktx2_dir);
  ASSERT_TRUE(ktx2.ok()) << ktx2.status();
  ASSERT_EQ(ktx2->manifest.resolution(), 512u);
  ASSERT_EQ(ktx2->manifest.tile_size(), 64u);
  const int levels = MipSafeLevels(512, 8) + 1;
  ASSERT_EQ(levels, 3);

  auto albedo_png = ReadPng(png_dir / "albedo_alpha.png");
  auto nd_png = ReadPng(png_dir / "normal_depth.png");
  auto orm_png = ReadPng(png_dir / "orm.png");
  ASSERT_TRUE(albedo_png.ok() && nd_png.ok() && orm_png.ok());
  EXPECT_FALSE(fs::exists(ktx2_dir / "albedo_alpha.png"));
  EXPECT_FALSE(fs::exists(ktx2_dir / ".ktx2_scratch"));

  std::vector<std::vector<MipLevel<uint8_t>>> decoded;
  for (const char* semantic : {"albedo_alpha", "normal_depth", "orm", "depth"}) {
    const v1::MapFile* map = FindMap(ktx2->manifest, semantic);
    ASSERT_NE(map, nullptr) << semantic;
    EXPECT_EQ(map->file(), std::string(semantic) + ".ktx2");
    EXPECT_EQ(map->format(), "ktx2_uastc");
    EXPECT_EQ(map->codec(), "uastc");
    EXPECT_EQ(map->levels(), static_cast<uint32_t>(levels));
    EXPECT_FALSE(map->precision().empty());
    EXPECT_EQ(map->channels_size(), 4);
    std::ifstream in(ktx2_dir / map->file(), std::ios::binary);
    std::stringstream bytes;
    bytes << in.rdbuf();
    EXPECT_EQ(static_cast<int64_t>(bytes.str().size()), map->digest().size_bytes());
    auto t = ParseKtx2(bytes.str());
    ASSERT_TRUE(t.ok()) << semantic << ": " << t.status();
    EXPECT_EQ(t->levels.size(), static_cast<size_t>(levels)) << semantic;
    EXPECT_EQ(t->Transfer(), std::string(semantic) == "albedo_alpha" ? kKtx2TransferSrgb : kKtx2TransferLinear);
    EXPECT_EQ(map->channels_size(), 4) << semantic;
    auto d = DecodeKtx2(ktx2_dir / map->file(), levels);
    ASSERT_TRUE(d.ok()) << semantic << ": " << d.status();
    decoded.push_back(std::move(*d));
  }
  const std::vector<uint8_t>& albedo = decoded[0][0].rgba;
  const std::vector<uint8_t>& nd = decoded[1][0].rgba;
  const std::vector<uint8_t>& orm = decoded[2][0].rgba;
  // Colour and ORM where the mesh is, coverage everywhere: a few 8-bit steps.
  for (int c = 0; c < 3; ++c) {
    const double a = RmsChannel(albedo, albedo_png->pixels8, c, &albedo_png->pixels8);
    const double o = RmsChannel(orm, orm_png->pixels8, c, &albedo_png->pixels8);
    std::printf("ktx2 channel %d RMS error (8-bit steps, covered texels): albedo %.2f, orm %.2f\n", c, a, o);
    EXPECT_LE(a, kAlbedoRms) << "albedo channel " << c;
    EXPECT_LE(o, kOrmRms) << "orm channel " << c;
  }
  const double coverage = RmsChannel(albedo, albedo_png->pixels8, 3);
  std::printf("ktx2 coverage RMS error: %.2f\n", coverage);
  EXPECT_LE(coverage, kAlbedoRms) << "coverage";
  // Depth (A of normal_depth, 16 bits in the PNG) and normals, covered texels.
  const std::vector<uint8_t>& depth_map = decoded[3][0].rgba;
  double depth_sq = 0, depth_max = 0, angle_sum = 0, nd_depth_sq = 0;
  std::vector<double> depth_errors;
  size_t n = 0;
  for (size_t i = 0; i < nd.size(); i += 4) {
    if (albedo_png->pixels8[i + 3] < 255) continue;  // fully covered texels: depth is defined there
    const double want = nd_png->pixels16[i + 3] / 65535.0, got = depth_map[i] / 255.0;
    const double e = std::abs(got - want);
    nd_depth_sq += (nd[i + 3] / 255.0 - want) * (nd[i + 3] / 255.0 - want);
    depth_sq += e * e;
    depth_max = std::max(depth_max, e);
    depth_errors.push_back(e);
    double a[3], b[3], la = 0, lb = 0, dot = 0;
    for (int c = 0; c < 3; ++c) {
      a[c] = nd_png->pixels16[i + c] / 65535.0 * 2 - 1;
      b[c] = nd[i + c] / 255.0 * 2 - 1;
      la += a[c] * a[c];
      lb += b[c] * b[c];
      dot += a[c] * b[c];
    }
    angle_sum += std::acos(std::clamp(dot / std::sqrt(la * lb + 1e-12), -1.0, 1.0)) * 180.0 / M_PI;
    ++n;
  }
  ASSERT_GT(n, 1000u);
  std::sort(depth_errors.begin(), depth_errors.end());
  const double depth_rms = std::sqrt(depth_sq / static_cast<double>(n));
  const double depth_p99 = depth_errors[depth_errors.size() * 99 / 100];
  const double angle_mean = angle_sum / static_cast<double>(n);
  const double nd_depth_rms = std::sqrt(nd_depth_sq / static_cast<double>(n));
  std::printf("ktx2 depth error (fraction of the bounding-sphere diameter), depth.ktx2: rms %.5f (%.2f/255) p99 %.5f "
              "max %.5f; normal_depth.ktx2 A: rms %.5f (%.2f/255); normal error mean %.2f deg\n",
              depth_rms, depth_rms * 255, depth_p99, depth_max, nd_depth_rms, nd_depth_rms * 255, angle_mean);
  RecordProperty("depth_rms", std::to_string(depth_rms));
  RecordProperty("depth_max", std::to_string(depth_max));
  RecordProperty("normal_mean_deg", std::to_string(angle_mean));
  EXPECT_LE(depth_rms, kDepthRms) << "the manifest states the bound";
  EXPECT_LE(angle_mean, kNormalMeanDegrees);
  // coverage_by_level: on the maps whose A is coverage, one figure per
  // level, the same for all of them; it is what the chain built from the
  // PNG bake's level 0 (the same texels) keeps, and the decoded files agree
  // within what compression moves across the cutoff.
  std::vector<TileRect> tiles;
  for (const v1::View& v : ktx2->manifest.views()) {
    tiles.push_back({static_cast<int>(v.tile().x()), static_cast<int>(v.tile().y()),
                     static_cast<int>(v.tile().width()), static_cast<int>(v.tile().height())});
  }
  const v1::MapFile* albedo_map = FindMap(ktx2->manifest, "albedo_alpha");
  ASSERT_EQ(albedo_map->coverage_by_level_size(), levels);
  EXPECT_EQ(albedo_map->coverage_by_level(0), 1.0);
  auto figures = [](const v1::MapFile* m) {
    return std::vector<double>(m->coverage_by_level().begin(), m->coverage_by_level().end());
  };
  EXPECT_EQ(figures(FindMap(ktx2->manifest, "orm")), figures(albedo_map));
  EXPECT_EQ(FindMap(ktx2->manifest, "normal_depth")->coverage_by_level_size(), 0);
  EXPECT_EQ(FindMap(ktx2->manifest, "depth")->coverage_by_level_size(), 0);
  auto kept = BuildCoverageMipChain(albedo_png->pixels8, 512, 512, tiles, levels);
  auto box = BuildCoverageMipChain(albedo_png->pixels8, 512, 512, tiles, levels, MipCoverage::kBoxFilter);
  ASSERT_TRUE(kept.ok() && box.ok());
  auto kept_ratios = CoverageByLevel(*kept, tiles);
  auto box_ratios = CoverageByLevel(*box, tiles);
  auto decoded_ratios = CoverageByLevel(decoded[0], tiles);
  ASSERT_TRUE(kept_ratios.ok() && box_ratios.ok() && decoded_ratios.ok());
  for (int l = 0; l < levels; ++l) {
    std::printf("ktx2 coverage level %d against level 0: manifest %.4f, decoded %.4f, plain box filter %.4f\n", l,
                albedo_map->coverage_by_level(l), (*decoded_ratios)[l], (*box_ratios)[l]);
    EXPECT_NEAR(albedo_map->coverage_by_level(l), (*kept_ratios)[l], 0.5e-4 + 1e-9) << "level " << l;
    EXPECT_NEAR((*decoded_ratios)[l], albedo_map->coverage_by_level(l), 0.03) << "level " << l;
  }
  // Levels below 0 are our chain: each a quarter of the one above.
  for (const auto& chain : decoded) {
    for (int l = 1; l < levels; ++l) EXPECT_EQ(chain[l].width, 512 >> l);
  }
  // bench/texture_format_bench.mjs compares these two folders: keep them
  // when asked to.
  if (const char* keep = std::getenv("IMPOSTOR_KEEP_KTX2_BAKE"); keep != nullptr && *keep != '\0') {
    fs::remove_all(fs::path(keep) / "png");
    fs::remove_all(fs::path(keep) / "ktx2");
    fs::create_directories(keep);
    fs::copy(png_dir, fs::path(keep) / "png", fs::copy_options::recursive);
    fs::copy(ktx2_dir, fs::path(keep) / "ktx2", fs::copy_options::recursive);
  }
  fs::remove_all(png_dir);
  fs::remove_all(ktx2_dir);
}

}  // namespace
}  // namespace impostor
