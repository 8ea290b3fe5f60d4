#include "common/net/server_list.h"

#include <algorithm>
#include <cctype>
#include <charconv>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace impostor {
namespace {

absl::Status Bad(absl::string_view field, absl::string_view entry, absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": \"", entry, "\" ", why));
}

// Checks ":PORT" at the end of a HOST:PORT entry (the text after the last
// colon, or after "]" for an IPv6 literal).
absl::Status CheckPort(absl::string_view field, absl::string_view entry, absl::string_view port) {
  int n = 0;
  const char* end = port.data() + port.size();
  auto [ptr, ec] = std::from_chars(port.data(), end, n);
  if (port.empty() || ec != std::errc() || ptr != end || n < 1 || n > 65535) {
    return Bad(field, entry, absl::StrCat("has no valid port (want HOST:PORT with PORT in 1..65535, e.g. ",
                                          "bake.studio.lan:50051)"));
  }
  return absl::OkStatus();
}

bool IsHostChar(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '_'; }

// HOST:PORT or [IPV6]:PORT.
absl::Status CheckHostPort(absl::string_view field, absl::string_view entry, absl::string_view host_port) {
  if (absl::StartsWith(host_port, "[")) {
    const size_t close = host_port.find(']');
    if (close == absl::string_view::npos || close == 1) return Bad(field, entry, "has an unclosed or empty [IPv6] host");
    for (char c : host_port.substr(1, close - 1)) {
      if (!std::isxdigit(static_cast<unsigned char>(c)) && c != ':' && c != '.') {
        return Bad(field, entry, "has a character an IPv6 address cannot hold");
      }
    }
    if (host_port.substr(close + 1, 1) != ":") return Bad(field, entry, "has no port after the [IPv6] host");
    return CheckPort(field, entry, host_port.substr(close + 2));
  }
  const size_t colon = host_port.rfind(':');
  if (colon == absl::string_view::npos) {
    return Bad(field, entry, absl::StrCat("has no port (want HOST:PORT, e.g. ", host_port, ":50051)"));
  }
  const absl::string_view host = host_port.substr(0, colon);
  if (host.empty()) return Bad(field, entry, "has no host (want HOST:PORT)");
  if (!std::all_of(host.begin(), host.end(), IsHostChar)) {
    return Bad(field, entry, "has a character a host name cannot hold (IPv6 literals go in brackets: [::1]:50051)");
  }
  return CheckPort(field, entry, host_port.substr(colon + 1));
}

// The scheme of "scheme:rest" when the text before the first colon is one
// (letters first, and not HOST:PORT, whose rest is all digits).
absl::string_view SchemeOf(absl::string_view entry) {
  const size_t colon = entry.find(':');
  if (colon == absl::string_view::npos || colon == 0) return {};
  const absl::string_view rest = entry.substr(colon + 1);
  if (!rest.empty() && std::all_of(rest.begin(), rest.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    return {};
  }
  const absl::string_view scheme = entry.substr(0, colon);
  if (!std::isalpha(static_cast<unsigned char>(scheme[0]))) return {};
  for (char c : scheme) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '+' && c != '-' && c != '.') return {};
  }
  return scheme;
}

absl::Status CheckEntry(absl::string_view field, absl::string_view entry) {
  const absl::string_view scheme = SchemeOf(entry);
  if (scheme.empty()) return CheckHostPort(field, entry, entry);
  const absl::string_view rest = entry.substr(scheme.size() + 1);
  if (scheme == "dns") {
    // dns:HOST:PORT, dns:///HOST:PORT or dns://AUTHORITY/HOST:PORT.
    absl::string_view name = rest;
    if (absl::StartsWith(name, "//")) {
      const size_t slash = name.find('/', 2);
      if (slash == absl::string_view::npos) return Bad(field, entry, "has no name after the DNS authority");
      name = name.substr(slash + 1);
    }
    return CheckHostPort(field, entry, name);
  }
  if (scheme == "unix" || scheme == "unix-abstract") {
    if (rest.empty() || rest == "//") return Bad(field, entry, "has no socket path");
    return absl::OkStatus();
  }
  if (scheme == "ipv4" || scheme == "ipv6") {
    return Bad(field, entry, "mixes gRPC's ipv4:/ipv6: list with other addresses; give one or the other");
  }
  // "bake.lan:http" is a bad port, not a scheme.
  if (!absl::StartsWith(rest, "/")) return CheckHostPort(field, entry, entry);
  return Bad(field, entry,
             absl::StrCat("has an unknown scheme \"", scheme,
                          "\" (want HOST:PORT, [IPV6]:PORT, dns:///HOST:PORT, unix:PATH; several separated by commas)"));
}

}  // namespace

absl::StatusOr<std::vector<std::string>> ParseServerList(absl::string_view list, absl::string_view field) {
  list = absl::StripAsciiWhitespace(list);
  if (list.empty()) return absl::InvalidArgumentError(absl::StrCat(field, ": required (HOST:PORT[,HOST:PORT...])"));
  // gRPC's own multi-address targets: one channel, gRPC checks them.
  if (absl::StartsWith(list, "ipv4:") || absl::StartsWith(list, "ipv6:")) return std::vector<std::string>{std::string(list)};
  std::vector<std::string> targets;
  int position = 0;
  for (absl::string_view entry : absl::StrSplit(list, ',')) {
    ++position;
    entry = absl::StripAsciiWhitespace(entry);
    if (entry.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": address ", position, " of \"", list, "\" is empty (want HOST:PORT,HOST:PORT)"));
    }
    if (std::any_of(entry.begin(), entry.end(), [](char c) { return std::isspace(static_cast<unsigned char>(c)) || std::iscntrl(static_cast<unsigned char>(c)); })) {
      return Bad(field, entry, "holds white space or a control character");
    }
    if (absl::Status s = CheckEntry(field, entry); !s.ok()) return s;
    if (std::find(targets.begin(), targets.end(), entry) != targets.end()) {
      return Bad(field, entry, "is listed twice");
    }
    targets.emplace_back(entry);
    if (targets.size() > kMaxServerAddresses) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": more than ", kMaxServerAddresses, " addresses in \"", list, "\""));
    }
  }
  return targets;
}

}  // namespace impostor
