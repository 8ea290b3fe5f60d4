#include "server/http/login_page.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "server/http/http_authorize.h"

namespace impostor {
namespace {

std::string EscapeHtml(const std::string& text) {
  return absl::StrReplaceAll(text, {{"&", "&amp;"}, {"<", "&lt;"}, {">", "&gt;"}, {"\"", "&quot;"}, {"'", "&#39;"}});
}

}  // namespace

std::string LoginPageHtml(const std::string& error) {
  return absl::StrCat(
      "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>Impostor farm: sign in</title>"
      "<link rel=\"stylesheet\" href=\"/static/style.css\"></head><body><main>"
      "<h1>Impostor bake farm</h1>"
      "<p>This farm needs a token. Ask its admin for a <b>reader</b> token "
      "(<code>impostor-server token create --role reader --name YOU</code>) and paste it here.</p>",
      error.empty() ? "" : absl::StrCat("<p class=\"error\" id=\"login-error\">", EscapeHtml(error), "</p>"),
      "<form method=\"post\" action=\"/login\">"
      "<input type=\"password\" name=\"token\" autocomplete=\"off\" size=\"60\" placeholder=\"imp_...\" required>"
      " <button type=\"submit\">Sign in</button></form></main></body></html>\n");
}

std::string TokenCookieHeader(const std::string& token) {
  return absl::StrCat(kTokenCookie, "=", token, "; Path=/; Max-Age=2592000; HttpOnly; SameSite=Strict");
}

}  // namespace impostor
