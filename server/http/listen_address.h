// HOST:PORT as --http-listen takes it.
#ifndef IMPOSTOR_SERVER_HTTP_LISTEN_ADDRESS_H_
#define IMPOSTOR_SERVER_HTTP_LISTEN_ADDRESS_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace impostor {

struct ListenAddress {
  std::string host;  // name or address, IPv6 without brackets
  int port = 0;      // 0..65535; 0 = the kernel picks one
};

// Parses "HOST:PORT" ("[::1]:8080" for IPv6). INVALID_ARGUMENT naming
// `flag` and what is wrong (no port, a port that is not 0..65535, an empty
// host).
absl::StatusOr<ListenAddress> ParseListenAddress(std::string_view text, std::string_view flag);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_HTTP_LISTEN_ADDRESS_H_
