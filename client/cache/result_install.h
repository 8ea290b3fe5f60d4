// Downloads a baked result into the cache and installs it atomically: every
// blob is fetched into its partial file (resumable), verified and
// hard-linked into a fresh staging directory (under the partial's lock; see
// partial_download.h), the `.entry` record written and pinned, everything
// synced, and the directory renamed to entries/<key> in one step. A reader
// therefore sees either no entry or a complete one, never a partial result,
// and no evictor can take the entry between its rename and the caller's
// pin. Runs on the caller's thread; safe to call concurrently (also from
// several processes) for any keys: when another install of the key wins,
// its entry is used, and the partial files of a result are deleted by the
// last install to use them.
#ifndef IMPOSTOR_CLIENT_CACHE_RESULT_INSTALL_H_
#define IMPOSTOR_CLIENT_CACHE_RESULT_INSTALL_H_

#include <atomic>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "client/cache/cache_layout.h"
#include "client/cache/entry_lock.h"
#include "client/cache/partial_download.h"
#include "client/transfer/farm_http_result_fetch.h"
#include "client/transport/transport.h"

namespace impostor::sdk {

struct InstallOutcome {
  EntryRecord record;
  // A shared lock on the installed entry's `.entry` (what EntryPin holds),
  // taken before the entry became visible (or, when another install won,
  // on theirs before its record was read).
  std::unique_ptr<EntryLock> pin;
  // What this call moved over the network, and the bytes of unfinished
  // partial files (interrupted downloads') it completed instead of fetching
  // them again; partials another download had finished count as neither.
  int64_t bytes_downloaded = 0;
  int64_t bytes_resumed = 0;
  // Another install (another process or Cache) of the key came first; its
  // copy is used.
  bool raced = false;
};

// One place a result's blobs can come from.
struct ResultSource {
  std::string name;  // for messages and logs: "server HOST:PORT", "mirror URL"
  BlobReader reader;
  // A release mirror, whose errors name URLs, not files: the install's
  // error then names the file and the digest.
  bool mirror = false;
};

// What to install and from where.
struct InstallPlan {
  // The result's listing: `maps` and `manifest_json` digests, cache key,
  // layout, frames, resolution (the farm's GetResult, or a release
  // catalog's entry: delivery::ManifestFromAsset).
  v1::Manifest listing;
  std::string listing_source;  // who gave the listing, for messages
  // Tried in order for each blob: a source that fails (unreachable,
  // stalled, missing the blob, or serving bytes that do not verify) moves
  // the blob on to the next, resuming from the verified bytes on disk (a
  // source's bad bytes are dropped first). Never empty.
  std::vector<ResultSource> sources;
};

// Downloads the plan's blobs, verifies and installs them. Errors as
// DownloadAndInstall; when every source failed for a blob, the message
// names the file, its digest and each source's failure, with the last
// source's code.
absl::StatusOr<InstallOutcome> InstallFromSources(const InstallPlan& plan, const CacheLayout& layout,
                                                  const std::string& key, const DownloadHooks& hooks,
                                                  const CancelSource* cancel);

// GetResult, download, verify, install. Errors: NOT_FOUND (nothing baked
// under the key), DATA_LOSS (bytes or manifest that do not match), INTERNAL
// (a malformed manifest, local disk), RESOURCE_EXHAUSTED (the cache's disk
// or quota is full: the message names the path and the free space, and no
// partial or staged file of this result is left), CANCELLED, or an RPC's
// error.
absl::StatusOr<InstallOutcome> DownloadAndInstall(Transport& transport, const CacheLayout& layout,
                                                  const std::string& key, const DownloadHooks& hooks,
                                                  const CancelSource* cancel);

// The plan for a result whose listing came from the farm's HTTP front end
// (GetResultOverHttp, already checked): every file from the front end, one
// request each, and for a blob it cannot give intact `farm` (named
// `farm_name`: the farm over gRPC, which the caller connects only when it
// is asked), resuming from the front end's verified bytes.
InstallPlan FarmHttpInstallPlan(const FarmHttpEndpoint& front_end, v1::Manifest listing, BlobReader farm,
                                std::string farm_name);

// The listing from the front end (GetResultOverHttp) and the install of
// FarmHttpInstallPlan: a result installed with no gRPC channel opened when
// the front end gives it all. nullopt when the front end could not give the
// listing (one warning says why, but for a NOT_FOUND: the farm over gRPC
// says whether the result is there), for the caller to go to the farm.
std::optional<absl::StatusOr<InstallOutcome>> InstallOverFarmHttp(const FarmHttpEndpoint& front_end, BlobReader farm,
                                                                  std::string farm_name, const CacheLayout& layout,
                                                                  const std::string& key, const DownloadHooks& hooks,
                                                                  const CancelSource* cancel);

// Deletes the staging directory `dir` (an install's, see cache_layout.md)
// unless an install is using it (its lock is held) or it is younger than
// `min_age_seconds`. True when deleted.
bool RemoveStagingIfUnused(const std::filesystem::path& dir, double min_age_seconds);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_CACHE_RESULT_INSTALL_H_
