// Opening a Cache with observers, for tests and benchmarks: count the RPCs
// that reach the wire, see where each blob download starts and how far it
// got (e.g. to stop the server midway). Not part of the public API.
#ifndef IMPOSTOR_CLIENT_CACHE_CACHE_TESTING_H_
#define IMPOSTOR_CLIENT_CACHE_CACHE_TESTING_H_

#include <memory>

#include "absl/status/statusor.h"
#include "client/cache/partial_download.h"
#include "client/transport/transport.h"
#include "impostor/cache.h"

namespace impostor::sdk {

struct CacheTestHooks {
  TransportHooks transport;
  DownloadHooks download;
};

class CacheFactory {
 public:
  // Cache::Open with `hooks` installed.
  static absl::StatusOr<std::unique_ptr<Cache>> Open(const CacheOptions& options, const CacheTestHooks& hooks);
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_CACHE_TESTING_H_
