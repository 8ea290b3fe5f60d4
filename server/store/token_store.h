// Bearer tokens and their roles (issue 14): who may call the farm.
//
// A token is "imp_" followed by 43 base64url characters (32 random bytes
// from OpenSSL's RAND_bytes), so a malformed header can be told from an
// unknown token and a leaked one is easy to grep for. Only the SHA-256 of
// the whole token string is stored: the secret itself is printed once by
// `impostor-server token create` and never kept.
//
// TokenStore is the persistence interface, with two engines chosen by
// token_store_factory.h: SQLite in the server's data directory, and
// PostgreSQL in the --database several replicas share (issue 15).
// Token names are the identity everything else refers to: job ownership,
// the worker that baked a result, quotas and audit lines. At most one
// unrevoked token has a given name; revoking frees the name for a successor.
#ifndef IMPOSTOR_SERVER_STORE_TOKEN_STORE_H_
#define IMPOSTOR_SERVER_STORE_TOKEN_STORE_H_

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor {

// What a token may do; see access_policy.h for the table of RPCs.
enum class Role { kReader, kSubmitter, kWorker, kAdmin };

std::string_view RoleName(Role role);
// INVALID_ARGUMENT naming the four roles for anything else.
absl::StatusOr<Role> ParseRole(std::string_view name);

inline constexpr std::string_view kTokenPrefix = "imp_";
inline constexpr size_t kTokenSecretChars = 43;  // base64url of 32 bytes, no padding

// A fresh secret: kTokenPrefix + 43 base64url characters.
std::string NewTokenSecret();
// True when `token` has the shape NewTokenSecret makes (prefix, length,
// alphabet). Says nothing about whether the token exists.
bool IsWellFormedToken(std::string_view token);
// What the store keeps: lowercase hex SHA-256 of the token string.
std::string TokenHash(std::string_view token);

// INVALID_ARGUMENT unless `name` is 1..64 characters of [A-Za-z0-9._-].
absl::Status ValidateTokenName(std::string_view name);

// A token's default required tags (`token create --require-tag`, issue 44):
// the same rule as a request's required_tags, at most kMaxWorkerTags, each
// 1..64 bytes of [a-z0-9._-] (common/request/worker_fit.h). Returns them
// sorted without repeats; INVALID_ARGUMENT naming --require-tag, and the
// limit, otherwise.
absl::StatusOr<std::vector<std::string>> NormalizeTokenRequiredTags(const std::vector<std::string>& tags);
// OK when `tags` is empty or `role` submits bakes (submitter, admin): on a
// reader's or worker's token they would promise a placement nothing
// enforces. INVALID_ARGUMENT naming --require-tag and the role otherwise.
absl::Status CheckRequiredTagsFitRole(Role role, const std::vector<std::string>& tags);

struct TokenRecord;
// What every engine's Insert checks first: the name (ValidateTokenName), a
// role of the enum, a 64-hex-digit secret hash, required tags that
// NormalizeTokenRequiredTags accepts and only on a role that submits bakes
// (submitter, admin). INVALID_ARGUMENT naming the field otherwise.
absl::Status ValidateTokenRecord(const TokenRecord& record);

struct TokenRecord {
  std::string name;
  Role role = Role::kReader;
  std::string secret_hash;  // TokenHash of the secret
  int64_t created_ms = 0;   // Unix epoch milliseconds
  int64_t expires_ms = 0;   // 0 = never
  int64_t last_used_ms = 0; // 0 = never; updated at most about once a minute
  int64_t revoked_ms = 0;   // 0 = live
  // Tags every bake submitted with this token requires of its worker, on
  // top of the request's own required_tags (the RPC edge merges them,
  // server/rpc/submit_tags.h). Engines store them sorted without repeats
  // (NormalizeTokenRequiredTags) and read them back so.
  std::vector<std::string> required_tags = {};
};

// How both engines keep required_tags in one text column: joined with ','
// (a tag never contains one), "" for none.
std::string EncodeTokenRequiredTags(const std::vector<std::string>& tags);
// The inverse; DATA_LOSS naming the token when a stored tag is not one.
absl::StatusOr<std::vector<std::string>> DecodeTokenRequiredTags(std::string_view column, std::string_view token_name);

// Thread-safety: implementations may be called from any thread.
class TokenStore {
 public:
  virtual ~TokenStore() = default;
  // ALREADY_EXISTS when an unrevoked token that has not expired by
  // record.created_ms has record.name (an expired one is marked revoked at
  // its expiry and the name goes to the new token); INVALID_ARGUMENT from
  // ValidateTokenRecord.
  virtual absl::Status Insert(const TokenRecord& record) = 0;
  virtual absl::StatusOr<std::optional<TokenRecord>> FindByHash(const std::string& secret_hash) = 0;
  // Every token ever created, revoked ones too, oldest first.
  virtual absl::StatusOr<std::vector<TokenRecord>> List() = 0;
  // Revokes the unrevoked token named `name`; NOT_FOUND when there is none.
  virtual absl::Status Revoke(const std::string& name, int64_t now_ms) = 0;
  virtual absl::Status MarkUsed(const std::string& secret_hash, int64_t now_ms) = 0;
};

// DIR/tokens.sqlite3 (WAL, so `impostor-server token ...` works beside a
// running server). INTERNAL with SQLite's message on failure.
absl::StatusOr<std::unique_ptr<TokenStore>> OpenSqliteTokenStore(const std::filesystem::path& data_dir);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_TOKEN_STORE_H_
