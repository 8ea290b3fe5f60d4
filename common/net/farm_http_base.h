// The base URL of a farm's HTTP front end (/api/v1/results/KEY/files/NAME
// under it), as a client is given it (ClientOptions::farm_http,
// client/transport/farm_http_url.h) or as the farm advertises it
// (impostor-server --http-advertise, sent with each GetResult answer under
// kFarmHttpMetadataKey). One check for both ends.
#ifndef IMPOSTOR_COMMON_NET_FARM_HTTP_BASE_H_
#define IMPOSTOR_COMMON_NET_FARM_HTTP_BASE_H_

#include <cstddef>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace impostor {

// The longest base URL accepted.
inline constexpr size_t kMaxFarmHttpUrlBytes = 2048;

// The GetResult answer's initial metadata naming the farm's HTTP front end
// (a base URL, as --http-advertise gave it).
inline constexpr char kFarmHttpMetadataKey[] = "impostor-farm-http";

// INVALID_ARGUMENT unless `url` is an http:// or https:// URL with a host,
// at most kMaxFarmHttpUrlBytes of printable ASCII, without a query, a
// fragment or credentials; with `tls` (the farm's gRPC is TLS) only
// https:// is accepted, as a bearer token would cross the network in clear.
// The message names the limit or the part that is wrong, not the field.
absl::Status ValidateFarmHttpBase(absl::string_view url, bool tls);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_FARM_HTTP_BASE_H_
