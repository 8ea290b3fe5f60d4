// Batch specs: JSON and YAML read the same, defaults and overrides, folder
// names, and every malformed spec refused with a message naming the entry
// and the field.
#include "client/cli/batch_spec.h"

#include <unistd.h>

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "client/cli/cli_args.h"

namespace impostor::cli {
namespace {

namespace fs = std::filesystem;

class BatchSpecTest : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("batch_spec_test_" + std::to_string(::getpid()) + "_" +
            testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    // Only existence is checked when parsing: empty files will do.
    for (const char* f : {"rock.glb", "crate.glb", "trees/oak/scene.gltf", "trees/pine/scene.gltf", "bush.gltf"}) {
      fs::create_directories((dir_ / f).parent_path());
      std::ofstream(dir_ / f) << "";
    }
  }
  void TearDown() override { fs::remove_all(dir_); }

  absl::StatusOr<BatchSpec> Parse(const std::string& text, SpecFormat format = SpecFormat::kJson,
                                  std::optional<int32_t> priority = std::nullopt) {
    return ParseBatchSpec(text, format, dir_, priority);
  }

  fs::path dir_;
};

constexpr char kJsonSpec[] = R"({
  "defaults": {"frames": 4, "resolution": 128, "priority": -50, "layout": "hemi-octahedral"},
  "assets": [
    "rock.glb",
    {"path": "crate.glb", "name": "box", "frames": 8, "priority": 20, "min_iou": 0.9, "min_psnr_db": 30},
    {"path": "trees/oak/scene.gltf", "product": "surfels", "preset": "prop", "point_budget": 500},
    "trees/pine/scene.gltf"
  ]
})";

constexpr char kYamlSpec[] = R"(# the same batch as kJsonSpec
defaults:
  frames: 4
  resolution: 128
  priority: -50
  layout: hemi-octahedral
assets:
  - rock.glb
  - path: crate.glb
    name: box
    frames: 8
    priority: 20
    min_iou: 0.9
    min_psnr_db: 30
  - {path: trees/oak/scene.gltf, product: surfels, preset: prop, point_budget: 500}
  - "trees/pine/scene.gltf"
)";

void ExpectTheExampleBatch(const BatchSpec& spec, const fs::path& dir) {
  ASSERT_EQ(spec.entries.size(), 4u);
  const BatchEntry& rock = spec.entries[0];
  EXPECT_EQ(rock.asset, "rock.glb");
  EXPECT_EQ(rock.model, dir / "rock.glb");
  EXPECT_EQ(rock.name, "rock");
  EXPECT_EQ(rock.settings.frames, 4u);
  EXPECT_EQ(rock.settings.resolution, 128u);
  EXPECT_EQ(rock.settings.layout, "hemi-octahedral");
  EXPECT_EQ(rock.settings.priority, -50);
  EXPECT_FALSE(rock.settings.min_iou.has_value());

  const BatchEntry& box = spec.entries[1];
  EXPECT_EQ(box.name, "box");
  EXPECT_EQ(box.settings.frames, 8u) << "an asset's key wins over defaults";
  EXPECT_EQ(box.settings.resolution, 128u);
  EXPECT_EQ(box.settings.priority, 20);
  EXPECT_FLOAT_EQ(box.settings.min_iou.value_or(-1), 0.9f);
  EXPECT_FLOAT_EQ(box.settings.min_psnr_db.value_or(-1), 30.0f);

  const BatchEntry& oak = spec.entries[2];
  EXPECT_EQ(oak.settings.product, "surfels");
  EXPECT_EQ(oak.settings.preset, "prop");
  EXPECT_EQ(oak.settings.point_budget.value_or(0), 500u);
  // Two files called scene.gltf: their folders tell them apart.
  EXPECT_EQ(oak.name, "oak_scene");
  EXPECT_EQ(spec.entries[3].name, "pine_scene");
}

TEST_F(BatchSpecTest, JsonSpec) {
  auto spec = Parse(kJsonSpec);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ExpectTheExampleBatch(*spec, dir_);
}

TEST_F(BatchSpecTest, YamlSpecReadsTheSame) {
  auto spec = Parse(kYamlSpec, SpecFormat::kYaml);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ExpectTheExampleBatch(*spec, dir_);
}

TEST_F(BatchSpecTest, FormatIsDetectedForStdin) {
  auto json = Parse(kJsonSpec, SpecFormat::kAuto);
  ASSERT_TRUE(json.ok()) << json.status();
  ExpectTheExampleBatch(*json, dir_);
  auto yaml = Parse(kYamlSpec, SpecFormat::kAuto);
  ASSERT_TRUE(yaml.ok()) << yaml.status();
  ExpectTheExampleBatch(*yaml, dir_);
}

TEST_F(BatchSpecTest, LoadsFilesByExtensionRelativeToTheirFolder) {
  std::ofstream(dir_ / "batch.yml") << kYamlSpec;
  std::ofstream(dir_ / "batch.json") << kJsonSpec;
  for (const char* file : {"batch.yml", "batch.json"}) {
    auto spec = LoadBatchSpec((dir_ / file).string(), std::nullopt);
    ASSERT_TRUE(spec.ok()) << file << ": " << spec.status();
    ExpectTheExampleBatch(*spec, dir_);
  }
}

TEST_F(BatchSpecTest, CommandLinePriorityBeatsDefaultsButNotAnAssetsOwn) {
  auto spec = Parse(kJsonSpec, SpecFormat::kJson, 70);
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->entries[0].settings.priority, 70);
  EXPECT_EQ(spec->entries[1].settings.priority, 20);
}

TEST_F(BatchSpecTest, BareListAndQuotedYamlNumbersStayStrings) {
  auto spec = Parse(R"(["rock.glb", "rock.glb"])");
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_EQ(spec->entries.size(), 2u);
  EXPECT_EQ(spec->entries[0].name, "rock");
  EXPECT_EQ(spec->entries[1].name, "rock-2") << "the same file twice gets two folders";
  auto quoted = Parse("assets:\n  - path: rock.glb\n    frames: \"8\"\n", SpecFormat::kYaml);
  ASSERT_FALSE(quoted.ok());
  EXPECT_NE(quoted.status().message().find("frames: expected a whole number"), std::string::npos) << quoted.status();
}

TEST_F(BatchSpecTest, MalformedSpecsNameTheEntryAndField) {
  struct Case {
    const char* name;
    std::string text;
    SpecFormat format;
    std::string message;  // a part of the error message
  };
  const Case cases[] = {
      {"missing file", R"({"assets": ["rock.glb", "nope.glb"]})", SpecFormat::kJson,
       "assets[1]: \"nope.glb\" not found (looked at "},
      {"missing file in object", R"({"assets": [{"path": "gone/tree.gltf"}]})", SpecFormat::kJson,
       "assets[0] (\"gone/tree.gltf\").path: \"gone/tree.gltf\" not found"},
      {"unknown key", R"({"assets": [{"path": "rock.glb", "frame": 8}]})", SpecFormat::kJson,
       "assets[0] (\"rock.glb\"): unknown key \"frame\"; known keys: path, name, albedo_codec, emissive, frames, layout,"},
      {"unknown default", R"({"defaults": {"resolutoin": 64}, "assets": ["rock.glb"]})", SpecFormat::kJson,
       "defaults: unknown key \"resolutoin\""},
      {"unknown top-level key", R"({"asset": ["rock.glb"]})", SpecFormat::kJson,
       "SPEC: unknown key \"asset\"; known keys: defaults, assets"},
      {"wrong type", R"({"assets": [{"path": "rock.glb", "frames": "8"}]})", SpecFormat::kJson,
       "assets[0] (\"rock.glb\").frames: expected a whole number, 0 or more, or \"auto\", got \"8\" (string)"},
      {"negative number", R"({"defaults": {"resolution": -64}, "assets": ["rock.glb"]})", SpecFormat::kJson,
       "defaults.resolution: expected a whole number, 0 or more, got -64 (number)"},
      {"fractional frames", R"({"assets": [{"path": "rock.glb", "frames": 4.5}]})", SpecFormat::kJson,
       "frames: expected a whole number"},
      {"path not a string", R"({"assets": [{"path": 12}]})", SpecFormat::kJson,
       "assets[0].path: expected a non-empty string, got 12 (number)"},
      {"asset not a path", R"({"assets": [true]})", SpecFormat::kJson,
       "assets[0]: expected a model path or an object with \"path\", got true (boolean)"},
      {"no path", R"({"assets": [{"name": "x"}]})", SpecFormat::kJson, "assets[0]: missing \"path\""},
      {"empty list", R"({"defaults": {}, "assets": []})", SpecFormat::kJson, "assets: the list is empty"},
      {"no assets", R"({"defaults": {"frames": 4}})", SpecFormat::kJson, "SPEC: missing \"assets\""},
      {"assets not a list", R"({"assets": {"path": "rock.glb"}})", SpecFormat::kJson,
       "assets: expected a list, got {\"path\":\"rock.glb\"} (object)"},
      {"priority out of range", R"({"assets": [{"path": "rock.glb", "priority": 101}]})", SpecFormat::kJson,
       "assets[0] (\"rock.glb\").priority: 101 is out of range -100..100"},
      {"default priority out of range", R"({"defaults": {"priority": -300}, "assets": ["rock.glb"]})",
       SpecFormat::kJson, "defaults.priority: -300 is out of range -100..100"},
      {"priority not whole", R"({"assets": [{"path": "rock.glb", "priority": 1.5}]})", SpecFormat::kJson,
       "priority: expected a whole number in -100..100, got 1.5 (number)"},
      {"min_iou out of range", R"({"assets": [{"path": "rock.glb", "min_iou": 1.5}]})", SpecFormat::kJson,
       "assets[0] (\"rock.glb\").min_iou: 1.5 is out of range 0..1"},
      {"min_psnr_db not a number", R"({"defaults": {"min_psnr_db": "high"}, "assets": ["rock.glb"]})",
       SpecFormat::kJson, "defaults.min_psnr_db: expected a number in 0..100, got \"high\" (string)"},
      {"duplicate name", R"({"assets": [{"path": "rock.glb", "name": "a"}, {"path": "crate.glb", "name": "a"}]})",
       SpecFormat::kJson, "assets[1] (\"crate.glb\").name: \"a\" is also the name of assets[0]"},
      {"name with slash", R"({"assets": [{"path": "rock.glb", "name": "../x"}]})", SpecFormat::kJson,
       "assets[0] (\"rock.glb\").name: \"../x\" is not a folder name"},
      {"invalid json", "{\"assets\": [\"rock.glb\",]}", SpecFormat::kJson, "SPEC: invalid JSON: "},
      {"invalid yaml", "assets:\n  - rock.glb\n - crate.glb\n", SpecFormat::kYaml, "SPEC: invalid YAML at line 3"},
      {"scalar document", "42", SpecFormat::kJson, "SPEC: expected an object"},
      {"yaml unknown key", "assets:\n  - path: rock.glb\n    resolutoin: 64\n", SpecFormat::kYaml,
       "assets[0] (\"rock.glb\"): unknown key \"resolutoin\""},
  };
  for (const Case& c : cases) {
    auto spec = Parse(c.text, c.format);
    ASSERT_FALSE(spec.ok()) << c.name << ": accepted";
    EXPECT_EQ(spec.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(spec.status().message().find(c.message), std::string::npos)
        << c.name << ": message \"" << spec.status().message() << "\" lacks \"" << c.message << "\"";
  }
}

TEST_F(BatchSpecTest, EveryBakeSettingHasAKey) {
  auto spec = Parse(R"({"assets": [{"path": "rock.glb", "frames": "auto", "min_iou": 0.9, "emissive": true,
    "quality_views": 8, "ring_views": 12, "lod_ratios": [0.5, 0.25], "lod_pixel_error": 2, "max_planes": 6,
    "tolerance": 0.1}]})");
  ASSERT_TRUE(spec.ok()) << spec.status();
  const sdk::BakeSettings& s = spec->entries[0].settings;
  EXPECT_TRUE(s.frames_auto);
  EXPECT_TRUE(s.emissive);
  EXPECT_EQ(s.quality_views.value_or(0), 8u);
  EXPECT_EQ(s.ring_views.value_or(0), 12u);
  EXPECT_EQ(s.lod_ratios, (std::vector<float>{0.5f, 0.25f}));
  EXPECT_FLOAT_EQ(s.lod_pixel_error.value_or(0), 2.0f);
  EXPECT_EQ(s.max_planes.value_or(0), 6u);
  EXPECT_FLOAT_EQ(s.tolerance.value_or(0), 0.1f);
  auto bad = Parse(R"({"assets": [{"path": "rock.glb", "lod_ratios": [0.5, "half"]}]})");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("assets[0] (\"rock.glb\").lod_ratios[1]: expected a number, got \"half\""),
            std::string::npos)
      << bad.status();
}

TEST_F(BatchSpecTest, ModelsFromTheCommandLine) {
  sdk::BakeSettings settings;
  settings.frames = 6;
  settings.priority = 10;
  auto spec = BatchFromModels({(dir_ / "rock.glb").string(), (dir_ / "trees/oak/scene.gltf").string(),
                               (dir_ / "trees/pine/scene.gltf").string()},
                              settings);
  ASSERT_TRUE(spec.ok()) << spec.status();
  ASSERT_EQ(spec->entries.size(), 3u);
  EXPECT_EQ(spec->entries[0].name, "rock");
  EXPECT_EQ(spec->entries[1].name, "oak_scene");
  EXPECT_EQ(spec->entries[2].name, "pine_scene");
  for (const BatchEntry& e : spec->entries) {
    EXPECT_EQ(e.settings.frames, 6u);
    EXPECT_EQ(e.settings.priority, 10);
  }
  auto missing = BatchFromModels({(dir_ / "rock.glb").string(), "absent.glb"}, settings);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("MODEL 2: \"absent.glb\" not found"), std::string::npos)
      << missing.status();
}

TEST_F(BatchSpecTest, ExplicitNamesAreNeverTakenByDerivedOnes) {
  auto spec = Parse(R"({"assets": [{"path": "crate.glb", "name": "rock"}, "rock.glb"]})");
  ASSERT_TRUE(spec.ok()) << spec.status();
  EXPECT_EQ(spec->entries[0].name, "rock");
  EXPECT_NE(spec->entries[1].name, "rock");
}

TEST(BatchArgs, BakeTakesManyModelsAndBakeBatchOneSpec) {
  auto bake = ParseCliArgs({"bake", "a.glb", "b.gltf", "c.glb", "--out", "o", "--keep-going", "--priority", "-20"},
                           nullptr);
  ASSERT_TRUE(bake.ok()) << bake.status();
  EXPECT_EQ(bake->command, Command::kBake);
  EXPECT_EQ(bake->targets, (std::vector<std::string>{"a.glb", "b.gltf", "c.glb"}));
  EXPECT_TRUE(bake->keep_going);
  EXPECT_EQ(bake->priority.value_or(0), -20);

  auto batch = ParseCliArgs({"bake-batch", "-", "--out", "o", "--json", "--quiet", "--client-id", "ci-7"}, nullptr);
  ASSERT_TRUE(batch.ok()) << batch.status();
  EXPECT_EQ(batch->command, Command::kBakeBatch);
  EXPECT_EQ(batch->target, "-");
  EXPECT_EQ(batch->client_id, "ci-7");
  EXPECT_FALSE(batch->priority.has_value());

  struct Case {
    std::vector<std::string> args;
    std::string message;
  } bad[] = {
      {{"bake-batch", "s.json", "x.json", "--out", "o"}, "unexpected argument \"x.json\""},
      {{"bake-batch", "s.json"}, "needs --out DIR"},
      {{"bake-batch", "--out", "o"}, "needs SPEC"},
      {{"bake", "a.glb", "--out", "o", "--priority", "101"}, "--priority: expected a whole number in -100..100"},
      {{"bake-batch", "s.json", "--out", "o", "--priority=-101"}, "--priority: expected a whole number in -100..100"},
      {{"bake-batch", "s.json", "--out", "o", "--priority", "high"}, "--priority"},
      {{"bake-batch", "s.json", "--out", "o", "--frames", "4"}, "unknown flag --frames"},
  };
  for (const Case& c : bad) {
    auto a = ParseCliArgs(c.args, nullptr);
    ASSERT_FALSE(a.ok()) << c.message;
    EXPECT_NE(a.status().message().find(c.message), std::string::npos) << a.status();
  }
}

}  // namespace
}  // namespace impostor::cli
