// The dashboard's login form (/login), for a farm run with --auth token: a
// person pastes a reader (or submitter, admin) token once; the server checks
// it and keeps it in an HttpOnly, SameSite=Strict cookie, so the pages' own
// requests carry it and no script can read it.
#ifndef IMPOSTOR_SERVER_HTTP_LOGIN_PAGE_H_
#define IMPOSTOR_SERVER_HTTP_LOGIN_PAGE_H_

#include <string>

namespace impostor {

// The form, with `error` (HTML-escaped here) above it when not empty.
std::string LoginPageHtml(const std::string& error);

// Set-Cookie value that stores `token` for the whole dashboard (30 days).
std::string TokenCookieHeader(const std::string& token);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_LOGIN_PAGE_H_
