// `impostor publish`: writes baked results as a release tree
// (release_format.md) that any static host or CDN serves as plain files.
// Blobs first, then the catalog, then the channel file by atomic rename, so
// an interrupted publish leaves the previous channel intact and every file
// it names in place. Incremental (a blob already at the destination, with
// the right bytes, is not written again) and idempotent (the same inputs
// give the same catalog digest: see PublishOptions::created_at_unix).
//
// Runs on the caller's thread; two publishes into one tree at once are safe
// for blobs and catalogs (atomic renames of content-addressed files), and
// the last channel rename wins.
#ifndef IMPOSTOR_CLIENT_DELIVERY_PUBLISHER_H_
#define IMPOSTOR_CLIENT_DELIVERY_PUBLISHER_H_

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/strings/string_view.h"
#include "absl/status/statusor.h"
#include "client/transport/transport.h"

namespace impostor::delivery {

// One asset to publish: `name` (ValidateAssetName) for the result under
// `cache_key`.
struct PublishEntry {
  std::string name;
  std::string cache_key;
  friend bool operator==(const PublishEntry&, const PublishEntry&) = default;
};

struct PublishOptions {
  std::filesystem::path out;  // the release root (holds v1/); created
  std::string channel;        // ValidateChannelName
  // The quality pass's view images, views.json, the worst view and the
  // contact sheet too (left out by default: they are for people).
  bool include_quality_views = false;
  // Ed25519 private key (PEM) to sign the catalog with; empty = unsigned.
  std::filesystem::path sign_key_file;
  // The catalog's created_at, Unix seconds. Unset: $SOURCE_DATE_EPOCH when
  // set, else now. A catalog whose assets equal those of the channel's
  // current one is not made again: that one is kept (same digest).
  std::optional<int64_t> created_at_unix;
};

struct PublishReport {
  std::string catalog_sha256;
  int64_t catalog_size_bytes = 0;
  bool catalog_reused = false;   // the channel's current catalog already held exactly these assets
  bool channel_changed = false;  // the channel file was rewritten
  int assets = 0;
  int blobs_written = 0;
  int blobs_present = 0;         // already at the destination, verified
  int64_t bytes_written = 0;
  std::string channel_path;      // relative to out
  std::string catalog_path;
};

// Parses the command line's inputs: each is a cache key (the asset is then
// named by its key) or NAME=KEY. INVALID_ARGUMENT naming the input.
absl::StatusOr<std::vector<PublishEntry>> EntriesFromArguments(const std::vector<std::string>& inputs);

// The assets of an `impostor bake-batch --json` report (JSON lines, or one
// JSON array of them): each "asset" line's `name` (else its model path's
// file name without extension) and `cache_key`. An asset that did not
// succeed is FAILED_PRECONDITION naming it: a release is never published
// without an asset its build asked for.
absl::StatusOr<std::vector<PublishEntry>> EntriesFromBatchReport(absl::string_view text, absl::string_view source);

// Writes the release. Errors: INVALID_ARGUMENT (a bad name or channel, one
// name given two keys, no entries), NOT_FOUND (a key the farm has no result
// for, naming the asset), the transport's errors, DATA_LOSS (the farm's
// bytes do not match their digests), INTERNAL / RESOURCE_EXHAUSTED (the
// destination, naming the path).
absl::StatusOr<PublishReport> Publish(sdk::Transport& transport, const std::vector<PublishEntry>& entries,
                                      const PublishOptions& options);

}  // namespace impostor::delivery

#endif  // IMPOSTOR_CLIENT_DELIVERY_PUBLISHER_H_
