// The one place where an HTTP request is allowed or refused, before any
// route runs. With --auth none (loopback only) everything is allowed, as on
// the gRPC side. With --auth token every page, API call and /metrics needs a
// reader, submitter or admin token, from the Authorization header
// ("Bearer <token>", what Prometheus' `authorization.credentials_file`
// sends) or from the `impostor_token` cookie that /login sets for a browser;
// only /healthz, /readyz and /login stay open (load balancers, the login
// form). A job's uploaded mesh (/api/v1/jobs/ID/mesh/...) is a studio's
// unreleased asset: only its submitter or an admin may read it, as with
// ReadBlob of inputs over gRPC.
#ifndef IMPOSTOR_SERVER_HTTP_HTTP_AUTHORIZE_H_
#define IMPOSTOR_SERVER_HTTP_HTTP_AUTHORIZE_H_

#include <string>

#include "server/auth/authenticator.h"
#include "server/scheduler/bake_scheduler.h"

namespace impostor {

struct HttpRequestInfo {
  std::string method;         // "GET"
  std::string path;           // "/api/v1/jobs"
  std::string authorization;  // the Authorization header, "" when absent
  std::string cookie;         // the Cookie header, "" when absent
};

struct HttpAuthorization {
  bool allowed = true;
  int status = 200;      // 401 or 403 when refused; 503 when tokens cannot be checked
  std::string message;   // why, when refused (never the secret)
  bool to_login = false;  // a browser page: send it to /login instead
};

// Who may see a job's input digests (the mesh's files' hashes). A digest is
// all it takes to name a blob in a SubmitBake and read it back through one's
// own job, so only the submitting token and admins see them; `name` empty
// and `admin` true with --auth none.
struct JobViewer {
  std::string name;
  bool admin = false;
  bool MaySeeInputsOf(const BakeScheduler::JobListing& listing) const {
    return admin || (!name.empty() && name == listing.owner);
  }
};

// The viewer of an allowed request: its token's name and role (admin with
// --auth none, where every listener is on loopback).
JobViewer ViewerOf(const HttpRequestInfo& request, Authenticator* authenticator);

// The cookie /login sets and AuthorizeRequest reads.
inline constexpr char kTokenCookie[] = "impostor_token";

// `authenticator` null = --auth none. `scheduler` answers who owns a job.
HttpAuthorization AuthorizeRequest(const HttpRequestInfo& request, Authenticator* authenticator,
                                   BakeScheduler* scheduler);

// The value of cookie `name` in a Cookie header, "" when absent.
std::string CookieValue(const std::string& cookie_header, const std::string& name);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_HTTP_AUTHORIZE_H_
