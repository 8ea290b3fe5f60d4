// The quality flags of `impostor bake` and the `impostor quality` command
// line, parsed without a server.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "client/cli/cli_args.h"

namespace impostor::cli {
namespace {

TEST(QualityCliArgsTest, GateFramesAutoAndViewsAreParsed) {
  auto a = ParseCliArgs({"bake", "m.glb", "--out", "d", "--frames", "auto", "--min-iou", "0.95", "--min-psnr=30",
                         "--quality-views", "32"},
                        nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_TRUE(a->frames_auto);
  EXPECT_EQ(a->frames, 0u);
  ASSERT_TRUE(a->min_iou.has_value());
  EXPECT_FLOAT_EQ(*a->min_iou, 0.95f);
  ASSERT_TRUE(a->min_psnr_db.has_value());
  EXPECT_FLOAT_EQ(*a->min_psnr_db, 30.0f);
  EXPECT_EQ(a->quality_views, 32u);

  auto plain = ParseCliArgs({"bake", "m.glb", "--out", "d"}, nullptr);
  ASSERT_TRUE(plain.ok());
  EXPECT_FALSE(plain->frames_auto);
  EXPECT_FALSE(plain->min_iou.has_value());
  EXPECT_FALSE(plain->quality_views.has_value());
}

TEST(QualityCliArgsTest, BadValuesAreUsageErrorsNamingTheFlag) {
  const struct {
    std::vector<std::string> args;
    std::string message;
  } cases[] = {
      {{"bake", "m.glb", "--out", "d", "--min-iou", "high"}, "--min-iou: expected a number like 0.95"},
      {{"bake", "m.glb", "--out", "d", "--min-psnr", "30dB"}, "--min-psnr: expected a number like 30"},
      {{"bake", "m.glb", "--out", "d", "--quality-views", "-1"}, "--quality-views: expected a whole number"},
      {{"bake", "m.glb", "--out", "d", "--frames", "automatic"}, "--frames: expected a whole number"},
      {{"quality"}, "'quality' needs KEY"},
      {{"quality", std::string(64, 'a'), "--min-iou", "1"}, "unknown flag --min-iou for 'quality'"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.message);
    auto a = ParseCliArgs(c.args, nullptr);
    ASSERT_FALSE(a.ok());
    EXPECT_NE(std::string(a.status().message()).find(c.message), std::string::npos) << a.status();
  }
}

TEST(QualityCliArgsTest, QualityTakesAKeyAndAnOptionalOut) {
  auto a = ParseCliArgs({"quality", std::string(64, 'b')}, nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_EQ(a->command, Command::kQuality);
  EXPECT_EQ(a->target, std::string(64, 'b'));
  EXPECT_TRUE(a->out.empty());
  auto b = ParseCliArgs({"quality", std::string(64, 'b'), "--out", "dir", "--json"}, nullptr);
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(b->out, "dir");
  EXPECT_TRUE(b->json);
  EXPECT_NE(UsageText().find("impostor quality KEY"), std::string::npos);
}

}  // namespace
}  // namespace impostor::cli

namespace impostor::cli {
namespace {

TEST(QualityCliArgsTest, AllViewsBelongsToTheQualityCommand) {
  auto a = ParseCliArgs({"quality", std::string(64, 'a'), "--out", "d", "--all-views"}, nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_TRUE(a->all_views);
  auto without = ParseCliArgs({"quality", std::string(64, 'a')}, nullptr);
  ASSERT_TRUE(without.ok());
  EXPECT_FALSE(without->all_views);
  // A flag without a value, and only for `quality`.
  EXPECT_FALSE(ParseCliArgs({"quality", std::string(64, 'a'), "--all-views=yes"}, nullptr).ok());
  EXPECT_FALSE(ParseCliArgs({"bake", "m.glb", "--out", "d", "--all-views"}, nullptr).ok());
}

}  // namespace
}  // namespace impostor::cli
