// What an atlas bake writes, checked in pixels on real bakes: texture
// arrays hold exactly the atlas's frames, supersampled edges keep the
// surface's colour, the contact sheet is listed.
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "tests/gpu/shared_renderer_test.h"
#include "common/request/bake_request.h"
#include "worker/bake/atlas_bake.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/output/map_writer.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

const fs::path kAssets = IMPOSTOR_TEST_ASSETS_DIR;

fs::path ScratchDir(const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_outputs_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

class AtlasOutputsTest : public testing::SharedRendererTest {
 protected:
  static absl::StatusOr<AtlasBakeOutput> Bake(const fs::path& model, v1::BakeParameters in, const fs::path& dir) {
    in.set_quality_views(0);  // not what these tests are about
    auto p = NormalizeParameters(in);
    if (!p.ok()) return p.status();
    const std::atomic<bool> cancelled{false};
    AtlasBakeRequest request{
        .entry_file = model, .parameters = *p, .cache_key = "outputs-test", .output_dir = dir, .load_limits = {}};
    return BakeAtlas(request, *renderer_, [](std::string_view, double) {}, cancelled);
  }
};
const v1::MapFile* FindMap(const v1::Manifest& m, const std::string& semantic) {
  for (const v1::MapFile& map : m.maps()) {
    if (map.semantic() == semantic) return &map;
  }
  return nullptr;
}

TEST_F(AtlasOutputsTest, TextureArrayHoldsEveryFrameOfTheAtlasAsALayer) {
  const fs::path helmet = kAssets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
  v1::BakeParameters params;
  params.set_layout(v1::LAYOUT_BILLBOARD);
  params.set_resolution(192);
  params.set_supersampling(1);
  const fs::path atlas_dir = ScratchDir("atlas"), array_dir = ScratchDir("array");
  auto atlas = Bake(helmet, params, atlas_dir);
  ASSERT_TRUE(atlas.ok()) << atlas.status();
  params.set_texture_array(true);
  auto array = Bake(helmet, params, array_dir);
  ASSERT_TRUE(array.ok()) << array.status();

  const int tile = static_cast<int>(array->manifest.tile_size());
  ASSERT_EQ(tile, 64);
  ASSERT_EQ(array->manifest.views_size(), 9);
  for (const char* semantic : {"albedo_alpha", "normal_depth", "orm"}) {
    const v1::MapFile* map = FindMap(array->manifest, semantic);
    ASSERT_NE(map, nullptr) << semantic;
    EXPECT_EQ(map->width(), 64u) << semantic;
    EXPECT_EQ(map->height(), 64u * 9) << semantic;
  }
  auto layers = ReadPng(array_dir / "albedo_alpha.png");
  auto sheet = ReadPng(atlas_dir / "albedo_alpha.png");
  ASSERT_TRUE(layers.ok() && sheet.ok());
  ASSERT_EQ(layers->width, 64);
  ASSERT_EQ(layers->height, 64 * 9);
  for (int i = 0; i < 9; ++i) {
    const v1::View& array_view = array->manifest.views(i);
    const v1::View& atlas_view = atlas->manifest.views(i);
    EXPECT_EQ(array_view.tile().x(), 0u);
    EXPECT_EQ(array_view.tile().y(), static_cast<uint32_t>(i * 64));
    int covered = 0;
    for (int y = 0; y < 64; ++y) {
      for (int x = 0; x < 64; ++x) {
        const size_t a = (static_cast<size_t>(i * 64 + y) * 64 + x) * 4;
        const size_t b = (static_cast<size_t>(atlas_view.tile().y() + y) * sheet->width + atlas_view.tile().x() + x) * 4;
        for (int c = 0; c < 4; ++c) {
          ASSERT_EQ(layers->pixels8[a + c], sheet->pixels8[b + c]) << "layer " << i << " texel " << x << "," << y;
        }
        covered += layers->pixels8[a + 3] != 0;
      }
    }
    EXPECT_GT(covered, 200) << "layer " << i;
  }
  // The contact sheet and cutout come from the frames either way.
  EXPECT_NE(FindMap(array->manifest, "contact_sheet"), nullptr);
  EXPECT_EQ(array->manifest.cutout().vertices_size(), atlas->manifest.cutout().vertices_size());
}

TEST_F(AtlasOutputsTest, SupersampledEdgesKeepTheSurfaceColour) {
  // Box: one material, flat base colour. With straight alpha every texel
  // the box covers, partly or wholly, has that colour; a premultiplied
  // fringe would darken the partly covered ones toward black.
  const fs::path box = kAssets / "props_pbr/Box/glTF-Binary/Box.glb";
  v1::BakeParameters params;
  params.set_frames(3);
  params.set_resolution(192);
  params.set_supersampling(4);
  const fs::path dir = ScratchDir("edges");
  auto out = Bake(box, params, dir);
  ASSERT_TRUE(out.ok()) << out.status();
  auto png = ReadPng(dir / "albedo_alpha.png");
  ASSERT_TRUE(png.ok());
  int partial = 0, full = 0;
  double full_r = 0;
  for (size_t i = 0; i < png->pixels8.size(); i += 4) {
    if (png->pixels8[i + 3] == 255) {
      ++full;
      full_r += png->pixels8[i];
    }
  }
  ASSERT_GT(full, 1000);
  const double mean_r = full_r / full;
  ASSERT_GT(mean_r, 100.0) << "the box is red";
  for (size_t i = 0; i < png->pixels8.size(); i += 4) {
    const int a = png->pixels8[i + 3];
    if (a == 0 || a == 255) continue;
    ++partial;
    EXPECT_NEAR(png->pixels8[i], mean_r, 12.0) << "edge texel " << i / 4 << " alpha " << a;
  }
  EXPECT_GT(partial, 100) << "4x4 supersampling must leave fractional coverage at the edges";
}

}  // namespace
}  // namespace impostor
