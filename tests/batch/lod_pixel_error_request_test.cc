// `impostor bake --lod-pixel-error E` is the batch key lod_pixel_error: the
// same field of the request (BakeSettings::lod_pixel_error, then
// BakeParameters.lod_pixel_error), the same range (0.1..16), a value out of
// it refused naming the flag and the range (a usage error, as a batch spec
// with one is refused before anything is sent).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "client/cli/bake_settings.h"
#include "client/cli/batch_spec.h"
#include "client/cli/cli_args.h"
#include "client/transport/job_convert.h"
#include "common/request/bake_request.h"
#include "common/request/lod_parameters.h"

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

// The normalised request `settings` make, as the server keys it.
v1::BakeParameters Normalized(const sdk::BakeSettings& settings) {
  absl::StatusOr<v1::BakeParameters> p = sdk::ToBakeParameters(settings);
  EXPECT_TRUE(p.ok()) << p.status();
  if (!p.ok()) return {};
  absl::StatusOr<v1::BakeParameters> n = NormalizeParameters(*p);
  EXPECT_TRUE(n.ok()) << n.status();
  return n.ok() ? *n : v1::BakeParameters{};
}

TEST(LodPixelErrorRequest, TheFlagIsTheBatchKey) {
  absl::StatusOr<cli::CliArgs> a = cli::ParseCliArgs(
      {"bake", "rock.glb", "--out", "o", "--product", "lod-chain", "--lod-pixel-error", "2"}, nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_FLOAT_EQ(a->lod_pixel_error.value_or(0), 2.0f);
  const sdk::BakeSettings from_flag = cli::BakeSettingsFromArgs(*a);
  EXPECT_FLOAT_EQ(from_flag.lod_pixel_error.value_or(0), 2.0f);
  const v1::BakeParameters flag_request = Normalized(from_flag);
  EXPECT_FLOAT_EQ(flag_request.lod_pixel_error(), 2.0f);

  // The batch spec's key: the same request, the same cache key.
  const fs::path dir = fs::temp_directory_path() / ("lod_pixel_error_spec_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "rock.glb") << "";
  absl::StatusOr<cli::BatchSpec> spec = cli::ParseBatchSpec(
      R"({"assets": [{"path": "rock.glb", "product": "lod-chain", "lod_pixel_error": 2}]})", cli::SpecFormat::kJson,
      dir, std::nullopt);
  fs::remove_all(dir);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(ComputeCacheKey(Mesh(), flag_request), ComputeCacheKey(Mesh(), Normalized(spec->entries[0].settings)));

  // Not given: the server's default (1), another request.
  absl::StatusOr<cli::CliArgs> plain =
      cli::ParseCliArgs({"bake", "rock.glb", "--out", "o", "--product", "lod-chain"}, nullptr);
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_FALSE(plain->lod_pixel_error.has_value());
  const v1::BakeParameters plain_request = Normalized(cli::BakeSettingsFromArgs(*plain));
  EXPECT_FLOAT_EQ(plain_request.lod_pixel_error(), 1.0f);
  EXPECT_NE(ComputeCacheKey(Mesh(), plain_request), ComputeCacheKey(Mesh(), flag_request));

  // Both ends of the range are in it.
  for (const char* edge : {"0.1", "16"}) {
    EXPECT_TRUE(cli::ParseCliArgs({"bake", "m.glb", "--out", "o", "--product", "lod-chain", "--lod-pixel-error", edge},
                                  nullptr)
                    .ok())
        << edge;
  }
}

// A batch asset of product lod-chain without a layout is `bake --product
// lod-chain` without --layout: the server's lod-chain default
// (hemi-octahedral), not the SDK's "octahedral" sent as given. A layout in
// the asset or in defaults is kept.
TEST(LodPixelErrorRequest, ALodChainAssetWithoutLayoutIsTheBakeFlagsRequest) {
  const fs::path dir = fs::temp_directory_path() / ("lod_chain_layout_spec_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "rock.glb") << "";
  absl::StatusOr<cli::BatchSpec> spec = cli::ParseBatchSpec(
      R"({"assets": [{"path": "rock.glb", "product": "lod-chain"},
                     {"path": "rock.glb", "name": "oct", "product": "lod-chain", "layout": "octahedral"}]})",
      cli::SpecFormat::kJson, dir, std::nullopt);
  absl::StatusOr<cli::BatchSpec> with_defaults = cli::ParseBatchSpec(
      R"({"defaults": {"layout": "octahedral", "product": "lod-chain"}, "assets": ["rock.glb"]})",
      cli::SpecFormat::kJson, dir, std::nullopt);
  fs::remove_all(dir);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_TRUE(with_defaults.ok()) << with_defaults.status();
  absl::StatusOr<cli::CliArgs> flags =
      cli::ParseCliArgs({"bake", "rock.glb", "--out", "o", "--product", "lod-chain"}, nullptr);
  ASSERT_TRUE(flags.ok()) << flags.status();
  const v1::BakeParameters from_flags = Normalized(cli::BakeSettingsFromArgs(*flags));
  EXPECT_EQ(from_flags.layout(), v1::LAYOUT_HEMI_OCTAHEDRAL);
  const v1::BakeParameters from_spec = Normalized(spec->entries[0].settings);
  EXPECT_EQ(from_spec.layout(), v1::LAYOUT_HEMI_OCTAHEDRAL);
  EXPECT_EQ(ComputeCacheKey(Mesh(), from_spec), ComputeCacheKey(Mesh(), from_flags));
  EXPECT_EQ(Normalized(spec->entries[1].settings).layout(), v1::LAYOUT_OCTAHEDRAL);
  EXPECT_EQ(Normalized(with_defaults->entries[0].settings).layout(), v1::LAYOUT_OCTAHEDRAL);
}

TEST(LodPixelErrorRequest, AValueOutOfRangeIsAUsageErrorNamingTheFlagAndTheRange) {
  const struct {
    const char* value;
    const char* expected;
  } cases[] = {
      {"20", "--lod-pixel-error: 20 is out of range 0.1..16"},
      {"0.05", "--lod-pixel-error: 0.05 is out of range 0.1..16"},
      {"-1", "--lod-pixel-error: -1 is out of range 0.1..16"},
      {"nan", "--lod-pixel-error: nan is out of range 0.1..16"},
      {"two", "--lod-pixel-error: expected a number like 1, got \"two\""},
      {"", "--lod-pixel-error: expected a number like 1, got \"\""},
  };
  for (const auto& c : cases) {
    absl::StatusOr<cli::CliArgs> a = cli::ParseCliArgs(
        {"bake", "m.glb", "--out", "o", "--product", "lod-chain", std::string("--lod-pixel-error=") + c.value},
        nullptr);
    ASSERT_FALSE(a.ok()) << c.value;
    EXPECT_EQ(a.status().code(), absl::StatusCode::kInvalidArgument) << c.value;
    EXPECT_NE(a.status().message().find(c.expected), std::string::npos) << c.value << ": " << a.status();
  }
  // The batch key's range is the same (judged as the server will).
  EXPECT_EQ(cli::kLodPixelErrorMin, kMinLodPixelError);
  EXPECT_EQ(cli::kLodPixelErrorMax, kMaxLodPixelError);
  sdk::BakeSettings s;
  s.product = "lod-chain";
  s.lod_pixel_error = 20;
  absl::StatusOr<v1::BakeParameters> p = sdk::ToBakeParameters(s);
  ASSERT_TRUE(p.ok()) << p.status();
  absl::StatusOr<v1::BakeParameters> n = NormalizeParameters(*p);
  ASSERT_FALSE(n.ok());
  EXPECT_NE(n.status().message().find("lod_pixel_error: 20 is out of range 0.1..16"), std::string::npos) << n.status();
}

TEST(LodPixelErrorRequest, HelpShowsTheFlag) {
  EXPECT_NE(cli::UsageText().find("[--lod-pixel-error E]"), std::string::npos);
  EXPECT_NE(cli::UsageText().find("0.1..16)"), std::string::npos) << cli::UsageText();
}

}  // namespace
}  // namespace impostor
