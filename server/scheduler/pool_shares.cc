#include "server/scheduler/pool_shares.h"

#include <algorithm>
#include <charconv>

#include "absl/strings/str_cat.h"
#include "common/request/worker_fit.h"

namespace impostor {
namespace {

bool IsValidTeam(const std::string& team) {
  if (team.empty() || team.size() > kMaxTeamBytes) return false;
  return std::all_of(team.begin(), team.end(), [](char c) { return c > ' ' && c < 127 && c != ','; });
}

absl::Status Bad(const char* flag, const std::string& entry, const std::string& why) {
  return absl::InvalidArgumentError(absl::StrCat(flag, ": \"", entry.substr(0, 200), "\" ", why));
}

}  // namespace

absl::StatusOr<std::vector<WorkerPool>> ParsePools(const std::vector<std::string>& pools_flag,
                                                   const std::vector<std::string>& shares_flag) {
  std::vector<WorkerPool> pools;
  for (const std::string& entry : pools_flag) {
    const size_t eq = entry.find('=');
    WorkerPool pool;
    pool.name = entry.substr(0, eq);
    pool.tag = eq == std::string::npos ? pool.name : entry.substr(eq + 1);
    if (!IsValidWorkerTag(pool.name)) return Bad("--pools", entry, "needs a pool name of 1..64 bytes of [a-z0-9._-]");
    if (!IsValidWorkerTag(pool.tag)) return Bad("--pools", entry, "needs a worker tag of 1..64 bytes of [a-z0-9._-]");
    if (std::any_of(pools.begin(), pools.end(), [&](const WorkerPool& p) { return p.name == pool.name; })) {
      return Bad("--pools", entry, absl::StrCat("declares pool \"", pool.name, "\" twice"));
    }
    if (pools.size() == kMaxPools) return Bad("--pools", entry, absl::StrCat("is over the limit of ", kMaxPools, " pools"));
    pools.push_back(std::move(pool));
  }
  for (const std::string& entry : shares_flag) {
    const size_t colon = entry.find(':');
    const size_t eq = entry.rfind('=');
    if (colon == std::string::npos || eq == std::string::npos || eq < colon) {
      return Bad("--pool-shares", entry, "is not POOL:TEAM=PERCENT");
    }
    const std::string name = entry.substr(0, colon);
    const std::string team = entry.substr(colon + 1, eq - colon - 1);
    const std::string digits = entry.substr(eq + 1);
    auto pool = std::find_if(pools.begin(), pools.end(), [&](const WorkerPool& p) { return p.name == name; });
    if (pool == pools.end()) {
      return Bad("--pool-shares", entry, absl::StrCat("names pool \"", name.substr(0, 64), "\", which --pools does not declare"));
    }
    if (!IsValidTeam(team)) {
      return Bad("--pool-shares", entry, "needs a team (a token name or client id) of 1..128 bytes of printable ASCII");
    }
    int percent = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), percent);
    if (digits.empty() || ec != std::errc() || end != digits.data() + digits.size() || percent < 1 || percent > 100) {
      return Bad("--pool-shares", entry, "has a percent outside 1..100");
    }
    if (std::any_of(pool->shares.begin(), pool->shares.end(), [&](const TeamShare& s) { return s.team == team; })) {
      return Bad("--pool-shares", entry, absl::StrCat("gives team \"", team, "\" a second share of pool \"", name, "\""));
    }
    if (pool->shares.size() == kMaxSharesPerPool) {
      return Bad("--pool-shares", entry, absl::StrCat("is over the limit of ", kMaxSharesPerPool, " shares in one pool"));
    }
    int sum = percent;
    for (const TeamShare& s : pool->shares) sum += s.percent;
    if (sum > 100) {
      return Bad("--pool-shares", entry, absl::StrCat("brings the shares of pool \"", name, "\" to ", sum, " %, over 100"));
    }
    pool->shares.push_back({.team = team, .percent = percent});
  }
  return pools;
}

bool JobOfTeam(const std::string& owner, const std::string& client_id, const std::string& team) {
  return owner == team || client_id == team;
}

int64_t GuaranteedWorkers(int percent, int64_t pool_workers) {
  if (pool_workers <= 0 || percent <= 0) return 0;
  return (int64_t{percent} * pool_workers + 99) / 100;
}

std::vector<std::string> OwedTeams(const WorkerPool& pool, int64_t pool_workers,
                                   const std::map<std::string, int64_t>& running_per_team) {
  // (running / guaranteed, flag order, team): compared as fractions.
  struct Owed {
    int64_t running;
    int64_t guaranteed;
    size_t order;
  };
  std::vector<Owed> owed;
  for (size_t i = 0; i < pool.shares.size(); ++i) {
    const int64_t guaranteed = GuaranteedWorkers(pool.shares[i].percent, pool_workers);
    const auto it = running_per_team.find(pool.shares[i].team);
    const int64_t running = it == running_per_team.end() ? 0 : it->second;
    if (running < guaranteed) owed.push_back({running, guaranteed, i});
  }
  std::stable_sort(owed.begin(), owed.end(), [](const Owed& a, const Owed& b) {
    return a.running * b.guaranteed < b.running * a.guaranteed;
  });
  std::vector<std::string> teams;
  for (const Owed& o : owed) teams.push_back(pool.shares[o.order].team);
  return teams;
}

}  // namespace impostor
