// The one place where an HTTP request is allowed or refused, before any
// route runs. Today everything is allowed: the farm has no identity yet.
// When token auth lands (--auth token), this checks the request's bearer
// token (Authorization header, or a cookie set by the dashboard's token
// prompt) for the reader role and refuses with 401 otherwise; every page,
// API call and /metrics goes through it (only /healthz and /readyz may stay
// open for load balancers).
#ifndef IMPOSTOR_SERVER_HTTP_HTTP_AUTHORIZE_H_
#define IMPOSTOR_SERVER_HTTP_HTTP_AUTHORIZE_H_

#include <string>

namespace impostor {

struct HttpRequestInfo {
  std::string method;         // "GET"
  std::string path;           // "/api/v1/jobs"
  std::string authorization;  // the Authorization header, "" when absent
};

struct HttpAuthorization {
  bool allowed = true;
  int status = 200;     // 401 or 403 when refused
  std::string message;  // why, when refused
};

HttpAuthorization AuthorizeRequest(const HttpRequestInfo& request);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_HTTP_AUTHORIZE_H_
