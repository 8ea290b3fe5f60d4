#include "server/rpc/submit_tags.h"

#include <algorithm>
#include <iterator>

#include "absl/strings/str_cat.h"
#include "common/request/worker_fit.h"

namespace impostor {

absl::StatusOr<std::vector<std::string>> WithTokenRequiredTags(const std::vector<std::string>& request_tags,
                                                               const Principal& caller) {
  if (caller.required_tags.empty()) return request_tags;
  std::vector<std::string> mine = request_tags;
  std::vector<std::string> token = caller.required_tags;
  std::sort(mine.begin(), mine.end());
  std::sort(token.begin(), token.end());
  std::vector<std::string> out;
  std::set_union(mine.begin(), mine.end(), token.begin(), token.end(), std::back_inserter(out));
  out.erase(std::unique(out.begin(), out.end()), out.end());
  if (static_cast<int>(out.size()) > kMaxWorkerTags) {
    return absl::InvalidArgumentError(absl::StrCat(
        "required_tags: the request's ", request_tags.size(), " and token '", caller.name, "''s ",
        caller.required_tags.size(), " default tags make ", out.size(), ", over the limit of ", kMaxWorkerTags));
  }
  return out;
}

}  // namespace impostor
