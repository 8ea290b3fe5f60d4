// Request validation of the view layouts: defaults, derived grids and the
// errors a client sees for each bad combination.
#include <string>

#include <gtest/gtest.h>

#include "common/request/bake_request.h"
#include "common/request/layout_parameters.h"

namespace impostor {
namespace {

v1::BakeParameters Params(v1::Layout layout, uint32_t frames = 0) {
  v1::BakeParameters p;
  p.set_layout(layout);
  p.set_frames(frames);
  p.set_resolution(1024);
  return p;
}

TEST(LayoutParameters, DefaultsPerLayout) {
  struct Case {
    v1::Layout layout;
    uint32_t frames;      // after normalisation
    uint32_t ring_views;  // after normalisation
  } cases[] = {
      {v1::LAYOUT_OCTAHEDRAL, 12, 0},
      {v1::LAYOUT_HEMI_OCTAHEDRAL, 12, 0},
      {v1::LAYOUT_AZIMUTH_ELEVATION, 11, 0},
      {v1::LAYOUT_RING_TOP, 5, 24},  // 24 + 1 frames in a 5 x 5 grid
      {v1::LAYOUT_BILLBOARD, 3, 0},
  };
  for (const Case& c : cases) {
    auto p = NormalizeParameters(Params(c.layout));
    ASSERT_TRUE(p.ok()) << v1::Layout_Name(c.layout) << ": " << p.status();
    EXPECT_EQ(p->frames(), c.frames) << v1::Layout_Name(c.layout);
    EXPECT_EQ(p->ring_views(), c.ring_views) << v1::Layout_Name(c.layout);
  }
}

TEST(LayoutParameters, RingViewsSetTheGrid) {
  v1::BakeParameters in = Params(v1::LAYOUT_RING_TOP);
  in.set_ring_views(8);
  auto p = NormalizeParameters(in);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->frames(), 3u);
  const ViewLayout layout = ViewLayoutOf(*p);
  EXPECT_EQ(FrameCount(layout), 9);
}

TEST(LayoutParameters, ExplicitDefaultsShareTheCacheKey) {
  v1::BakeParameters implicit = Params(v1::LAYOUT_RING_TOP);
  v1::BakeParameters explicit_ = Params(v1::LAYOUT_RING_TOP);
  explicit_.set_ring_views(24);
  auto a = NormalizeParameters(implicit);
  auto b = NormalizeParameters(explicit_);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->SerializeAsString(), b->SerializeAsString());
}

TEST(LayoutParameters, BadCombinationsNameTheFieldAndTheRule) {
  struct Case {
    const char* name;
    v1::BakeParameters params;
    const char* expect;
  };
  auto with_ring = [](v1::Layout layout, uint32_t ring) {
    v1::BakeParameters p = Params(layout);
    p.set_ring_views(ring);
    return p;
  };
  v1::BakeParameters surfels = Params(v1::LAYOUT_BILLBOARD);
  surfels.set_product(v1::PRODUCT_SURFELS);
  surfels.set_frames(0);
  const Case cases[] = {
      {"even azimuth-elevation", Params(v1::LAYOUT_AZIMUTH_ELEVATION, 8),
       "parameters.frames: azimuth-elevation needs an odd row count so that a row sits at 0 degrees "
       "elevation; got 8 (use 7 or 9)"},
      {"tiny azimuth-elevation", Params(v1::LAYOUT_AZIMUTH_ELEVATION, 1), "out of range 3..63"},
      {"ring-top with frames", Params(v1::LAYOUT_RING_TOP, 5),
       "parameters.frames: ring-top derives its atlas grid from ring_views; leave frames unset"},
      {"billboard with frames", Params(v1::LAYOUT_BILLBOARD, 3), "parameters.frames: billboard derives"},
      {"ring too small", with_ring(v1::LAYOUT_RING_TOP, 2), "parameters.ring_views: 2 is out of range 3..64"},
      {"ring too large", with_ring(v1::LAYOUT_RING_TOP, 65), "parameters.ring_views: 65 is out of range 3..64"},
      {"ring with octahedral", with_ring(v1::LAYOUT_OCTAHEDRAL, 8),
       "parameters.ring_views: only for layout ring-top, not octahedral"},
      {"ring with billboard", with_ring(v1::LAYOUT_BILLBOARD, 8), "parameters.ring_views: only for layout ring-top"},
      {"surfels from a billboard", surfels, "parameters.layout: surfel captures use octahedral or hemi-octahedral"},
      {"unknown layout", Params(static_cast<v1::Layout>(9)), "parameters.layout: unknown value 9"},
  };
  for (const Case& c : cases) {
    auto p = NormalizeParameters(c.params);
    ASSERT_FALSE(p.ok()) << c.name;
    EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_NE(std::string(p.status().message()).find(c.expect), std::string::npos)
        << c.name << ": " << p.status().message();
  }
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

TEST(SupersamplingParameters, DefaultRangeAndProducts) {
  v1::BakeParameters atlas;
  auto p = NormalizeParameters(atlas);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->supersampling(), 2u);

  struct Case {
    const char* name;
    v1::Product product;
    uint32_t supersampling;
    uint32_t resolution;
    const char* expect;  // empty = accepted
  } cases[] = {
      {"one", v1::PRODUCT_ATLAS, 1, 1024, ""},
      {"four", v1::PRODUCT_ATLAS, 4, 4096, ""},
      {"zero", v1::PRODUCT_ATLAS, 0, 1024, "parameters.supersampling: 0 is out of range 1..4"},
      {"five", v1::PRODUCT_ATLAS, 5, 1024, "parameters.supersampling: 5 is out of range 1..4"},
      {"too many pixels", v1::PRODUCT_ATLAS, 4, 8192,
       "parameters.supersampling: 4 x resolution 8192 = 32768 px exceeds the 16384 px render limit"},
      {"lod chain", v1::PRODUCT_LOD_CHAIN, 3, 1024, ""},
      {"surfels", v1::PRODUCT_SURFELS, 2, 1024,
       "parameters.supersampling: only for products PRODUCT_ATLAS and PRODUCT_LOD_CHAIN"},
  };
  for (const Case& c : cases) {
    v1::BakeParameters in;
    in.set_product(c.product);
    in.set_supersampling(c.supersampling);
    in.set_resolution(c.resolution);
    auto out = NormalizeParameters(in);
    if (std::string(c.expect).empty()) {
      ASSERT_TRUE(out.ok()) << c.name << ": " << out.status();
      EXPECT_EQ(out->supersampling(), c.supersampling) << c.name;
    } else {
      ASSERT_FALSE(out.ok()) << c.name;
      EXPECT_NE(std::string(out.status().message()).find(c.expect), std::string::npos)
          << c.name << ": " << out.status().message();
    }
  }
}

}  // namespace
}  // namespace impostor

namespace impostor {
namespace {

TEST(LayoutParameters, EverySettingThatChangesTheBakeChangesTheKey) {
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path("a.glb");
  mesh.mutable_entry()->mutable_digest()->set_hash(std::string(64, 'a'));
  mesh.mutable_entry()->mutable_digest()->set_size_bytes(10);
  auto key = [&](const v1::BakeParameters& in) {
    auto p = NormalizeParameters(in);
    EXPECT_TRUE(p.ok()) << p.status();
    return ComputeCacheKey(mesh, *p);
  };
  v1::BakeParameters ring10, ring12;
  ring10.set_layout(v1::LAYOUT_RING_TOP);
  ring10.set_ring_views(10);
  ring12 = ring10;
  ring12.set_ring_views(12);  // both 4 x 4 grids
  EXPECT_NE(key(ring10), key(ring12));
  v1::BakeParameters ss1, ss2, array;
  ss1.set_supersampling(1);
  ss2.set_supersampling(2);
  array.set_texture_array(true);
  EXPECT_NE(key(ss1), key(ss2));
  EXPECT_EQ(key(ss2), key(v1::BakeParameters()));  // the default, spelt out
  EXPECT_NE(key(array), key(v1::BakeParameters()));
  v1::BakeParameters surfel_array;
  surfel_array.set_product(v1::PRODUCT_SURFELS);
  surfel_array.set_texture_array(true);
  EXPECT_FALSE(NormalizeParameters(surfel_array).ok());
}

}  // namespace
}  // namespace impostor
