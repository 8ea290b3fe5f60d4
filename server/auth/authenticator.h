// Turns the "authorization: Bearer <token>" request metadata into a
// Principal (token name, role and default required tags), or UNAUTHENTICATED naming why not:
// no token, a malformed header or token, an unknown, expired or revoked
// token. The message never contains the secret.
//
// Validations are cached per token for `ttl_ms` (default 2 s): a token
// revoked with `impostor-server token revoke` (another process writing the
// same database) is refused within that time on a running server, and the
// database is read at most once per token per TTL. last_used is written at
// most once a minute per token.
//
// Thread-safety: every method may be called from any thread.
#ifndef IMPOSTOR_SERVER_AUTH_AUTHENTICATOR_H_
#define IMPOSTOR_SERVER_AUTH_AUTHENTICATOR_H_

#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "server/store/token_store.h"

namespace impostor {

// Who is calling. With --auth none every caller is the anonymous admin
// (name empty), as before tokens existed.
struct Principal {
  std::string name;
  Role role = Role::kAdmin;
  // The token's default required tags (TokenRecord::required_tags), sorted
  // without repeats; SubmitBake adds them to the request's.
  std::vector<std::string> required_tags = {};
};

class Authenticator {
 public:
  // `store` must outlive the authenticator. `now_ms`: Unix epoch ms (tests
  // pass a fake clock); empty = the system clock.
  Authenticator(TokenStore* store, int64_t ttl_ms = 2000, std::function<int64_t()> now_ms = {});

  // `authorization`: the header's value, or nullptr when the call had none.
  absl::StatusOr<Principal> Authenticate(const std::string* authorization);

 private:
  struct Cached {
    TokenRecord record;  // secret_hash empty = unknown token
    int64_t fetched_ms = 0;
  };
  int64_t Now() const;

  TokenStore* const store_;
  const int64_t ttl_ms_;
  const std::function<int64_t()> now_ms_;
  std::mutex mu_;
  // By secret hash. Bounded: unknown tokens are not kept (a caller trying
  // random tokens must not grow it).
  std::map<std::string, Cached> cache_ ABSL_GUARDED_BY(mu_);
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_AUTH_AUTHENTICATOR_H_
