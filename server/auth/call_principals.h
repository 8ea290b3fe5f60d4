// Who is making each call in progress (token name, role, default required
// tags), as the authorisation layer (authorized_services.h) established it,
// for the few handlers that use identity: SubmitBake (the job's owner and
// the token's required tags) and LeaseJob (the lease holder).
// Keyed by the call's ServerContext; an entry lives exactly as long as the
// handler runs (CallPrincipals::Scope).
//
// Thread-safety: every method may be called from any thread.
#ifndef IMPOSTOR_SERVER_AUTH_CALL_PRINCIPALS_H_
#define IMPOSTOR_SERVER_AUTH_CALL_PRINCIPALS_H_

#include <map>
#include <mutex>

#include "absl/base/thread_annotations.h"
#include "server/auth/authenticator.h"

namespace impostor {

class CallPrincipals {
 public:
  class Scope {
   public:
    Scope(CallPrincipals* registry, const void* call, Principal principal) : registry_(registry), call_(call) {
      std::lock_guard lock(registry_->mu_);
      registry_->calls_[call_] = std::move(principal);
    }
    ~Scope() {
      std::lock_guard lock(registry_->mu_);
      registry_->calls_.erase(call_);
    }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    CallPrincipals* const registry_;
    const void* const call_;
  };

  // The caller of `call`; the anonymous admin (--auth none) when unknown.
  Principal Of(const void* call) {
    std::lock_guard lock(mu_);
    auto it = calls_.find(call);
    return it == calls_.end() ? Principal{} : it->second;
  }

 private:
  std::mutex mu_;
  std::map<const void*, Principal> calls_ ABSL_GUARDED_BY(mu_);
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_AUTH_CALL_PRINCIPALS_H_
