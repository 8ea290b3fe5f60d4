// NormalizeSubmit / NormalizeLookup (common/request/normalized_bake_request):
// a request is checked, normalised and keyed in one pass before the
// scheduler sees it. Each bad field is refused naming the field and the
// limit; a good one carries the normalised parameters and the same key
// ComputeCacheKey gives.
#include "common/request/normalized_bake_request.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/request/bake_request.h"

namespace impostor {
namespace {

v1::SubmitBakeRequest Good() {
  v1::SubmitBakeRequest r;
  r.mutable_mesh()->mutable_entry()->set_path("model.glb");
  r.mutable_mesh()->mutable_entry()->mutable_digest()->set_hash(std::string(64, 'a'));
  r.mutable_mesh()->mutable_entry()->mutable_digest()->set_size_bytes(10);
  return r;
}

void ExpectRefused(const absl::StatusOr<NormalizedBakeRequest>& r, const std::string& text) {
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << r.status();
  EXPECT_NE(r.status().message().find(text), std::string::npos) << r.status();
}

TEST(NormalizeSubmit, CarriesTheNormalisedParametersAndTheirKey) {
  v1::SubmitBakeRequest r = Good();
  r.set_priority(7);
  r.set_request_id("ci-42_retry");
  auto n = NormalizeSubmit(r);
  ASSERT_TRUE(n.ok()) << n.status();
  auto params = NormalizeParameters(r.parameters());
  ASSERT_TRUE(params.ok());
  EXPECT_EQ(n->parameters.SerializeAsString(), params->SerializeAsString());
  EXPECT_GT(n->parameters.resolution(), 0u);  // defaults filled in
  EXPECT_EQ(n->cache_key, ComputeCacheKey(r.mesh(), *params));
  EXPECT_EQ(n->cache_key.size(), 64u);
  EXPECT_EQ(n->priority, 7);
  EXPECT_EQ(n->request_id, "ci-42_retry");
  EXPECT_FALSE(n->has_gate);
}

TEST(NormalizeSubmit, TheSameRequestSpelledTwoWaysHasOneKey) {
  v1::SubmitBakeRequest plain = Good();
  v1::SubmitBakeRequest spelled = Good();
  auto defaults = NormalizeParameters(plain.parameters());
  ASSERT_TRUE(defaults.ok());
  *spelled.mutable_parameters() = *defaults;  // every default written out
  auto a = NormalizeSubmit(plain);
  auto b = NormalizeSubmit(spelled);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->cache_key, b->cache_key);
  spelled.mutable_parameters()->set_resolution(defaults->resolution() * 2);
  auto c = NormalizeSubmit(spelled);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_NE(a->cache_key, c->cache_key);
}

TEST(NormalizeSubmit, RefusesEachBadFieldNamingItAndTheLimit) {
  v1::SubmitBakeRequest r = Good();
  r.set_priority(101);
  ExpectRefused(NormalizeSubmit(r), "priority: 101 is out of range -100..100");
  r.set_priority(-101);
  ExpectRefused(NormalizeSubmit(r), "priority: -101 is out of range -100..100");

  r = Good();
  r.set_request_id(std::string(kMaxRequestIdBytes + 1, 'x'));
  ExpectRefused(NormalizeSubmit(r), "request_id: 129 bytes is over the limit of 128");
  r.set_request_id("a/b");
  ExpectRefused(NormalizeSubmit(r), "request_id: byte 1 (0x2f) is not one of [A-Za-z0-9_-]");

  r = Good();
  r.mutable_gate()->set_min_iou(1.5f);
  ExpectRefused(NormalizeSubmit(r), "gate");
  r.mutable_gate()->set_min_iou(0.9f);
  r.mutable_parameters()->set_quality_views(0);
  ExpectRefused(NormalizeSubmit(r), "parameters.quality_views 0");

  r = Good();
  r.mutable_mesh()->mutable_entry()->set_path("../escape.glb");
  ExpectRefused(NormalizeSubmit(r), "mesh.entry");
  r = Good();
  r.mutable_mesh()->mutable_entry()->mutable_digest()->set_hash("not-hex");
  ExpectRefused(NormalizeSubmit(r), "mesh.entry");
}

TEST(NormalizeSubmit, KeepsAGateOnlyWhenOneIsSet) {
  v1::SubmitBakeRequest r = Good();
  r.mutable_gate()->set_min_psnr_db(30);
  auto n = NormalizeSubmit(r);
  ASSERT_TRUE(n.ok()) << n.status();
  EXPECT_TRUE(n->has_gate);
  EXPECT_FLOAT_EQ(n->gate.min_psnr_db(), 30);
}

TEST(NormalizeLookup, IgnoresWhatDoesNotChangeTheKey) {
  v1::SubmitBakeRequest r = Good();
  r.set_priority(500);          // out of range for a submit
  r.set_request_id("a/b");      // malformed for a submit
  auto n = NormalizeLookup(r);
  ASSERT_TRUE(n.ok()) << n.status();
  auto s = NormalizeSubmit(Good());
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(n->cache_key, s->cache_key);
  r.mutable_mesh()->mutable_entry()->set_path("");
  EXPECT_FALSE(NormalizeLookup(r).ok());
}

// required_tags: worker tags as impostor-worker --tags takes them, sorted
// and without repeats; a bad one or too many is named with the limit.
TEST(NormalizeSubmit, RequiredTagsAreCheckedSortedAndNotPartOfTheKey) {
  v1::SubmitBakeRequest r = Good();
  r.add_required_tags("team-forest");
  r.add_required_tags("gpu");
  r.add_required_tags("gpu");
  auto n = NormalizeSubmit(r);
  ASSERT_TRUE(n.ok()) << n.status();
  EXPECT_EQ(n->required_tags, (std::vector<std::string>{"gpu", "team-forest"}));
  auto untagged = NormalizeSubmit(Good());
  ASSERT_TRUE(untagged.ok());
  EXPECT_EQ(n->cache_key, untagged->cache_key);

  v1::SubmitBakeRequest bad = Good();
  bad.add_required_tags("gpu");
  bad.add_required_tags("GPU");
  ExpectRefused(NormalizeSubmit(bad), "required_tags[1]: \"GPU\" is not 1..64 bytes of [a-z0-9._-]");
  v1::SubmitBakeRequest empty = Good();
  empty.add_required_tags("");
  ExpectRefused(NormalizeSubmit(empty), "required_tags[0]: \"\" is not 1..64 bytes");
  v1::SubmitBakeRequest many = Good();
  for (int i = 0; i < 17; ++i) many.add_required_tags("t" + std::to_string(i));
  ExpectRefused(NormalizeSubmit(many), "required_tags: 17 tags is over the limit of 16");
}

}  // namespace
}  // namespace impostor
