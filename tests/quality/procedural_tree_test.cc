// The procedural tree itself (tests/support/procedural_tree.h): the same
// bytes for the same options, a valid glTF by the Khronos validator, twigs
// narrower than a texel of the target atlas, and clear refusals of options
// outside their ranges.
#include "tests/support/procedural_tree.h"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "tests/cards/validator.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

TEST(ProceduralTree, TheSameOptionsGiveTheSameBytesAndAnotherSeedAnotherTree) {
  auto a = MakeProceduralTree();
  auto b = MakeProceduralTree();
  ProceduralTreeOptions other;
  other.seed = 2;
  auto c = MakeProceduralTree(other);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(a->glb, b->glb);
  EXPECT_NE(a->glb, c->glb);
  // 1 + 3 + 9 + 27 + 81 branches of 6 quads; 6 leaves on each of 81 twigs.
  EXPECT_EQ(a->branch_triangles, 121u * 12u);
  EXPECT_EQ(a->leaf_triangles, 81u * 6u * 2u);
}

// What makes it the tree: its twigs are thinner than a texel of the
// target configuration (hemi-octahedral 12 x 12 at 2048 px: 170 px tiles
// spanning the bounding sphere's diameter), where the shared assets' plants
// have none.
TEST(ProceduralTree, ItsTwigsAreNarrowerThanHalfATexelOfTheTargetAtlas) {
  auto tree = MakeProceduralTree();
  ASSERT_TRUE(tree.ok()) << tree.status();
  const double texel = 2.0 * tree->bounding_radius / (2048 / 12);
  std::printf("twig diameter %.5f, texel %.5f (%.2f texels), bounding radius %.3f\n", 2 * tree->thinnest_radius,
              texel, 2 * tree->thinnest_radius / texel, tree->bounding_radius);
  EXPECT_LT(2 * tree->thinnest_radius, texel / 2);
  EXPECT_GT(tree->bounding_radius, 0.4f);
}

TEST(ProceduralTree, TheKhronosValidatorFindsNoErrors) {
  const fs::path file = fs::temp_directory_path() / ("procedural_tree_" + std::to_string(::getpid()) + ".glb");
  auto tree = WriteProceduralTree(file);
  ASSERT_TRUE(tree.ok()) << tree.status();
  const ValidatorResult result = RunGltfValidator(file);
  fs::remove(file);
  EXPECT_EQ(result.exit_code, 0) << result.report;
}

TEST(ProceduralTree, OptionsOutsideTheirRangesAreRefusedByName) {
  struct Case {
    void (*set)(ProceduralTreeOptions*);
    const char* field;
  } cases[] = {
      {[](ProceduralTreeOptions* o) { o->branch_levels = 0; }, "branch_levels"},
      {[](ProceduralTreeOptions* o) { o->branch_levels = 6; }, "branch_levels"},
      {[](ProceduralTreeOptions* o) { o->children = 1; }, "children"},
      {[](ProceduralTreeOptions* o) { o->leaves_per_twig = 17; }, "leaves_per_twig"},
      {[](ProceduralTreeOptions* o) { o->trunk_radius = 0; }, "trunk_radius"},
      {[](ProceduralTreeOptions* o) { o->trunk_radius = 1; }, "trunk_radius"},
  };
  for (const Case& c : cases) {
    ProceduralTreeOptions o;
    c.set(&o);
    auto tree = MakeProceduralTree(o);
    ASSERT_FALSE(tree.ok()) << c.field;
    EXPECT_EQ(tree.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(tree.status().message().find(c.field), std::string::npos) << tree.status();
  }
  const fs::path nowhere = fs::temp_directory_path() / "no_such_folder_for_the_tree" / "tree.glb";
  EXPECT_FALSE(WriteProceduralTree(nowhere).ok());
}

}  // namespace
}  // namespace impostor::testing
