#include "server/auth/authenticator.h"

#include <chrono>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/time/time.h"

namespace impostor {
namespace {

constexpr int64_t kLastUsedEveryMs = 60'000;
constexpr std::string_view kBearer = "Bearer ";

std::string Iso(int64_t ms) {
  return absl::FormatTime("%Y-%m-%dT%H:%M:%SZ", absl::FromUnixMillis(ms), absl::UTCTimeZone());
}

}  // namespace

Authenticator::Authenticator(TokenStore* store, int64_t ttl_ms, std::function<int64_t()> now_ms)
    : store_(store), ttl_ms_(ttl_ms), now_ms_(std::move(now_ms)) {}

int64_t Authenticator::Now() const {
  if (now_ms_) return now_ms_();
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

absl::StatusOr<Principal> Authenticator::Authenticate(const std::string* authorization) {
  if (authorization == nullptr) {
    return absl::UnauthenticatedError(
        "no token: send the 'authorization: Bearer <token>' metadata (impostor --token-file FILE or "
        "IMPOSTOR_TOKEN); `impostor-server token create` makes one");
  }
  // The scheme is case-insensitive (RFC 7235 section 2.1): "bearer" too.
  if (authorization->size() < kBearer.size() ||
      !absl::EqualsIgnoreCase(absl::string_view(*authorization).substr(0, kBearer.size()),
                              absl::string_view(kBearer.data(), kBearer.size()))) {
    return absl::UnauthenticatedError("malformed authorization metadata: expected 'Bearer <token>'");
  }
  const std::string_view token = std::string_view(*authorization).substr(kBearer.size());
  if (!IsWellFormedToken(token)) {
    return absl::UnauthenticatedError(absl::StrCat("malformed token: expected '", std::string(kTokenPrefix), "' and ",
                                                   kTokenSecretChars, " base64url characters"));
  }
  const std::string hash = TokenHash(token);
  const int64_t now = Now();
  TokenRecord record;
  bool mark_used = false;
  {
    std::lock_guard lock(mu_);
    auto it = cache_.find(hash);
    if (it == cache_.end() || now - it->second.fetched_ms >= ttl_ms_ || now < it->second.fetched_ms) {
      auto found = store_->FindByHash(hash);
      if (!found.ok()) return absl::UnavailableError(absl::StrCat("token check failed: ", found.status().message()));
      if (!found->has_value()) {
        if (it != cache_.end()) cache_.erase(it);
        return absl::UnauthenticatedError("unknown token: it was never issued by this server");
      }
      const int64_t last_used = it == cache_.end() ? (*found)->last_used_ms : it->second.record.last_used_ms;
      it = cache_.insert_or_assign(hash, Cached{**found, now}).first;
      it->second.record.last_used_ms = std::max(last_used, (*found)->last_used_ms);
    }
    record = it->second.record;
    if (record.revoked_ms == 0 && (record.expires_ms == 0 || now < record.expires_ms) &&
        now - record.last_used_ms >= kLastUsedEveryMs) {
      it->second.record.last_used_ms = now;
      mark_used = true;
    }
  }
  if (record.revoked_ms != 0) {
    return absl::UnauthenticatedError(
        absl::StrCat("revoked token: '", record.name, "' was revoked at ", Iso(record.revoked_ms)));
  }
  if (record.expires_ms != 0 && now >= record.expires_ms) {
    return absl::UnauthenticatedError(
        absl::StrCat("expired token: '", record.name, "' expired at ", Iso(record.expires_ms)));
  }
  // A lost last-used update is not worth refusing a valid call for.
  if (mark_used) (void)store_->MarkUsed(hash, now);
  return Principal{record.name, record.role, record.required_tags};
}

}  // namespace impostor
