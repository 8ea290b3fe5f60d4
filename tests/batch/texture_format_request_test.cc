// --texture-format / --albedo-codec (issue 22): the CLI flags and batch-spec
// keys take only known values, and the server's normalisation accepts KTX2
// for atlases only, rounds the resolution to block-aligned tiles and keys
// the encoder's version (PNG keys stay as they were).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "client/cli/batch_spec.h"
#include "client/cli/cli_args.h"
#include "common/request/bake_request.h"
#include "common/atlas/frame_camera.h"
#include "common/request/ktx2_encoder_version.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

v1::MeshInput Mesh() {
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path("model.glb");
  mesh.mutable_entry()->mutable_digest()->set_hash(std::string(64, 'a'));
  mesh.mutable_entry()->mutable_digest()->set_size_bytes(100);
  return mesh;
}

TEST(TextureFormatRequest, CliFlagsTakeKnownValuesOnly) {
  auto a = cli::ParseCliArgs({"bake", "m.glb", "--out", "o", "--texture-format", "ktx2", "--albedo-codec=uastc-rdo"},
                             nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->texture_format, "ktx2");
  EXPECT_EQ(a->albedo_codec, "uastc-rdo");
  a = cli::ParseCliArgs({"bake", "m.glb", "--out", "o"}, nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->texture_format, "");
  struct Case {
    const char* flag;
    const char* value;
    const char* expected;
  } bad[] = {{"--texture-format", "dds", "--texture-format: unknown format \"dds\"; expected png or ktx2"},
             {"--texture-format", "KTX2", "--texture-format: unknown format \"KTX2\""},
             {"--albedo-codec", "etc1s", "--albedo-codec: unknown codec \"etc1s\"; expected uastc or uastc-rdo"}};
  for (const Case& c : bad) {
    auto r = cli::ParseCliArgs({"bake", "m.glb", "--out", "o", c.flag, c.value}, nullptr);
    ASSERT_FALSE(r.ok()) << c.flag << " " << c.value;
    EXPECT_NE(r.status().message().find(c.expected), std::string::npos) << r.status();
  }
}

TEST(TextureFormatRequest, BatchSpecKeysTakeKnownValuesOnly) {
  const fs::path dir = fs::temp_directory_path() / ("texture_format_spec_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "rock.glb") << "";
  auto spec = cli::ParseBatchSpec(
      R"({"defaults": {"texture_format": "ktx2"}, "assets": ["rock.glb", {"path": "rock.glb", "name": "b", "albedo_codec": "uastc-rdo", "texture_format": "png"}]})",
      cli::SpecFormat::kJson, dir, std::nullopt);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->entries[0].settings.texture_format, "ktx2");
  EXPECT_EQ(spec->entries[1].settings.texture_format, "png");
  EXPECT_EQ(spec->entries[1].settings.albedo_codec, "uastc-rdo");
  for (const char* bad : {R"({"assets": [{"path": "rock.glb", "texture_format": "jpeg"}]})",
                          R"({"assets": [{"path": "rock.glb", "texture_format": 2}]})",
                          R"({"assets": [{"path": "rock.glb", "albedo_codec": "bc7"}]})"}) {
    auto r = cli::ParseBatchSpec(bad, cli::SpecFormat::kJson, dir, std::nullopt);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.status().message().find("expected \""), std::string::npos) << r.status();
  }
  fs::remove_all(dir);
}

TEST(TextureFormatRequest, Ktx2RoundsResolutionToBlockAlignedTilesAndIsKeyed) {
  v1::BakeParameters p;
  auto png = NormalizeParameters(p);
  ASSERT_TRUE(png.ok()) << png.status();
  EXPECT_EQ(png->texture_format(), v1::TEXTURE_FORMAT_PNG);
  EXPECT_EQ(png->resolution(), 2048u);
  // An explicit PNG is the same request as none.
  p.set_texture_format(v1::TEXTURE_FORMAT_PNG);
  auto png2 = NormalizeParameters(p);
  ASSERT_TRUE(png2.ok());
  EXPECT_EQ(ComputeCacheKey(Mesh(), *png), ComputeCacheKey(Mesh(), *png2));

  p.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  auto ktx2 = NormalizeParameters(p);
  ASSERT_TRUE(ktx2.ok()) << ktx2.status();
  EXPECT_EQ(ktx2->albedo_codec(), v1::ALBEDO_CODEC_UASTC);
  EXPECT_EQ(ktx2->resolution(), 12u * 160u);  // 2048/12: tiles of 160 px, a multiple of 4 * 2^3
  EXPECT_EQ(TileSize(static_cast<int>(ktx2->resolution()), 12), 160);
  EXPECT_NE(ComputeCacheKey(Mesh(), *png), ComputeCacheKey(Mesh(), *ktx2));
  p.set_albedo_codec(v1::ALBEDO_CODEC_UASTC_RDO);
  auto rdo = NormalizeParameters(p);
  ASSERT_TRUE(rdo.ok()) << rdo.status();
  EXPECT_NE(ComputeCacheKey(Mesh(), *rdo), ComputeCacheKey(Mesh(), *ktx2));
  // Normalising twice changes nothing (the server stores normalised requests).
  auto again = NormalizeParameters(*ktx2);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->resolution(), ktx2->resolution());
  EXPECT_FALSE(kKtx2EncoderVersion.empty());
}

TEST(TextureFormatRequest, BadCombinationsNameTheField) {
  struct Case {
    const char* name;
    v1::BakeParameters p;
    const char* expected;
  };
  std::vector<Case> cases;
  auto add = [&](const char* name, const char* expected, auto set) {
    v1::BakeParameters p;
    set(p);
    cases.push_back({name, p, expected});
  };
  add("unknown format", "parameters.texture_format: unknown value 9",
      [](v1::BakeParameters& p) { p.set_texture_format(static_cast<v1::TextureFormat>(9)); });
  add("unknown codec", "parameters.albedo_codec: unknown value 7", [](v1::BakeParameters& p) {
    p.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
    p.set_albedo_codec(static_cast<v1::AlbedoCodec>(7));
  });
  add("codec without ktx2", "parameters.albedo_codec: only with TEXTURE_FORMAT_KTX2",
      [](v1::BakeParameters& p) { p.set_albedo_codec(v1::ALBEDO_CODEC_UASTC_RDO); });
  add("surfels", "TEXTURE_FORMAT_KTX2 is only for PRODUCT_ATLAS", [](v1::BakeParameters& p) {
    p.set_product(v1::PRODUCT_SURFELS);
    p.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  });
  add("lod chain", "TEXTURE_FORMAT_KTX2 is only for PRODUCT_ATLAS", [](v1::BakeParameters& p) {
    p.set_product(v1::PRODUCT_LOD_CHAIN);
    p.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  });
  add("texture array", "cannot be combined with texture_array", [](v1::BakeParameters& p) {
    p.set_texture_array(true);
    p.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  });
  add("frames auto", "needs an explicit frame count", [](v1::BakeParameters& p) {
    p.set_frames_auto(true);
    p.mutable_auto_target()->set_min_iou(0.9f);
    p.set_texture_format(v1::TEXTURE_FORMAT_KTX2);
  });
  for (const Case& c : cases) {
    auto out = NormalizeParameters(c.p);
    ASSERT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(out.status().message().find(c.expected), std::string::npos) << c.name << ": " << out.status();
  }
}

}  // namespace
}  // namespace impostor
