#include "server/http/api_params.h"

#include <algorithm>
#include <cctype>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "common/util/sha256.h"
#include "common/util/utf8.h"

namespace impostor {
namespace {

std::string Quoted(const std::string& value) {
  std::string shown = ValidUtf8(Utf8Prefix(value, 80));
  for (char& c : shown) {
    if (static_cast<unsigned char>(c) < 0x20 || c == '"' || c == '\\') c = '?';
  }
  return absl::StrCat("\"", shown, value.size() > 80 ? "...\"" : "\"");
}

const std::string* Single(const QueryParams& params, const std::string& name) {
  auto it = params.find(name);
  return it == params.end() ? nullptr : &it->second;
}

// "<created_ms>.<rest>" with rest checked by `valid_rest`.
bool SplitToken(const std::string& token, int64_t* created_ms, std::string* rest) {
  const size_t dot = token.find('.');
  if (dot == std::string::npos || dot == 0) return false;
  if (!absl::SimpleAtoi(token.substr(0, dot), created_ms) || *created_ms < 0) return false;
  *rest = token.substr(dot + 1);
  return !rest->empty();
}

}  // namespace

absl::Status CheckKnownParams(const QueryParams& params, const std::set<std::string>& known) {
  for (auto it = params.begin(); it != params.end(); ++it) {
    if (!known.count(it->first)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      return absl::InvalidArgumentError(absl::StrCat(Quoted(it->first), ": unknown query parameter",
                                                     known.empty() ? "; this path takes none"
                                                                   : absl::StrCat("; expected one of ", list)));
    }
    if (params.count(it->first) > 1) {
      return absl::InvalidArgumentError(absl::StrCat(it->first, ": given more than once"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<int> ParsePageSize(const QueryParams& params) {
  const std::string* v = Single(params, "page_size");
  if (v == nullptr) return kDefaultPageSize;
  int n = 0;
  if (!absl::SimpleAtoi(*v, &n) || n < 1 || n > kMaxPageSize) {
    return absl::InvalidArgumentError(
        absl::StrCat("page_size: ", Quoted(*v), " is not a whole number in 1..", kMaxPageSize));
  }
  return n;
}

std::string StateName(v1::JobState state) {
  std::string name = v1::JobState_Name(state);
  if (name.rfind("JOB_STATE_", 0) == 0) name = name.substr(10);
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  return name;
}

absl::StatusOr<v1::JobState> ParseStateFilter(const QueryParams& params) {
  const std::string* v = Single(params, "state");
  if (v == nullptr || *v == "all") return v1::JOB_STATE_UNSPECIFIED;
  for (int s = v1::JOB_STATE_QUEUED; s <= v1::JOB_STATE_CANCELLED; ++s) {
    if (v1::JobState_IsValid(s) && StateName(static_cast<v1::JobState>(s)) == *v) return static_cast<v1::JobState>(s);
  }
  return absl::InvalidArgumentError(
      absl::StrCat("state: ", Quoted(*v), " is not one of queued, running, succeeded, failed, cancelled, all"));
}

std::string JobPageToken(const JobStore::JobCursor& cursor) { return absl::StrCat(cursor.created_ms, ".", cursor.job_id); }

absl::StatusOr<std::optional<JobStore::JobCursor>> ParseJobPageToken(const QueryParams& params) {
  const std::string* v = Single(params, "page_token");
  if (v == nullptr || v->empty()) return std::optional<JobStore::JobCursor>();
  JobStore::JobCursor c;
  if (!SplitToken(*v, &c.created_ms, &c.job_id) || c.job_id.size() > 128) {
    return absl::InvalidArgumentError(
        absl::StrCat("page_token: ", Quoted(*v), " is not a token this server gave (next_page_token)"));
  }
  return std::optional<JobStore::JobCursor>(c);
}

std::string ResultPageToken(const JobStore::ResultCursor& cursor) {
  return absl::StrCat(cursor.created_ms, ".", cursor.cache_key);
}

absl::StatusOr<std::optional<JobStore::ResultCursor>> ParseResultPageToken(const QueryParams& params) {
  const std::string* v = Single(params, "page_token");
  if (v == nullptr || v->empty()) return std::optional<JobStore::ResultCursor>();
  JobStore::ResultCursor c;
  if (!SplitToken(*v, &c.created_ms, &c.cache_key) || !IsSha256Hex(c.cache_key)) {
    return absl::InvalidArgumentError(
        absl::StrCat("page_token: ", Quoted(*v), " is not a token this server gave (next_page_token)"));
  }
  return std::optional<JobStore::ResultCursor>(c);
}

}  // namespace impostor
