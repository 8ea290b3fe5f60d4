#include "server/http/http_authorize.h"

#include <string_view>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace impostor {
namespace {

bool IsOpenPath(std::string_view path) { return path == "/healthz" || path == "/readyz" || path == "/login"; }

// A dashboard page a person opens in a browser (not the API, not /metrics,
// not the page's own scripts): refused requests go to the login form.
bool IsBrowserPage(const HttpRequestInfo& request) {
  const std::string_view p = request.path;
  return request.method == "GET" &&
         (p == "/" || p.starts_with("/jobs/") || p.starts_with("/results/"));
}

// "/api/v1/jobs/ID/mesh/..." -> ID; "" for any other path.
std::string MeshJobId(std::string_view path) {
  constexpr std::string_view kPrefix = "/api/v1/jobs/";
  if (!path.starts_with(kPrefix)) return "";
  path.remove_prefix(kPrefix.size());
  const size_t slash = path.find('/');
  if (slash == std::string_view::npos || !path.substr(slash).starts_with("/mesh/")) return "";
  return std::string(path.substr(0, slash));
}

// The header wins over the cookie, as a token file wins on the clients.
std::string AuthorizationOf(const HttpRequestInfo& request) {
  if (!request.authorization.empty()) return request.authorization;
  if (const std::string cookie = CookieValue(request.cookie, kTokenCookie); !cookie.empty()) {
    return "Bearer " + cookie;
  }
  return "";
}

HttpAuthorization Refuse(int status, std::string message, bool to_login = false) {
  return {.allowed = false, .status = status, .message = std::move(message), .to_login = to_login};
}

}  // namespace

std::string CookieValue(const std::string& cookie_header, const std::string& name) {
  for (absl::string_view part : absl::StrSplit(cookie_header, ';')) {
    part = absl::StripAsciiWhitespace(part);
    if (absl::ConsumePrefix(&part, name) && absl::ConsumePrefix(&part, "=")) return std::string(part);
  }
  return "";
}

HttpAuthorization AuthorizeRequest(const HttpRequestInfo& request, Authenticator* authenticator,
                                   BakeScheduler* scheduler) {
  if (authenticator == nullptr || IsOpenPath(request.path)) return {};
  const std::string authorization = AuthorizationOf(request);
  auto principal = authenticator->Authenticate(authorization.empty() ? nullptr : &authorization);
  if (!principal.ok()) {
    // The token store not answering says nothing about the token: 503, as
    // /readyz says, not 401 (which tells the caller its token is bad).
    if (absl::IsUnavailable(principal.status())) return Refuse(503, std::string(principal.status().message()));
    return Refuse(401, std::string(principal.status().message()), IsBrowserPage(request));
  }
  if (principal->role == Role::kWorker) {
    return Refuse(403, absl::StrCat("token \"", principal->name,
                                    "\" has role worker; the dashboard, the JSON API and /metrics need a reader, "
                                    "submitter or admin token"));
  }
  if (const std::string job_id = MeshJobId(request.path); !job_id.empty() && principal->role != Role::kAdmin) {
    auto owner = scheduler->JobOwner(job_id);
    if (owner.ok() && *owner != principal->name) {
      return Refuse(403, absl::StrCat("a job's mesh files: only the token that submitted the job or an admin may "
                                      "read them (this is token \"",
                                      principal->name, "\", role ", std::string(RoleName(principal->role)), ")"));
    }
    // NOT_FOUND and the like: the route answers them.
  }
  return {};
}

JobViewer ViewerOf(const HttpRequestInfo& request, Authenticator* authenticator) {
  if (authenticator == nullptr) return {.name = "", .admin = true};
  const std::string authorization = AuthorizationOf(request);
  auto principal = authenticator->Authenticate(authorization.empty() ? nullptr : &authorization);
  if (!principal.ok()) return {};
  return {.name = principal->name, .admin = principal->role == Role::kAdmin};
}

}  // namespace impostor
