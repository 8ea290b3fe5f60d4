// Which role may call which RPC: the whole authorisation matrix in one table
// (access_policy.cc), readable and testable in one place.
//
// A rule names the roles allowed to call a method, whether the call changes
// state (it gets an audit line), and which per-object check follows for
// roles other than admin:
//  - kOwnJob: the job must have been submitted by the caller's token
//    (WatchJob, GetJob, CancelJob for submitters);
//  - kReadableBlob: readers and submitters may read result blobs only; a
//    worker may read the input blobs of the job it holds (ReadBlob);
//  - kOwnLease: a worker may report on a job only while its own token
//    holds the lease (a lease id seen by one worker token is no key for
//    another; the result's baked_by names the token that took the lease).
// Methods absent from the table are admin-only.
#ifndef IMPOSTOR_SERVER_AUTH_ACCESS_POLICY_H_
#define IMPOSTOR_SERVER_AUTH_ACCESS_POLICY_H_

#include <cstdint>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "server/auth/authenticator.h"

namespace impostor {

enum class ObjectCheck { kNone, kOwnJob, kReadableBlob, kOwnLease };

struct MethodRule {
  std::string_view method;  // full name, e.g. "/impostor.v1.AssetService/ReadBlob"
  std::vector<Role> roles;  // besides admin, who is always allowed
  ObjectCheck check = ObjectCheck::kNone;
  bool changes_state = false;
};

// Every rule; the table the role x RPC tests walk.
const std::vector<MethodRule>& AccessRules();
// The rule for `method`, or nullptr (admin only).
const MethodRule* FindRule(std::string_view method);

// OK when `principal`'s role may call `method` (before per-object checks);
// PERMISSION_DENIED naming the method and the roles it needs otherwise.
absl::Status AuthorizeMethod(const Principal& principal, std::string_view method);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_AUTH_ACCESS_POLICY_H_
