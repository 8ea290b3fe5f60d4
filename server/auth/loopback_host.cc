#include "server/auth/loopback_host.h"

namespace impostor {

bool IsLoopbackHost(std::string_view host) {
  if (host.substr(0, 5) == "unix:" || host.substr(0, 14) == "unix-abstract:") return true;
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  if (host == "localhost" || host == "::1") return true;
  if (host.substr(0, 4) != "127.") return false;
  for (char c : host) {
    if (!(c == '.' || (c >= '0' && c <= '9'))) return false;
  }
  return true;
}

}  // namespace impostor
