// Alpha-tested coverage through the mip chain (worker/output/coverage_scale.h,
// MipCoverage in tile_mip_chain.h): thin features the box filter drops keep
// their area, empty and full tiles are untouched, tiles are scaled apart,
// the bytes are deterministic, and the manifest carries the figures.
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/manifest/manifest_json.h"
#include "worker/output/coverage_scale.h"
#include "worker/output/tile_mip_chain.h"

namespace impostor {
namespace {

constexpr int kTile = 64;
constexpr int kLevels = 4;  // 64, 32, 16, 8 px tiles

// An RGBA8 image of `tiles_wide` 64 px tiles in a row; `alpha(tile, x, y)`
// gives each texel's coverage, colour is an arbitrary function of position.
template <typename Alpha>
std::vector<uint8_t> MakeImage(int tiles_wide, Alpha alpha) {
  const int width = tiles_wide * kTile;
  std::vector<uint8_t> rgba(static_cast<size_t>(width) * kTile * 4);
  for (int y = 0; y < kTile; ++y) {
    for (int x = 0; x < width; ++x) {
      const size_t i = (static_cast<size_t>(y) * width + x) * 4;
      rgba[i + 0] = static_cast<uint8_t>(x * 3);
      rgba[i + 1] = static_cast<uint8_t>(y * 5);
      rgba[i + 2] = static_cast<uint8_t>(x + y);
      rgba[i + 3] = alpha(x / kTile, x % kTile, y);
    }
  }
  return rgba;
}

std::vector<TileRect> Row(int tiles_wide) {
  std::vector<TileRect> tiles;
  for (int t = 0; t < tiles_wide; ++t) tiles.push_back({t * kTile, 0, kTile, kTile});
  return tiles;
}

// 1-texel-wide diagonal lines at alpha 255 on alpha 0, `spacing` apart: a
// box filter spreads each line over the 2^L texels of level L and the
// alpha test at 128 drops all of them from level 2 on.
uint8_t DiagonalLines(int spacing, int x, int y) { return (x + y) % spacing == 0 ? 255 : 0; }

std::vector<MipLevel<uint8_t>> Chain(const std::vector<uint8_t>& rgba, int tiles_wide, MipCoverage coverage) {
  auto chain = BuildCoverageMipChain(rgba, tiles_wide * kTile, kTile, Row(tiles_wide), kLevels, coverage);
  EXPECT_TRUE(chain.ok()) << chain.status();
  return chain.ok() ? *chain : std::vector<MipLevel<uint8_t>>{};
}

std::vector<double> Ratios(const std::vector<MipLevel<uint8_t>>& chain, int tiles_wide) {
  auto r = CoverageByLevel(chain, Row(tiles_wide));
  EXPECT_TRUE(r.ok()) << r.status();
  return r.ok() ? *r : std::vector<double>{};
}

std::string Join(const std::vector<double>& v) {
  std::string s;
  for (double d : v) s += (s.empty() ? "" : ", ") + std::to_string(d);
  return "[" + s + "]";
}

// The texels of tile `t` (of a row of 64 px tiles) at `level`, RGBA.
std::vector<uint8_t> TileBytes(const MipLevel<uint8_t>& l, int t, int level) {
  const int side = kTile >> level;
  std::vector<uint8_t> out;
  for (int y = 0; y < side; ++y) {
    const size_t row = (static_cast<size_t>(y) * l.width + t * side) * 4;
    out.insert(out.end(), l.rgba.begin() + row, l.rgba.begin() + row + side * 4);
  }
  return out;
}

TEST(CoverageScale, ThinLinesKeepTheirAlphaTestedAreaWhereTheBoxFilterLosesIt) {
  const struct {
    int spacing;
    double tolerance;  // |ratio to level 0 - 1| at every level
  } cases[] = {{5, 0.05}, {7, 0.10}};
  for (const auto& c : cases) {
    const std::string name = "lines " + std::to_string(c.spacing) + " texels apart";
    const std::vector<uint8_t> rgba = MakeImage(1, [&](int, int x, int y) { return DiagonalLines(c.spacing, x, y); });
    const std::vector<double> box = Ratios(Chain(rgba, 1, MipCoverage::kBoxFilter), 1);
    const std::vector<double> kept = Ratios(Chain(rgba, 1, MipCoverage::kPreserveAlphaTest), 1);
    std::printf("%s: box filter %s, preserving %s\n", name.c_str(), Join(box).c_str(), Join(kept).c_str());
    ASSERT_EQ(box.size(), static_cast<size_t>(kLevels)) << name;
    ASSERT_EQ(kept.size(), static_cast<size_t>(kLevels)) << name;
    // The plain box filter loses the lines at levels 2 and 3 ...
    EXPECT_LT(box[2], 0.05) << name;
    EXPECT_LT(box[3], 0.05) << name;
    // ... the preserving chain keeps their area at every level.
    for (int level = 0; level < kLevels; ++level) {
      EXPECT_NEAR(kept[level], 1.0, c.tolerance) << name << " level " << level;
    }
  }
}

TEST(CoverageScale, EmptyAndFullTilesAreLeftAsTheBoxFilterMadeThem) {
  const struct {
    const char* name;
    uint8_t (*alpha)(int, int, int);
  } cases[] = {
      {"empty", [](int, int, int) -> uint8_t { return 0; }},
      {"empty but faint (A < 128 everywhere)", [](int, int x, int y) -> uint8_t { return (x * 7 + y) % 128; }},
      {"full at 255", [](int, int, int) -> uint8_t { return 255; }},
      {"full, A 128..255", [](int, int x, int y) -> uint8_t { return static_cast<uint8_t>(128 + (x * 5 + y * 3) % 128); }},
  };
  for (const auto& c : cases) {
    const std::vector<uint8_t> rgba = MakeImage(1, c.alpha);
    const std::vector<MipLevel<uint8_t>> box = Chain(rgba, 1, MipCoverage::kBoxFilter);
    const std::vector<MipLevel<uint8_t>> kept = Chain(rgba, 1, MipCoverage::kPreserveAlphaTest);
    ASSERT_EQ(kept.size(), box.size()) << c.name;
    for (size_t level = 0; level < box.size(); ++level) {
      EXPECT_EQ(kept[level].rgba, box[level].rgba) << c.name << " level " << level;
    }
    for (double r : Ratios(kept, 1)) EXPECT_EQ(r, 1.0) << c.name;
  }
}

TEST(CoverageScale, TilesAreScaledEachByItsOwnLevelZero) {
  // A thin tile beside a solid one: the solid tile keeps the box filter's
  // bytes, the thin one gets exactly what it gets alone.
  const std::vector<uint8_t> pair =
      MakeImage(2, [](int tile, int x, int y) -> uint8_t { return tile == 0 ? DiagonalLines(5, x, y) : 255; });
  const std::vector<uint8_t> thin_alone = MakeImage(1, [](int, int x, int y) { return DiagonalLines(5, x, y); });
  const std::vector<MipLevel<uint8_t>> kept = Chain(pair, 2, MipCoverage::kPreserveAlphaTest);
  const std::vector<MipLevel<uint8_t>> box = Chain(pair, 2, MipCoverage::kBoxFilter);
  const std::vector<MipLevel<uint8_t>> alone = Chain(thin_alone, 1, MipCoverage::kPreserveAlphaTest);
  ASSERT_EQ(kept.size(), static_cast<size_t>(kLevels));
  ASSERT_EQ(alone.size(), static_cast<size_t>(kLevels));
  for (int level = 0; level < kLevels; ++level) {
    EXPECT_EQ(TileBytes(kept[level], 1, level), TileBytes(box[level], 1, level)) << "solid tile, level " << level;
    EXPECT_EQ(TileBytes(kept[level], 0, level), TileBytes(alone[level], 0, level)) << "thin tile, level " << level;
  }
  // And the thin tile was scaled (else this test shows nothing).
  EXPECT_NE(TileBytes(kept[2], 0, 2), TileBytes(box[2], 0, 2));
}

TEST(CoverageScale, SameInputSameBytesAndTheSameAlphaForEveryCoverageMap) {
  const std::vector<uint8_t> rgba = MakeImage(2, [](int tile, int x, int y) -> uint8_t {
    return tile == 0 ? DiagonalLines(7, x, y) : static_cast<uint8_t>((x * x + y * 3) % 13 == 0 ? 255 : 0);
  });
  const std::vector<MipLevel<uint8_t>> a = Chain(rgba, 2, MipCoverage::kPreserveAlphaTest);
  const std::vector<MipLevel<uint8_t>> b = Chain(rgba, 2, MipCoverage::kPreserveAlphaTest);
  // An ORM-like map: other colours, the same coverage.
  std::vector<uint8_t> orm = rgba;
  for (size_t i = 0; i < orm.size(); i += 4) orm[i] = orm[i + 1] = orm[i + 2] = static_cast<uint8_t>(i / 4 % 251);
  const std::vector<MipLevel<uint8_t>> o = Chain(orm, 2, MipCoverage::kPreserveAlphaTest);
  ASSERT_EQ(a.size(), static_cast<size_t>(kLevels));
  ASSERT_EQ(o.size(), a.size());
  for (size_t level = 0; level < a.size(); ++level) {
    EXPECT_EQ(a[level].rgba, b[level].rgba) << "level " << level;
    for (size_t i = 3; i < a[level].rgba.size(); i += 4) {
      ASSERT_EQ(a[level].rgba[i], o[level].rgba[i]) << "level " << level << " texel " << i / 4;
    }
  }
}

TEST(CoverageScale, ScalingMeetsTheTargetAndKeepsEmptyTexelsEmpty) {
  // One 16x16 tile with A = 0..255 (one texel each): any target count is
  // reachable exactly; 0 stays 0 and nothing else becomes 0.
  std::vector<uint8_t> ramp(16 * 16 * 4, 9);
  for (int i = 0; i < 256; ++i) ramp[i * 4 + 3] = static_cast<uint8_t>(i);
  const TileRect tile{0, 0, 16, 16};
  for (int want : {1, 40, 128, 200, 255}) {
    std::vector<uint8_t> rgba = ramp;
    auto covered = ScaleAlphaToCoverage(rgba, 16, 16, tile, want, 256);
    ASSERT_TRUE(covered.ok()) << covered.status();
    EXPECT_EQ(*covered, want) << "want " << want;
    auto counted = CoveredTexels(rgba, 16, 16, tile);
    ASSERT_TRUE(counted.ok());
    EXPECT_EQ(*counted, want) << "want " << want;
    EXPECT_EQ(rgba[3], 0) << "want " << want;
    for (int i = 1; i < 256; ++i) EXPECT_GT(rgba[i * 4 + 3], 0) << "want " << want << " texel " << i;
    for (size_t i = 0; i < rgba.size(); i += 4) EXPECT_EQ(rgba[i], 9) << "colour is not touched";
  }
  std::vector<uint8_t> rgba = ramp;
  EXPECT_EQ(ScaleAlphaToCoverage(rgba, 16, 16, {8, 8, 16, 16}, 1, 4).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ScaleAlphaToCoverage(rgba, 16, 16, tile, 5, 4).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ScaleAlphaToCoverage(rgba, 16, 16, tile, 1, 0).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CoveredTexels(rgba, 16, 15, tile).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(rgba, ramp) << "a refused call changes nothing";
}

TEST(CoverageByLevelManifest, RoundTripsOnKtx2MapsAndStaysOffPngMaps) {
  v1::Manifest m;
  m.set_format_version(kManifestFormatVersion);
  m.set_layout(v1::LAYOUT_OCTAHEDRAL);
  for (int i = 0; i < 3; ++i) m.mutable_bounding_sphere()->add_center(0);
  v1::MapFile* png = m.add_maps();
  png->set_semantic("albedo_alpha");
  png->set_file("albedo_alpha.png");
  png->set_format("png_rgba8");
  v1::MapFile* ktx2 = m.add_maps();
  ktx2->set_semantic("albedo_alpha");
  ktx2->set_file("albedo_alpha.ktx2");
  ktx2->set_format("ktx2_uastc");
  ktx2->set_codec("uastc");
  ktx2->set_levels(3);
  ktx2->set_precision("p");
  for (double r : {1.0, 0.9987, 1.0213}) ktx2->add_coverage_by_level(r);
  v1::MapFile* depth = m.add_maps();
  *depth = *ktx2;
  depth->set_semantic("depth");
  depth->clear_coverage_by_level();
  const std::string json = ManifestToJson(m);
  EXPECT_NE(json.find("\"coverage_by_level\": [\n        1.0,\n        0.9987,\n        1.0213\n      ]"),
            std::string::npos)
      << json;
  EXPECT_EQ(json.find("coverage_by_level"), json.rfind("coverage_by_level")) << "only the KTX2 albedo map has it";
  auto back = ManifestFromJson(json);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->maps_size(), 3);
  EXPECT_EQ(back->maps(0).coverage_by_level_size(), 0);
  ASSERT_EQ(back->maps(1).coverage_by_level_size(), 3);
  EXPECT_EQ(back->maps(1).coverage_by_level(1), 0.9987);
  EXPECT_EQ(back->maps(2).coverage_by_level_size(), 0);
}

}  // namespace
}  // namespace impostor
