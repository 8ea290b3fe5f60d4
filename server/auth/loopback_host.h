// Whether a listener's host is reachable only from this machine: what
// decides the default --auth and the plaintext warning.
#ifndef IMPOSTOR_SERVER_AUTH_LOOPBACK_HOST_H_
#define IMPOSTOR_SERVER_AUTH_LOOPBACK_HOST_H_

#include <string_view>

namespace impostor {

// True for "localhost", 127.0.0.0/8 (dotted digits only: "127.evil.lan" is a
// name), "::1" with or without brackets, and Unix sockets ("unix:...",
// "unix-abstract:...").
bool IsLoopbackHost(std::string_view host);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_AUTH_LOOPBACK_HOST_H_
