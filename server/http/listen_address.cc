#include "server/http/listen_address.h"

#include "absl/strings/str_cat.h"

namespace impostor {

absl::StatusOr<ListenAddress> ParseListenAddress(std::string_view text, std::string_view flag) {
  auto bad = [&](std::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat(std::string(flag), ": \"", std::string(text.substr(0, 200)), "\" ", std::string(why)));
  };
  const size_t colon = text.rfind(':');
  if (colon == std::string_view::npos) return bad("has no port; expected HOST:PORT, e.g. 0.0.0.0:8080");
  std::string_view host = text.substr(0, colon);
  const std::string_view port = text.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (host.empty()) return bad("has no host; expected HOST:PORT, e.g. 0.0.0.0:8080");
  if (host.find_first_of(" /[]") != std::string_view::npos) return bad("has an invalid host");
  if (host.find(':') != std::string_view::npos && text.front() != '[') {
    return bad("has an IPv6 host without brackets; write [ADDRESS]:PORT");
  }
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string_view::npos) {
    return bad("has a port that is not a number in 0..65535");
  }
  const int value = std::stoi(std::string(port));
  if (value > 65535) return bad("has a port that is not a number in 0..65535");
  return ListenAddress{std::string(host), value};
}

}  // namespace impostor
