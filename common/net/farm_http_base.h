// The base URL of a farm's HTTP front end (/api/v1/results/KEY/manifest and
// /api/v1/results/KEY/files/NAME under it), as a client is given it (ClientOptions::farm_http,
// client/transport/farm_http_url.h) or as the farm advertises it
// (impostor-server --http-advertise, sent with each GetResult answer under
// kFarmHttpMetadataKey). One check for both ends.
#ifndef IMPOSTOR_COMMON_NET_FARM_HTTP_BASE_H_
#define IMPOSTOR_COMMON_NET_FARM_HTTP_BASE_H_

#include <cstddef>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace impostor {

// The longest base URL accepted.
inline constexpr size_t kMaxFarmHttpUrlBytes = 2048;

// The GetResult answer's initial metadata naming the farm's HTTP front end
// (a base URL, as --http-advertise gave it).
inline constexpr char kFarmHttpMetadataKey[] = "impostor-farm-http";

// The media type of BASE/api/v1/results/KEY/manifest: an impostor.v1.Manifest
// in protobuf's binary form, as gRPC's GetResult answers it.
inline constexpr char kResultManifestMediaType[] = "application/x-protobuf";

// The most bytes of such a manifest a client reads (a result lists a few
// dozen files: a few KB).
inline constexpr size_t kMaxResultManifestBytes = size_t{4} << 20;

// The Repr-Digest header (RFC 9530) the listing is sent with, and its value
// for `body`: "sha-256=:BASE64:". The client checks the listing against it,
// so a proxy's truncated or altered body is refused rather than read as a
// result with fewer files.
inline constexpr char kReprDigestHeader[] = "Repr-Digest";
std::string ReprDigestSha256(std::string_view body);

// The sha-256 member of a Repr-Digest value, whole ("sha-256=:BASE64:", as
// ReprDigestSha256 writes it), maybe among other members separated by
// commas; "" when it has none.
std::string_view ReprDigestSha256Member(std::string_view header);

// INVALID_ARGUMENT unless `url` is an http:// or https:// URL with a host,
// at most kMaxFarmHttpUrlBytes of printable ASCII, without a query, a
// fragment or credentials; with `tls` (the farm's gRPC is TLS) only
// https:// is accepted, as a bearer token would cross the network in clear.
// The message names the limit or the part that is wrong, not the field.
absl::Status ValidateFarmHttpBase(absl::string_view url, bool tls);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_NET_FARM_HTTP_BASE_H_
