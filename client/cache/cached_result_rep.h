// What a CachedResult handle holds: an immutable view of an installed entry
// shared by every handle to it, and the pin that keeps it from eviction.
// Internal to the cache.
#ifndef IMPOSTOR_CLIENT_CACHE_CACHED_RESULT_REP_H_
#define IMPOSTOR_CLIENT_CACHE_CACHED_RESULT_REP_H_

#include <memory>
#include <string>
#include <vector>

#include "client/cache/entry_lock.h"
#include "impostor/cache.h"

namespace impostor::sdk {

// An installed result as handed out; built once per entry and process.
struct EntryView {
  std::string key;
  std::filesystem::path dir;
  std::filesystem::path manifest_path;
  std::string manifest_json;
  std::vector<CachedFile> files;
  int64_t size_bytes = 0;
  std::string layout;
  uint32_t frames = 0;
  uint32_t resolution = 0;
  std::string product;  // ManifestSummary's
  uint32_t view_count = 0;
  bool texture_array = false;
};

// One per entry and process while any handle is alive: its shared file lock
// tells evictors in every process that the entry is in use; this process's
// cache sees the same through a weak_ptr to it.
struct EntryPin {
  std::unique_ptr<EntryLock> lock;
};

struct CachedResult::Rep {
  std::shared_ptr<const EntryView> view;
  std::shared_ptr<EntryPin> pin;
  bool downloaded = false;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_CACHED_RESULT_REP_H_
