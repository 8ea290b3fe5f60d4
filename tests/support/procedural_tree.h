// A tree made by the tests themselves (issue 43: "a procedurally generated
// tree with thin branches"), written as a binary glTF 2.0 file.
//
// Why our own: the shared assets' plants are low-poly cards and blobs; none
// has what thins out first in an atlas, branches narrower than a texel. This
// one has a tapered trunk, four levels of branches whose radius halves at
// each level (the twigs are about a third of a texel of a 12 x 12, 2048 px
// atlas's tile wide) and small two-sided leaf quads at the twigs' ends.
//
// Deterministic: the same options give the same bytes on every machine (its
// own integer random generator, no <random> distributions, whose sequences
// the standard leaves to each library).
#ifndef IMPOSTOR_TESTS_SUPPORT_PROCEDURAL_TREE_H_
#define IMPOSTOR_TESTS_SUPPORT_PROCEDURAL_TREE_H_

#include <cstdint>
#include <filesystem>
#include <string>

#include "absl/status/statusor.h"

namespace impostor::testing {

struct ProceduralTreeOptions {
  uint64_t seed = 1;
  int branch_levels = 4;      // levels of branches above the trunk, 1..5
  int children = 3;           // branches grown from each branch, 2..5
  int leaves_per_twig = 6;    // leaf quads at each last-level branch, 0..16
  float trunk_radius = 0.03f;  // of the tree's height (1 unit); each level halves it
};

struct ProceduralTree {
  std::string glb;             // the file's bytes
  uint32_t branch_triangles = 0;
  uint32_t leaf_triangles = 0;
  float thinnest_radius = 0;   // the last level's tip radius, in units of the height
  float bounding_radius = 0;   // of the vertices about their box's centre
};

// INVALID_ARGUMENT naming the option outside its range; INTERNAL when
// tinygltf cannot serialise the model.
absl::StatusOr<ProceduralTree> MakeProceduralTree(const ProceduralTreeOptions& options = {});

// MakeProceduralTree, written to `path` (its folder must exist).
absl::StatusOr<ProceduralTree> WriteProceduralTree(const std::filesystem::path& path,
                                                   const ProceduralTreeOptions& options = {});

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_PROCEDURAL_TREE_H_
