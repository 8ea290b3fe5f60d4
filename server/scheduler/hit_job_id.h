// Job ids of cache hits, which get no row: "hit-" + cache key + "-" + 32
// hex characters (a hash of the requester and its request_id, so a retried
// submit gets the same id; random without a request_id) + optionally "-" +
// the owner token's name in hex (what JobOwner answers). The id grants
// nothing: the result it names is readable by every reader already.
#ifndef IMPOSTOR_SERVER_SCHEDULER_HIT_JOB_ID_H_
#define IMPOSTOR_SERVER_SCHEDULER_HIT_JOB_ID_H_

#include <optional>
#include <string>
#include <string_view>

namespace impostor {

struct HitId {
  std::string cache_key;
  std::string owner;
};

std::string HitJobId(const std::string& key, const std::string& requester, const std::string& request_id,
                     const std::string& owner);

// The key and owner a hit id names; nullopt for anything else (a queued
// job's id, or a malformed one).
std::optional<HitId> ParseHitJobId(std::string_view id);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_SCHEDULER_HIT_JOB_ID_H_
