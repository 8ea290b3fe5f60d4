// BakeParameters.emissive: `impostor bake --emissive` sets it, the server
// accepts it for atlases only, and it is part of the cache key only when set
// (keys of bakes without it do not change).
#include <gtest/gtest.h>

#include <string>

#include "client/cli/cli_args.h"
#include "common/request/bake_request.h"

namespace impostor {
namespace {

v1::MeshInput Mesh() {
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path("model.glb");
  mesh.mutable_entry()->mutable_digest()->set_hash(std::string(64, 'a'));
  mesh.mutable_entry()->mutable_digest()->set_size_bytes(100);
  return mesh;
}

TEST(EmissiveRequestTest, CliFlag) {
  absl::StatusOr<cli::CliArgs> a = cli::ParseCliArgs({"bake", "tree.gltf", "--out", "o", "--emissive"}, nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_TRUE(a->emissive);
  a = cli::ParseCliArgs({"bake", "tree.gltf", "--out", "o"}, nullptr);
  ASSERT_TRUE(a.ok()) << a.status();
  EXPECT_FALSE(a->emissive);
  EXPECT_FALSE(cli::ParseCliArgs({"bake", "tree.gltf", "--out", "o", "--emissive=yes"}, nullptr).ok());
}

TEST(EmissiveRequestTest, AcceptedForAtlasesAndInTheCacheKey) {
  v1::BakeParameters p;
  p.set_product(v1::PRODUCT_ATLAS);
  absl::StatusOr<v1::BakeParameters> plain = NormalizeParameters(p);
  ASSERT_TRUE(plain.ok()) << plain.status();
  p.set_emissive(true);
  absl::StatusOr<v1::BakeParameters> emissive = NormalizeParameters(p);
  ASSERT_TRUE(emissive.ok()) << emissive.status();
  EXPECT_TRUE(emissive->emissive());
  EXPECT_NE(ComputeCacheKey(Mesh(), *plain), ComputeCacheKey(Mesh(), *emissive));
}

TEST(EmissiveRequestTest, RefusedForOtherProductsNamingTheField) {
  for (v1::Product product : {v1::PRODUCT_SURFELS, v1::PRODUCT_CARDS, v1::PRODUCT_LOD_CHAIN}) {
    v1::BakeParameters p;
    p.set_product(product);
    p.set_emissive(true);
    absl::StatusOr<v1::BakeParameters> out = NormalizeParameters(p);
    ASSERT_EQ(out.status().code(), absl::StatusCode::kInvalidArgument) << product;
    EXPECT_NE(out.status().message().find("parameters.emissive"), std::string::npos)
        << out.status();
  }
}

}  // namespace
}  // namespace impostor
