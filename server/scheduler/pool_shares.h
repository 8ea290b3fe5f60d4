// Pools and shares (issue 44): a pool is the workers that report one tag;
// a share guarantees a team (a token name or a client id) at least a
// percentage of a pool's workers while that team has work queued for it.
// The configuration (parsed from --pools and --pool-shares) and the pure
// rule that says which teams a pool owes a worker; BakeScheduler applies
// it when a pool's worker asks for work (bake_scheduler_leases.cc).
// Thread-safe: plain values and pure functions.
//
// A share is a minimum, not a cap: a team below its guarantee has its jobs
// offered first to the pool's workers; at or above it, the usual order
// (priority, then fewest running, then least recently served) decides, so
// a team may use the whole pool while no one else has work.
#ifndef IMPOSTOR_SERVER_SCHEDULER_POOL_SHARES_H_
#define IMPOSTOR_SERVER_SCHEDULER_POOL_SHARES_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor {

// Pools, and shares in one pool, a server takes: each is a metric label.
inline constexpr size_t kMaxPools = 16;
inline constexpr size_t kMaxSharesPerPool = 16;
// A team as --pool-shares names it: 1..128 bytes of printable ASCII
// without ',' (a token name, or an impostor-client-id).
inline constexpr size_t kMaxTeamBytes = 128;

struct TeamShare {
  std::string team;
  int percent = 0;  // 1..100; a pool's shares sum to at most 100
};

struct WorkerPool {
  std::string name;  // [a-z0-9._-], 1..64 bytes
  std::string tag;   // the worker tag (--tags) that puts a worker in it
  std::vector<TeamShare> shares;  // in flag order
};

// --pools (each NAME or NAME=TAG; a bare NAME is the pool of workers
// tagged NAME) and --pool-shares (each POOL:TEAM=PERCENT) as the server
// takes them: the pools in flag order with their shares. INVALID_ARGUMENT
// naming the flag and the entry: a malformed entry, a bad name or tag, a
// pool declared twice, a share in a pool --pools does not declare, a team
// given two shares in one pool, a percent outside 1..100, a pool's shares
// summing over 100, more than kMaxPools pools or kMaxSharesPerPool shares
// in one pool.
absl::StatusOr<std::vector<WorkerPool>> ParsePools(const std::vector<std::string>& pools_flag,
                                                   const std::vector<std::string>& shares_flag);

// Whether a job submitted by token `owner` ('' without tokens) from client
// `client_id` belongs to `team`: the owner is the team, or the client id is.
bool JobOfTeam(const std::string& owner, const std::string& client_id, const std::string& team);

// The workers `percent` of a pool of `pool_workers` guarantees: rounded up,
// so 50 % of 3 workers is 2 ("at least"); 0 for an empty pool.
int64_t GuaranteedWorkers(int percent, int64_t pool_workers);

// The teams of `pool` whose running jobs on its workers
// (`running_per_team`, absent = 0) are below their guarantee over
// `pool_workers`, the furthest below (running / guaranteed) first, then in
// flag order. Empty when no share is owed.
std::vector<std::string> OwedTeams(const WorkerPool& pool, int64_t pool_workers,
                                   const std::map<std::string, int64_t>& running_per_team);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_SCHEDULER_POOL_SHARES_H_
