// A game's view of one release channel: the catalog the channel names, read
// from the first mirror that answers, verified (digest, and signature when a
// public key is configured), kept on disk, and refreshed by ETag. With every
// mirror gone, the last good catalog on disk still resolves names: a game
// that ever fetched the channel keeps working offline.
//
// On disk, under `state_dir` (the result cache's releases/ folder):
//   channels/<channel>.json      the last good channel file, as served
//   catalogs/<64 hex>            catalogs it named, as served
// both written by atomic rename, so a crash leaves the previous pair.
//
// Thread-safety: every method may be called from any thread; concurrent
// refreshes share one (the others wait for it).
#ifndef IMPOSTOR_CLIENT_DELIVERY_CHANNEL_CATALOG_H_
#define IMPOSTOR_CLIENT_DELIVERY_CHANNEL_CATALOG_H_

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "client/delivery/catalog.h"
#include "client/delivery/catalog_signature.h"
#include "client/transport/retry.h"

namespace impostor::delivery {

struct ChannelCatalogOptions {
  std::vector<std::string> mirrors;  // base URLs, in the order tried
  std::string channel;
  std::filesystem::path state_dir;
  // Set: only catalogs signed by this key are accepted.
  std::optional<CatalogPublicKey> public_key;
  // A catalog younger than this is used without asking a mirror.
  double refresh_seconds = 60;
  double stall_seconds = 30;
  int max_attempts = 3;
  std::string ca_file;
  const sdk::CancelSource* cancel = nullptr;
};

// What Current() answers.
struct ResolvedCatalog {
  std::shared_ptr<const Catalog> catalog;
  std::string catalog_sha256;
  // True when no mirror answered and this is the catalog kept on disk.
  bool offline = false;
};

class ChannelCatalog {
 public:
  // Loads the last good catalog from disk if there is one; contacts no
  // mirror. INVALID_ARGUMENT for a bad channel name or mirror URL.
  static absl::StatusOr<std::unique_ptr<ChannelCatalog>> Open(ChannelCatalogOptions options);

  // The channel's catalog: the one in memory while younger than
  // refresh_seconds, else asked of the mirrors in order (If-None-Match; a
  // 304 keeps the current one). When no mirror answers, the last good one
  // (offline = true), and the mirrors are asked again only after
  // refresh_seconds. Errors: UNAVAILABLE naming every mirror's failure when
  // there is none to fall back to; PERMISSION_DENIED for a catalog whose
  // signature fails (the previous one stays in use only if the refresh
  // fails that way on every mirror); NOT_FOUND when every mirror answers
  // 404 for the channel file.
  absl::StatusOr<ResolvedCatalog> Current(bool force_refresh = false);

  const ChannelCatalogOptions& options() const { return options_; }

 private:
  explicit ChannelCatalog(ChannelCatalogOptions options);
  // The channel and catalog from one mirror; nullopt result = 304.
  struct Fetched {
    std::string channel_text;
    std::string catalog_text;
    ChannelPointer pointer;
    std::shared_ptr<const Catalog> catalog;
    std::string etag;
  };
  absl::StatusOr<std::optional<Fetched>> FetchFrom(const std::string& mirror, const std::string& etag)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  // The catalog `text` for `pointer`: its digest (unless `digest_checked`:
  // ReadVerifiedToString hashed it as it came), its signature, its parse.
  absl::StatusOr<std::shared_ptr<const Catalog>> CheckCatalog(const ChannelPointer& pointer, const std::string& text,
                                                              const std::string& source,
                                                              bool digest_checked = false) const;
  void LoadFromDisk() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);
  void SaveToDisk(const Fetched& fetched) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_);

  const ChannelCatalogOptions options_;
  std::mutex mu_;  // held through a refresh: concurrent callers share it
  std::shared_ptr<const Catalog> current_ ABSL_GUARDED_BY(mu_);
  std::string current_sha256_ ABSL_GUARDED_BY(mu_);
  std::optional<std::chrono::steady_clock::time_point> checked_at_ ABSL_GUARDED_BY(mu_);
  std::map<std::string, std::string> etags_ ABSL_GUARDED_BY(mu_);  // by mirror
  bool warned_offline_ ABSL_GUARDED_BY(mu_) = false;
  bool offline_ ABSL_GUARDED_BY(mu_) = false;  // the last refresh found no mirror
};

}  // namespace impostor::delivery

#endif  // IMPOSTOR_CLIENT_DELIVERY_CHANNEL_CATALOG_H_
