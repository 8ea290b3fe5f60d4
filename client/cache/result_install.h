// Downloads a baked result into the cache and installs it atomically: every
// blob is fetched into its partial file (resumable) and verified, hard-linked
// into a fresh staging directory with the `.entry` record, synced, and the
// directory renamed to entries/<key> in one step. A reader therefore sees
// either no entry or a complete one, never a partial result. Runs on the
// caller's thread; safe to call concurrently (also from several processes)
// for any keys.
#ifndef IMPOSTOR_CLIENT_CACHE_RESULT_INSTALL_H_
#define IMPOSTOR_CLIENT_CACHE_RESULT_INSTALL_H_

#include <atomic>
#include <string>

#include "absl/status/statusor.h"
#include "client/cache/cache_layout.h"
#include "client/cache/partial_download.h"
#include "client/transport.h"

namespace impostor::sdk {

struct InstallOutcome {
  EntryRecord record;
  int64_t bytes_downloaded = 0;
  int64_t bytes_resumed = 0;
  // Another process installed the same key first; its copy is used.
  bool raced = false;
};

// GetResult, download, verify, install. Errors: NOT_FOUND (nothing baked
// under the key), DATA_LOSS (bytes or manifest that do not match), INTERNAL
// (a malformed manifest, local disk), RESOURCE_EXHAUSTED (the cache's disk
// or quota is full: the message names the path and the free space, and no
// partial or staged file of this result is left), CANCELLED, or an RPC's
// error.
absl::StatusOr<InstallOutcome> DownloadAndInstall(Transport& transport, const CacheLayout& layout,
                                                  const std::string& key, const DownloadHooks& hooks,
                                                  const std::atomic<bool>* cancel);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_RESULT_INSTALL_H_
