// Query parameters of the JSON API (docs/http_api.md): parsed and checked
// here, so every handler refuses a bad value the same way, naming the
// parameter and its limits (HTTP 400).
#ifndef IMPOSTOR_SERVER_HTTP_API_PARAMS_H_
#define IMPOSTOR_SERVER_HTTP_API_PARAMS_H_

#include <map>
#include <optional>
#include <set>
#include <string>

#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "server/store/job_store.h"

namespace impostor {

inline constexpr int kDefaultPageSize = 50;
inline constexpr int kMaxPageSize = 500;

// Query parameters as decoded by the HTTP library (name -> value; a name
// given twice is refused by CheckKnownParams).
using QueryParams = std::multimap<std::string, std::string>;

// INVALID_ARGUMENT naming the first parameter not in `known`, or one given
// more than once.
absl::Status CheckKnownParams(const QueryParams& params, const std::set<std::string>& known);
// page_size: default kDefaultPageSize, 1..kMaxPageSize.
absl::StatusOr<int> ParsePageSize(const QueryParams& params);
// state: queued, running, succeeded, failed, cancelled or all (default all =
// JOB_STATE_UNSPECIFIED).
absl::StatusOr<v1::JobState> ParseStateFilter(const QueryParams& params);

// Page tokens: opaque to clients ("<created_ms>.<id>"), the last row of the
// previous page.
std::string JobPageToken(const JobStore::JobCursor& cursor);
absl::StatusOr<std::optional<JobStore::JobCursor>> ParseJobPageToken(const QueryParams& params);
std::string ResultPageToken(const JobStore::ResultCursor& cursor);
absl::StatusOr<std::optional<JobStore::ResultCursor>> ParseResultPageToken(const QueryParams& params);

// Lower-case state name as the API writes it ("queued"...).
std::string StateName(v1::JobState state);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_API_PARAMS_H_
