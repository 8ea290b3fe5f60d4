// Request validation of the quality-pass fields, their cache-key line and the
// manifest's quality block in manifest.json.
#include "common/request/quality_parameters.h"

#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "common/manifest/manifest_json.h"

namespace impostor {
namespace {

v1::BakeParameters AutoParams() {
  v1::BakeParameters p;
  p.set_frames_auto(true);
  p.mutable_auto_target()->set_min_iou(0.9f);
  return p;
}

TEST(QualityParametersTest, DefaultsAreFilledAndKeysUnchanged) {
  v1::BakeParameters in;
  auto p = NormalizeParameters(in);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->quality_views(), 16u);
  EXPECT_EQ(QualityCacheKeyLine(*p), "") << "default atlas keys keep their value";
  v1::BakeParameters explicit_default;
  explicit_default.set_quality_views(16);
  auto q = NormalizeParameters(explicit_default);
  ASSERT_TRUE(q.ok());
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path("a.glb");
  mesh.mutable_entry()->mutable_digest()->set_hash(std::string(64, 'a'));
  EXPECT_EQ(ComputeCacheKey(mesh, *p), ComputeCacheKey(mesh, *q));
  v1::BakeParameters other;
  other.set_quality_views(32);
  auto r = NormalizeParameters(other);
  ASSERT_TRUE(r.ok());
  EXPECT_NE(ComputeCacheKey(mesh, *p), ComputeCacheKey(mesh, *r));
}

TEST(QualityParametersTest, FramesAutoNormalisesWithFramesUnsetAndItsOwnKey) {
  auto p = NormalizeParameters(AutoParams());
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->frames(), 0u) << "the baker picks it";
  EXPECT_TRUE(p->frames_auto());
  EXPECT_EQ(p->resolution(), 2048u);
  EXPECT_EQ(QualityCacheKeyLine(*p), "quality_views 16 frames_auto min_iou 0.899999976 min_psnr_db -");
  v1::BakeParameters stricter = AutoParams();
  stricter.mutable_auto_target()->set_min_iou(0.95f);
  auto s = NormalizeParameters(stricter);
  ASSERT_TRUE(s.ok());
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path("a.glb");
  mesh.mutable_entry()->mutable_digest()->set_hash(std::string(64, 'a'));
  EXPECT_NE(ComputeCacheKey(mesh, *p), ComputeCacheKey(mesh, *s)) << "the target is part of the key";
  v1::BakeParameters fixed;
  auto f = NormalizeParameters(fixed);
  EXPECT_NE(ComputeCacheKey(mesh, *p), ComputeCacheKey(mesh, *f));
}

// frames_auto covers every layout: each normalises with its knob unset
// (frames; ring-top's ring_views too), so the baker's ladder picks it.
TEST(QualityParametersTest, FramesAutoNormalisesForEveryLayout) {
  for (v1::Layout layout : {v1::LAYOUT_OCTAHEDRAL, v1::LAYOUT_HEMI_OCTAHEDRAL, v1::LAYOUT_AZIMUTH_ELEVATION,
                            v1::LAYOUT_RING_TOP, v1::LAYOUT_BILLBOARD}) {
    SCOPED_TRACE(static_cast<int>(layout));
    v1::BakeParameters in = AutoParams();
    in.set_layout(layout);
    auto p = NormalizeParameters(in);
    ASSERT_TRUE(p.ok()) << p.status();
    EXPECT_EQ(p->layout(), layout);
    EXPECT_TRUE(p->frames_auto());
    EXPECT_EQ(p->frames(), 0u);
    EXPECT_FALSE(p->has_ring_views());
  }
}

TEST(QualityParametersTest, BadParametersAreRefusedNamingTheField) {
  struct Case {
    std::string name;
    v1::BakeParameters params;
    std::string message;
  };
  std::vector<Case> cases;
  {
    v1::BakeParameters p;
    p.set_quality_views(257);
    cases.push_back({"too many views", p, "parameters.quality_views: 257 is out of range 0..256"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.set_frames(12);
    cases.push_back({"frames with auto", p, "parameters.frames: must be unset with frames_auto"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.clear_auto_target();
    cases.push_back({"auto without target", p, "parameters.auto_target: frames_auto needs at least one threshold"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.mutable_auto_target()->set_min_iou(1.5f);
    cases.push_back({"target out of range", p, "parameters.auto_target.min_iou: 1.5 is out of range 0..1"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.mutable_auto_target()->clear_min_iou();
    p.mutable_auto_target()->set_min_psnr_db(120.0f);
    cases.push_back({"psnr out of range", p, "parameters.auto_target.min_psnr_db: 120 is out of range 0..100"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.set_quality_views(0);
    cases.push_back({"auto without the pass", p, "parameters.quality_views: frames_auto needs the quality pass"});
  }
  {
    v1::BakeParameters p;
    p.mutable_auto_target()->set_min_iou(0.5f);
    cases.push_back({"target without auto", p, "parameters.auto_target: only with frames_auto"});
  }
  {
    v1::BakeParameters p;
    p.set_product(v1::PRODUCT_SURFELS);
    p.set_quality_views(8);
    cases.push_back({"surfels", p, "parameters.quality_views: only for products PRODUCT_ATLAS and PRODUCT_LOD_CHAIN"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.set_product(v1::PRODUCT_SURFELS);
    cases.push_back({"surfels auto", p, "parameters.frames_auto: only for products"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.set_layout(v1::LAYOUT_AZIMUTH_ELEVATION);
    p.set_frames(9);
    cases.push_back({"azimuth-elevation frames with auto", p,
                     "parameters.frames: must be unset with frames_auto (the baker picks it from 7, 9, 11, 13, 17, 21)"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.set_layout(v1::LAYOUT_RING_TOP);
    p.set_ring_views(16);
    cases.push_back({"ring_views with auto", p,
                     "parameters.ring_views: must be unset with frames_auto (the baker picks it from 8, 12, 16, 24, 32, "
                     "48); got 16"});
  }
  {
    v1::BakeParameters p = AutoParams();
    p.set_layout(v1::LAYOUT_BILLBOARD);
    p.set_frames(3);
    cases.push_back({"billboard frames with auto", p, "parameters.frames: billboard derives its atlas grid"});
  }
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    auto p = NormalizeParameters(c.params);
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(p.status().message()).find(c.message), std::string::npos) << p.status();
  }
}

// The smallest atlas manifest with a quality block (16 views of 128 px).
v1::Manifest AtlasManifestWithQuality() {
  v1::Manifest m;
  m.set_format_version(kManifestFormatVersion);
  m.set_product(v1::PRODUCT_ATLAS);
  m.set_layout(v1::LAYOUT_OCTAHEDRAL);
  for (int i = 0; i < 3; ++i) m.mutable_bounding_sphere()->add_center(0.0f);
  m.mutable_bounding_sphere()->set_radius(1.0f);
  v1::AtlasQuality* q = m.mutable_quality();
  q->set_blend("triangle3");
  q->set_views(16);
  q->set_view_pixels(128);
  return m;
}

TEST(QualityManifestJsonTest, QualityBlockAndWarningsRoundTrip) {
  v1::Manifest m = AtlasManifestWithQuality();
  v1::AtlasQuality* q = m.mutable_quality();
  q->set_silhouette_iou_min(0.91f);
  q->set_silhouette_iou_mean(0.95f);
  q->set_albedo_psnr_union_db_min(20.5f);
  q->set_albedo_psnr_union_db_mean(24.25f);
  q->set_albedo_ssim_union_min(0.6f);
  q->set_albedo_ssim_union_mean(0.7f);
  q->set_normal_error_deg_mean(7.5f);
  q->set_normal_error_deg_max(120.0f);
  q->set_depth_error_mean(0.02f);
  q->set_depth_error_max(0.5f);
  q->set_pop(1.75f);
  q->add_frames_tried(8);
  q->add_frames_tried(10);
  q->add_frames_met(false);
  q->add_frames_met(true);
  q->set_worst_view(3);
  m.add_warnings("frames_auto: something");
  auto back = ManifestFromJson(ManifestToJson(m));
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->quality().SerializeAsString(), q->SerializeAsString());
  ASSERT_EQ(back->warnings_size(), 1);
  EXPECT_EQ(back->warnings(0), "frames_auto: something");

  // Results from before the quality pass have neither.
  m.clear_quality();
  m.clear_warnings();
  auto old = ManifestFromJson(ManifestToJson(m));
  ASSERT_TRUE(old.ok()) << old.status();
  EXPECT_FALSE(old->has_quality());

  // A present block must be whole.
  std::string text = ManifestToJson(m);
  text.insert(text.rfind('}'), ", \"quality\": {\"blend\": \"triangle3\"}");
  auto broken = ManifestFromJson(text);
  ASSERT_FALSE(broken.ok());
  EXPECT_NE(std::string(broken.status().message()).find("quality.views: missing"), std::string::npos)
      << broken.status();
}

// Issue 43's figures: written when measured, read back exactly, absent from
// older manifests (0, no sizes), and a damaged list refused naming the entry.
TEST(QualityManifestJsonTest, GoodForSizesAndAntialiasedPopRoundTripAndBadOnesAreRefused) {
  v1::Manifest m = AtlasManifestWithQuality();
  v1::AtlasQuality* q = m.mutable_quality();
  q->set_pop(4.0f);
  const std::string without = ManifestToJson(m);
  EXPECT_EQ(without.find("good_up_to_pixels"), std::string::npos);
  EXPECT_EQ(without.find("pop_antialiased"), std::string::npos);
  auto old = ManifestFromJson(without);
  ASSERT_TRUE(old.ok()) << old.status();
  EXPECT_EQ(old->quality().pop_antialiased(), 0.0f);
  EXPECT_EQ(old->quality().sizes_size(), 0);

  q->set_pop_antialiased(1.25f);
  for (auto [pixels, iou, psnr, meets, firm] :
       {std::tuple{32u, 0.91f, 33.5f, true, 0.96875f}, std::tuple{140u, 0.97f, 28.25f, true, 0.975f},
        std::tuple{256u, 0.93f, 24.0f, false, 0.0f}}) {
    v1::SizeQuality* s = q->add_sizes();
    s->set_pixels(pixels);
    s->set_silhouette_iou_mean(iou);
    s->set_albedo_psnr_shared_db_mean(psnr);
    s->set_meets(meets);
    s->set_silhouette_iou_firm_mean(firm);  // 0: not recorded, as before bake7
  }
  q->set_good_up_to_pixels(140);
  const std::string text = ManifestToJson(m);
  auto back = ManifestFromJson(text);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->quality().SerializeAsString(), q->SerializeAsString());

  for (auto [from, to, want] : {
           std::tuple{"\"meets\": false", "\"meets\": 0", "quality.sizes[2].meets: missing or not true/false"},
           std::tuple{"\"pixels\": 256", "\"pixels\": -256", "quality.sizes[2].pixels: not a whole number"},
           std::tuple{"\"pixels\": 140", "\"pixels\": \"140\"", "quality.sizes[1].pixels: missing or not a number"},
           std::tuple{"\"good_up_to_pixels\": 140", "\"good_up_to_pixels\": 1e9", "quality.good_up_to_pixels"},
           std::tuple{"\"pop_antialiased\": 1.25", "\"pop_antialiased\": null", "quality.pop_antialiased"},
           std::tuple{"\"silhouette_iou_firm_mean\": 0.96875", "\"silhouette_iou_firm_mean\": 1.5",
                      "quality.sizes[0].silhouette_iou_firm_mean: not a number 0..1"},
           std::tuple{"\"silhouette_iou_firm_mean\": 0.96875", "\"silhouette_iou_firm_mean\": \"high\"",
                      "quality.sizes[0].silhouette_iou_firm_mean: not a number 0..1"},
       }) {
    std::string bad = text;
    const size_t at = bad.find(from);
    ASSERT_NE(at, std::string::npos) << from << " in " << text;
    bad.replace(at, std::string(from).size(), to);
    auto refused = ManifestFromJson(bad);
    ASSERT_FALSE(refused.ok()) << to;
    EXPECT_EQ(refused.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(refused.status().message()).find(want), std::string::npos) << refused.status();
  }
}

}  // namespace
}  // namespace impostor
