// The address list of a farm served by several head-node replicas, as the
// `--server` flag, ClientOptions::server and CacheOptions::server take it:
// "host1:50051,host2:50051". Each entry is a gRPC target that a client
// dials on its own channel (see failover_channel.h); a single entry may
// itself be a DNS name with several A/AAAA records, which gRPC's pick_first
// policy tries in order within that entry's channel.
//
// Accepted entries:
//   HOST:PORT            host name or IPv4 literal, PORT 1..65535
//   [IPV6]:PORT          IPv6 literal
//   dns:///HOST:PORT     (or dns://AUTHORITY/HOST:PORT) gRPC's DNS target
//   unix:PATH, unix-abstract:NAME
// A whole string starting with "ipv4:" or "ipv6:" is gRPC's own comma list
// (one channel, pick_first over the addresses) and is passed through as one
// target.
//
// Pure functions; thread-safe.
#ifndef IMPOSTOR_COMMON_NET_SERVER_LIST_H_
#define IMPOSTOR_COMMON_NET_SERVER_LIST_H_

#include <string>
#include "absl/strings/string_view.h"
#include <vector>

#include "absl/status/statusor.h"

namespace impostor {

// The most addresses one list may name.
inline constexpr size_t kMaxServerAddresses = 16;

// The gRPC targets of `list`, in order. INVALID_ARGUMENT naming `field`
// (e.g. "--server" or "ClientOptions.server") and the entry at fault for an
// empty list or entry, an entry without a port or with a port outside
// 1..65535, white space or a character a host name cannot hold, an unknown
// scheme, the same address twice, or more than kMaxServerAddresses entries.
absl::StatusOr<std::vector<std::string>> ParseServerList(absl::string_view list, absl::string_view field);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_SERVER_LIST_H_
