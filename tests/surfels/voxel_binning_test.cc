// Voxel clustering on synthetic samples: budgets are never exceeded and are
// nearly filled, cells average what fell in them, normals stay unit length
// even where a thin sheet is seen from both sides, and the files round-trip.
#include "worker/surfels/voxel_binning.h"

#include <cmath>
#include <numbers>
#include <random>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include "worker/surfels/atlas_samples.h"
#include "worker/surfels/ply_writer.h"
#include "worker/surfels/point_buffer.h"

namespace impostor {
namespace {

// Dense samples on a unit sphere (outward normals) and a flat leaf sampled
// from both sides: enough surface for budgets up to ~100k points.
std::vector<Surfel> SphereAndLeafSamples(int count) {
  std::mt19937 rng(42);
  std::normal_distribution<float> gauss;
  std::uniform_real_distribution<float> uniform(-0.5f, 0.5f);
  std::vector<Surfel> samples;
  for (int i = 0; i < count; ++i) {
    Surfel s;
    glm::vec3 d(gauss(rng), gauss(rng), gauss(rng));
    s.position = s.normal = glm::normalize(d);
    s.albedo = {0.2f, 0.5f, 0.1f};
    samples.push_back(s);
    Surfel leaf;  // the plane y = 2, seen from above and below
    leaf.position = {uniform(rng), 2.0f, uniform(rng)};
    leaf.normal = {0.0f, i % 2 == 0 ? 1.0f : -1.0f, 0.0f};
    samples.push_back(leaf);
  }
  return samples;
}

TEST(VoxelBinning, BudgetIsNeverExceededAndNearlyFilled) {
  const std::vector<Surfel> samples = SphereAndLeafSamples(200'000);
  for (size_t budget : {1u, 7u, 100u, 2048u, 16384u, 32768u}) {
    const BudgetFit fit = FitVoxelSizeToBudget(samples, budget, /*min_voxel_size=*/1e-4f);
    const std::vector<Surfel> points = BinSamples(samples, VoxelGrid{BoundsOf(samples).min, fit.voxel_size});
    SCOPED_TRACE(::testing::Message() << "budget " << budget << " voxel " << fit.voxel_size);
    EXPECT_EQ(points.size(), fit.point_count);
    EXPECT_LE(points.size(), budget);
    EXPECT_GE(static_cast<double>(points.size()), 0.9 * static_cast<double>(budget));
    EXPECT_TRUE(fit.budget_reached);
    EXPECT_LE(fit.evaluations, 48);
  }
}

TEST(VoxelBinning, TooFewSamplesSaySoInsteadOfShrinkingForever) {
  const std::vector<Surfel> samples = SphereAndLeafSamples(500);  // 1000 samples
  const BudgetFit fit = FitVoxelSizeToBudget(samples, 5000, /*min_voxel_size=*/0.01f);
  EXPECT_FALSE(fit.budget_reached);
  EXPECT_LE(fit.point_count, 1000u);
  EXPECT_FLOAT_EQ(fit.voxel_size, 0.01f) << "the smallest voxel allowed";
}

TEST(VoxelBinning, CellsAverageTheirSamples) {
  // Two cells of a grid of size 1 at the origin: cell (0,0,0) gets two
  // samples, cell (3,0,0) one.
  std::vector<Surfel> samples(3);
  samples[0].position = {0.2f, 0.2f, 0.2f};
  samples[0].albedo = {1.0f, 0.0f, 0.0f};
  samples[0].orm = {1.0f, 0.5f, 0.0f};
  samples[0].normal = {1.0f, 0.0f, 0.0f};
  samples[1].position = {0.6f, 0.8f, 0.4f};
  samples[1].albedo = {0.0f, 1.0f, 0.0f};
  samples[1].orm = {0.0f, 0.5f, 1.0f};
  samples[1].normal = {0.0f, 1.0f, 0.0f};
  samples[2].position = {3.5f, 0.5f, 0.5f};
  samples[2].albedo = {0.3f, 0.3f, 0.3f};
  const std::vector<Surfel> points = BinSamples(samples, VoxelGrid{{0, 0, 0}, 1.0f});
  ASSERT_EQ(points.size(), 2u);
  EXPECT_NEAR(points[0].position.x, 0.4f, 1e-6);
  EXPECT_NEAR(points[0].position.y, 0.5f, 1e-6);
  EXPECT_NEAR(points[0].position.z, 0.3f, 1e-6);
  EXPECT_NEAR(points[0].albedo.r, 0.5f, 1e-6);
  EXPECT_NEAR(points[0].albedo.g, 0.5f, 1e-6);
  EXPECT_NEAR(points[0].orm.z, 0.5f, 1e-6);
  EXPECT_NEAR(points[0].normal.x, std::numbers::sqrt2 / 2, 1e-6);
  EXPECT_NEAR(points[0].normal.y, std::numbers::sqrt2 / 2, 1e-6);
  EXPECT_NEAR(points[1].position.x, 3.5f, 1e-6);
  EXPECT_EQ(CountOccupiedCells(samples, VoxelGrid{{0, 0, 0}, 1.0f}), 2u);
}

TEST(VoxelBinning, BothSidesOfALeafKeepAUnitNormal) {
  const std::vector<Surfel> samples = SphereAndLeafSamples(20'000);
  const std::vector<Surfel> points = BinSamples(samples, VoxelGrid{BoundsOf(samples).min, 0.05f});
  int leaf_points = 0;
  for (const Surfel& p : points) {
    ASSERT_NEAR(glm::length(p.normal), 1.0f, 1e-5f);
    if (std::abs(p.position.y - 2.0f) < 1e-4f) {
      ++leaf_points;
      EXPECT_NEAR(std::abs(p.normal.y), 1.0f, 1e-5f) << "the leaf's normal, not noise";
    }
  }
  EXPECT_GT(leaf_points, 300);
}

TEST(VoxelBinning, PointsComeOutInMortonOrderDeterministically) {
  const std::vector<Surfel> samples = SphereAndLeafSamples(5000);
  const VoxelGrid grid{BoundsOf(samples).min, 0.1f};
  const std::vector<Surfel> a = BinSamples(samples, grid);
  const std::vector<Surfel> b = BinSamples(samples, grid);
  ASSERT_EQ(EncodePointBuffer(a), EncodePointBuffer(b));
  // Consecutive points are mostly neighbours: the mean step is a few cells,
  // far below the random-order mean distance (~1.5 units).
  double step = 0;
  for (size_t i = 1; i < a.size(); ++i) step += glm::length(a[i].position - a[i - 1].position);
  EXPECT_LT(step / (a.size() - 1), 0.5);
}

TEST(PointBuffer, IsTwelveLittleEndianFloatsPerPoint) {
  Surfel p;
  p.position = {1.0f, -2.0f, 3.5f};
  p.normal = {0.0f, 0.0f, 1.0f};
  p.albedo = {0.25f, 0.5f, 0.75f};
  p.orm = {1.0f, 0.125f, 0.0f};
  const std::string bytes = EncodePointBuffer({p, p});
  ASSERT_EQ(bytes.size(), 96u);
  // 1.0f = 0x3f800000, little-endian: 00 00 80 3f.
  EXPECT_EQ(static_cast<uint8_t>(bytes[0]), 0x00);
  EXPECT_EQ(static_cast<uint8_t>(bytes[2]), 0x80);
  EXPECT_EQ(static_cast<uint8_t>(bytes[3]), 0x3f);
  auto back = DecodePointBuffer(bytes);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->size(), 2u);
  EXPECT_EQ((*back)[1].position, p.position);
  EXPECT_EQ((*back)[1].orm, p.orm);
  auto bad = DecodePointBuffer(bytes.substr(0, 50));
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(Ply, HeaderDeclaresEveryPropertyAndTheBodyMatches) {
  Surfel p;
  p.albedo = {1.0f, 0.2158605f, 0.0f};  // sRGB 255, 128, 0
  const std::string ply = EncodePly({p, p, p}, {"voxel_size 0.5"});
  const std::string header_end = "end_header\n";
  const size_t body = ply.find(header_end);
  ASSERT_NE(body, std::string::npos);
  const std::string header = ply.substr(0, body);
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\ncomment voxel_size 0.5\n", 0), 0u) << header;
  EXPECT_NE(header.find("element vertex 3\n"), std::string::npos);
  for (const char* prop : {"float x", "float nx", "uchar red", "uchar blue", "float metalness"}) {
    EXPECT_NE(header.find(std::string("property ") + prop + "\n"), std::string::npos) << prop;
  }
  // 9 floats + 3 bytes per vertex.
  EXPECT_EQ(ply.size() - body - header_end.size(), 3u * 39u);
  const size_t red = body + header_end.size() + 24;
  EXPECT_EQ(static_cast<uint8_t>(ply[red]), 255);
  EXPECT_EQ(static_cast<uint8_t>(ply[red + 1]), 128);
  EXPECT_EQ(static_cast<uint8_t>(ply[red + 2]), 0);
}

TEST(Srgb, DecodesToLinear) {
  EXPECT_FLOAT_EQ(SrgbByteToLinear(0), 0.0f);
  EXPECT_FLOAT_EQ(SrgbByteToLinear(255), 1.0f);
  EXPECT_NEAR(SrgbByteToLinear(128), 0.2158605f, 1e-6f);
  for (int c = 0; c < 256; ++c) EXPECT_EQ(LinearToSrgbByte(SrgbByteToLinear(static_cast<uint8_t>(c))), c);
}

}  // namespace
}  // namespace impostor
