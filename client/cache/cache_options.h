// CacheOptions checked (Cache::Open refuses what this refuses) and turned
// into the ClientOptions of the cache's connection to the farm. Pure
// functions; thread-safe.
#ifndef IMPOSTOR_CLIENT_CACHE_CACHE_OPTIONS_H_
#define IMPOSTOR_CLIENT_CACHE_CACHE_OPTIONS_H_

#include <optional>

#include "absl/status/status.h"
#include "client/transfer/farm_http_result_fetch.h"
#include "impostor/cache.h"
#include "impostor/client.h"

namespace impostor::sdk {

// OK, or INVALID_ARGUMENT naming the field ("CacheOptions.mirrors[0]: ...").
absl::Status ValidateOptions(const CacheOptions& o);

// The farm connection's settings (server, deadlines, TLS, token).
ClientOptions TransportOptions(const CacheOptions& o);

// The farm's HTTP front end the options name (farm_http or
// $IMPOSTOR_FARM_HTTP, with a farm server), for installs over HTTP alone
// (result_install.h); nullopt for none, and for bad options, which the
// farm's transport refuses when it connects.
std::optional<FarmHttpEndpoint> FarmHttpOf(const CacheOptions& o);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_CACHE_OPTIONS_H_
