// Pools and shares (issue 44): the pure rules in
// server/scheduler/pool_shares.h, table by table. The scheduler applying
// them over 200 bakes is pool_share_scheduling_test.cc.
#include "server/scheduler/pool_shares.h"

#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace impostor {
namespace {

TEST(PoolShares, ParsesPoolsAndShares) {
  auto pools = ParsePools({"gpu", "big=ram-256g"}, {"gpu:team-forest=50", "gpu:ci/10.0.0.7=20", "big:team-desert=100"});
  ASSERT_TRUE(pools.ok()) << pools.status();
  ASSERT_EQ(pools->size(), 2u);
  EXPECT_EQ((*pools)[0].name, "gpu");
  EXPECT_EQ((*pools)[0].tag, "gpu") << "a bare NAME is the pool of workers tagged NAME";
  ASSERT_EQ((*pools)[0].shares.size(), 2u);
  EXPECT_EQ((*pools)[0].shares[0].team, "team-forest");
  EXPECT_EQ((*pools)[0].shares[0].percent, 50);
  EXPECT_EQ((*pools)[0].shares[1].team, "ci/10.0.0.7");
  EXPECT_EQ((*pools)[1].name, "big");
  EXPECT_EQ((*pools)[1].tag, "ram-256g");
  EXPECT_EQ((*pools)[1].shares[0].percent, 100);
  auto none = ParsePools({}, {});
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  auto client_with_colon = ParsePools({"gpu"}, {"gpu:ipv4:10.0.0.7=10"});
  ASSERT_TRUE(client_with_colon.ok()) << client_with_colon.status();
  EXPECT_EQ((*client_with_colon)[0].shares[0].team, "ipv4:10.0.0.7") << "a peer address as client id";
}

TEST(PoolShares, RefusesBadFlagsNamingTheFlagAndEntry) {
  const struct {
    const char* name;
    std::vector<std::string> pools;
    std::vector<std::string> shares;
    const char* message;
  } cases[] = {
      {"unknown pool", {"gpu"}, {"cpu:team-forest=50"},
       "--pool-shares: \"cpu:team-forest=50\" names pool \"cpu\", which --pools does not declare"},
      {"percent 0", {"gpu"}, {"gpu:team-forest=0"}, "--pool-shares: \"gpu:team-forest=0\" has a percent outside 1..100"},
      {"percent 101", {"gpu"}, {"gpu:team-forest=101"},
       "--pool-shares: \"gpu:team-forest=101\" has a percent outside 1..100"},
      {"percent not a number", {"gpu"}, {"gpu:team-forest=half"},
       "--pool-shares: \"gpu:team-forest=half\" has a percent outside 1..100"},
      {"percent with a sign", {"gpu"}, {"gpu:team-forest=-5"},
       "--pool-shares: \"gpu:team-forest=-5\" has a percent outside 1..100"},
      {"shares over 100", {"gpu"}, {"gpu:team-forest=60", "gpu:team-desert=41"},
       "--pool-shares: \"gpu:team-desert=41\" brings the shares of pool \"gpu\" to 101 %, over 100"},
      {"no team", {"gpu"}, {"gpu:=50"},
       "--pool-shares: \"gpu:=50\" needs a team (a token name or client id) of 1..128 bytes of printable ASCII"},
      {"not POOL:TEAM=PERCENT", {"gpu"}, {"gpu=50"}, "--pool-shares: \"gpu=50\" is not POOL:TEAM=PERCENT"},
      {"a team twice", {"gpu"}, {"gpu:team-forest=10", "gpu:team-forest=20"},
       "--pool-shares: \"gpu:team-forest=20\" gives team \"team-forest\" a second share of pool \"gpu\""},
      {"pool twice", {"gpu", "gpu=other"}, {},
       "--pools: \"gpu=other\" declares pool \"gpu\" twice"},
      {"bad pool name", {"GPU"}, {}, "--pools: \"GPU\" needs a pool name of 1..64 bytes of [a-z0-9._-]"},
      {"bad tag", {"gpu=Big GPU"}, {}, "--pools: \"gpu=Big GPU\" needs a worker tag of 1..64 bytes of [a-z0-9._-]"},
      {"empty tag", {"gpu="}, {}, "--pools: \"gpu=\" needs a worker tag of 1..64 bytes of [a-z0-9._-]"},
  };
  for (const auto& c : cases) {
    auto got = ParsePools(c.pools, c.shares);
    ASSERT_FALSE(got.ok()) << c.name;
    EXPECT_EQ(got.status().code(), absl::StatusCode::kInvalidArgument) << c.name;
    EXPECT_EQ(got.status().message(), c.message) << c.name;
  }
  std::vector<std::string> many;
  for (int i = 0; i <= static_cast<int>(kMaxPools); ++i) many.push_back("p" + std::to_string(i));
  EXPECT_FALSE(ParsePools(many, {}).ok()) << "more than kMaxPools pools";
}

TEST(PoolShares, AShareGuaranteesWorkersRoundedUp) {
  const struct {
    int percent;
    int64_t workers;
    int64_t guaranteed;
  } cases[] = {{50, 4, 2}, {50, 3, 2}, {75, 4, 3}, {1, 10, 1}, {100, 7, 7}, {33, 3, 1}, {50, 0, 0}, {10, 1, 1}};
  for (const auto& c : cases) {
    EXPECT_EQ(GuaranteedWorkers(c.percent, c.workers), c.guaranteed) << c.percent << " % of " << c.workers;
  }
}

TEST(PoolShares, OwesTheTeamsBelowTheirGuaranteeFurthestBelowFirst) {
  const WorkerPool pool{.name = "gpu",
                        .tag = "gpu",
                        .shares = {{.team = "forest", .percent = 50}, {.team = "desert", .percent = 25}}};
  const struct {
    const char* name;
    int64_t workers;
    std::map<std::string, int64_t> running;
    std::vector<std::string> owed;
  } cases[] = {
      {"nothing runs: both, forest first (flag order)", 8, {}, {"forest", "desert"}},
      {"forest at its 4 of 8", 8, {{"forest", 4}}, {"desert"}},
      {"forest over its share: still none owed to it", 8, {{"forest", 7}, {"desert", 2}}, {}},
      {"forest 1 of 4, desert 0 of 2: desert further below", 8, {{"forest", 1}}, {"desert", "forest"}},
      {"forest 3 of 4, desert 1 of 2: desert further below", 8, {{"forest", 3}, {"desert", 1}}, {"desert", "forest"}},
      {"an empty pool owes nothing", 0, {}, {}},
      {"a team without a share is never owed", 8, {{"other", 0}}, {"forest", "desert"}},
  };
  for (const auto& c : cases) EXPECT_EQ(OwedTeams(pool, c.workers, c.running), c.owed) << c.name;
}

TEST(PoolShares, AJobIsItsTokensTeamOrItsClients) {
  EXPECT_TRUE(JobOfTeam("team-forest", "team-forest/10.0.0.7", "team-forest")) << "the submitting token";
  EXPECT_TRUE(JobOfTeam("", "team-forest", "team-forest")) << "the impostor-client-id, without tokens";
  EXPECT_FALSE(JobOfTeam("", "team-forest/10.0.0.7", "team-forest")) << "a client id is matched whole";
  EXPECT_FALSE(JobOfTeam("team-desert", "team-desert", "team-forest"));
}

}  // namespace
}  // namespace impostor
