#include "server/scheduler/hit_job_id.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "server/scheduler/bake_scheduler.h"  // NewId

namespace impostor {
namespace {

constexpr std::string_view kHitPrefix = "hit-";
constexpr size_t kHitTagChars = 32;

std::string ToHex(std::string_view bytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned char b : bytes) {
    out.push_back(kHex[b >> 4]);
    out.push_back(kHex[b & 0xf]);
  }
  return out;
}

}  // namespace

std::string HitJobId(const std::string& key, const std::string& requester, const std::string& request_id,
                     const std::string& owner) {
  std::string id = std::string(kHitPrefix) + key + "-";
  if (request_id.empty()) {
    id += NewId("").substr(0, kHitTagChars);
  } else {
    id += Sha256Hex(absl::StrCat(requester, "\n", request_id)).substr(0, kHitTagChars);
  }
  if (!owner.empty()) absl::StrAppend(&id, "-", ToHex(owner));
  return id;
}

std::optional<HitId> ParseHitJobId(std::string_view id) {
  auto is_hex = [](std::string_view s) {
    return std::all_of(s.begin(), s.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
  };
  if (id.substr(0, kHitPrefix.size()) != kHitPrefix) return std::nullopt;
  id.remove_prefix(kHitPrefix.size());
  if (id.size() < 64 + 1 + kHitTagChars || id[64] != '-') return std::nullopt;
  HitId hit{std::string(id.substr(0, 64)), ""};
  if (!IsSha256Hex(hit.cache_key) || !is_hex(id.substr(65, kHitTagChars))) return std::nullopt;
  std::string_view owner = id.substr(65 + kHitTagChars);
  if (owner.empty()) return hit;
  if (owner[0] != '-' || owner.size() < 3 || owner.size() % 2 == 0 || !is_hex(owner.substr(1))) return std::nullopt;
  for (size_t i = 1; i + 1 < owner.size(); i += 2) {
    auto nibble = [](char c) { return c <= '9' ? c - '0' : c - 'a' + 10; };
    hit.owner.push_back(static_cast<char>(nibble(owner[i]) * 16 + nibble(owner[i + 1])));
  }
  return hit;
}

}  // namespace impostor
