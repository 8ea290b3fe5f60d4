// Where a farm's HTTP front end is (ClientOptions::farm_http) and the URL of
// a result's file on it: the second road for a result's bytes beside gRPC
// (issue 45; client/transfer/farm_http_fetch.h uses it).
#ifndef IMPOSTOR_CLIENT_TRANSPORT_FARM_HTTP_URL_H_
#define IMPOSTOR_CLIENT_TRANSPORT_FARM_HTTP_URL_H_

#include <string>
#include "absl/strings/string_view.h"

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/net/farm_http_base.h"

namespace impostor::sdk {

// Read when ClientOptions::farm_http is empty.
inline constexpr char kFarmHttpEnvVar[] = "IMPOSTOR_FARM_HTTP";

// The front end to use: `configured` (the options' field, named `field` in
// errors), else `env` ($IMPOSTOR_FARM_HTTP; null or empty = not set), checked
// with ValidateFarmHttpBase (common/net/farm_http_base.h) and without a
// trailing "/"; "" when neither is given or the one given is "none".
// INVALID_ARGUMENT naming the field (or the variable) and what is wrong.
absl::StatusOr<std::string> ResolveFarmHttp(absl::string_view configured, absl::string_view field, const char* env,
                                            bool tls);

// True when the front end is turned off: `configured`, or `env` when
// `configured` is empty, is "none". Then a front end the farm advertises is
// not used either.
bool FarmHttpTurnedOff(absl::string_view configured, const char* env);

// The front end a farm advertises (the value of kFarmHttpMetadataKey on a
// GetResult answer: impostor-server --http-advertise), checked as a
// configured one (`tls`: the client's gRPC is TLS) and without a trailing
// "/"; INVALID_ARGUMENT saying why it cannot be used.
absl::StatusOr<std::string> AdvertisedFarmHttp(absl::string_view value, bool tls);

// BASE/api/v1/results/KEY/manifest: the result's listing (an
// impostor.v1.Manifest, kResultManifestMediaType).
std::string ResultManifestUrl(absl::string_view base, absl::string_view cache_key);

// BASE/api/v1/results/KEY/files/NAME, NAME percent-encoded but for
// RFC 3986's unreserved characters (a result's file names are plain names;
// CheckManifestFiles).
std::string ResultFileUrl(absl::string_view base, absl::string_view cache_key, absl::string_view file_name);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_FARM_HTTP_URL_H_
