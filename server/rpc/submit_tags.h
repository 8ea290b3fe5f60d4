// The worker tags a submitted bake requires (issue 44): the request's own
// required_tags plus the default tags of the token that submits it
// (`impostor-server token create --require-tag`). Merged here, at the RPC
// edge, so that the scheduler sees one list of tags and nothing of tokens.
#ifndef IMPOSTOR_SERVER_RPC_SUBMIT_TAGS_H_
#define IMPOSTOR_SERVER_RPC_SUBMIT_TAGS_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/auth/authenticator.h"

namespace impostor {

// The union of `request_tags` (NormalizeSubmit's) and `caller`'s
// required_tags, sorted without repeats. INVALID_ARGUMENT naming
// required_tags, both counts, the token and the limit when the union has more
// than kMaxWorkerTags (each list alone is within it).
absl::StatusOr<std::vector<std::string>> WithTokenRequiredTags(const std::vector<std::string>& request_tags,
                                                               const Principal& caller);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_RPC_SUBMIT_TAGS_H_
