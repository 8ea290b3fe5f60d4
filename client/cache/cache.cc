// Cache: the public facade. Wires the pieces together: the on-disk layout
// and index (cache_layout), LRU accounting (lru_index), pins (entry_lock),
// single-flight downloads (download_coordinator), atomic installs
// (result_install) and the lazily opened connection (lazy_transport).
#include "impostor/cache.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>
#include <system_error>
#include <unordered_map>
#include <unordered_set>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/cache/cache_layout.h"
#include "client/cache/cache_options.h"
#include "client/cache/cache_testing.h"
#include "client/cache/cached_result_rep.h"
#include "client/cache/download_coordinator.h"
#include "client/cache/entry_lock.h"
#include "client/cache/lazy_transport.h"
#include "client/cache/lru_index.h"
#include "client/cache/manifest_summary.h"
#include "client/cache/partial_download.h"
#include "client/cache/result_install.h"
#include "client/cache/work_queue.h"
#include "client/delivery/catalog.h"
#include "client/delivery/catalog_signature.h"
#include "client/delivery/channel_catalog.h"
#include "client/transfer/http_blob_read.h"
#include "client/delivery/release_paths.h"
#include "client/transfer/blob_download.h"
#include "client/transport/job_convert.h"
#include "client/transfer/mesh_files.h"
#include "client/transfer/mesh_upload.h"
#include "client/transfer/result_fetch.h"
#include "client/base/sdk_log.h"
#include "client/base/small_file.h"
#include "common/net/keepalive.h"
#include "common/net/server_list.h"
#include "common/net/tls_files.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

// Staging directories younger than this are kept even when unlocked: an
// install locks its directory right after creating it, and an older build
// of this library (which does not lock it) creates it only once every blob
// is on disk and renames it moments later. Older unlocked ones are
// leftovers of killed installs, holding links to the blobs they had.
constexpr double kStagingMaxAgeSeconds = 60;

int64_t NowUnixSeconds() {
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

absl::Status InvalidKey(const std::string& key) {
  return absl::InvalidArgumentError(
      absl::StrCat("cache key \"", key.substr(0, 80), "\": expected 64 lowercase hex characters",
                   " (asset names need CacheOptions.mirrors and channel)"));
}

}  // namespace

class Cache::Impl {
 public:
  Impl(const CacheOptions& options, const CacheTestHooks& hooks)
      : options_(options),
        layout_(options.dir),
        hooks_(hooks),
        transport_(TransportOptions(options), hooks.transport, options.offline_retry_seconds),
        farm_http_(FarmHttpOf(options)) {}

  ~Impl() {
    cancel_.Cancel();
    if (downloads_ != nullptr) downloads_->Shutdown();
    if (io_ != nullptr) io_->Drain();
  }

  absl::Status Start() {
    if (absl::Status s = layout_.Init(); !s.ok()) return s;
    LoadNewEntries();
    RemoveStaleFiles(options_.partial_max_age_seconds, nullptr);
    Trim(options_.max_bytes, nullptr);
    if (!options_.channel.empty()) {
      delivery::ChannelCatalogOptions c;
      c.mirrors = options_.mirrors;
      c.channel = options_.channel;
      c.state_dir = layout_.root() / "releases";
      if (!options_.catalog_public_key_file.empty()) {
        absl::StatusOr<delivery::CatalogPublicKey> key = delivery::LoadCatalogPublicKey(options_.catalog_public_key_file);
        if (!key.ok()) return key.status();
        c.public_key = *key;
      }
      c.refresh_seconds = options_.catalog_refresh_seconds;
      c.stall_seconds = options_.rpc_timeout_seconds;
      c.max_attempts = options_.max_attempts;
      c.ca_file = options_.mirror_ca_file;
      c.cancel = &cancel_;
      absl::StatusOr<std::unique_ptr<delivery::ChannelCatalog>> catalog = delivery::ChannelCatalog::Open(std::move(c));
      if (!catalog.ok()) return catalog.status();
      catalog_ = std::move(*catalog);
    }
    downloads_ = std::make_unique<DownloadCoordinator>(
        options_.max_parallel_downloads, options_.max_parallel_prefetches,
        [this](const std::string& key, CancelSource& cancel) { return Download(key, cancel); });
    io_ = std::make_unique<WorkQueue>(options_.io_threads);
    return absl::OkStatus();
  }

  const CacheOptions& options() const { return options_; }

  absl::StatusOr<CachedResult> Get(const std::string& name) {
    absl::StatusOr<std::string> resolved = Resolve(name);
    if (!resolved.ok()) return resolved.status();
    const std::string& key = *resolved;
    absl::StatusOr<std::optional<CachedResult>> local = TryLocal(key);
    if (!local.ok()) return local.status();
    if (local->has_value()) {
      Count(&CacheStats::hits);
      return **local;
    }
    Count(&CacheStats::misses);
    std::promise<absl::StatusOr<CachedResult>> promise;
    std::future<absl::StatusOr<CachedResult>> future = promise.get_future();
    downloads_->Join(key, /*urgent=*/true, [&promise](DownloadCoordinator::Result r) { promise.set_value(std::move(r)); });
    return future.get();
  }

  void GetAsync(const std::string& name, GetCallback done) {
    if (!IsCacheKey(name) && catalog_ == nullptr) {
      io_->Post([done = std::move(done), status = InvalidKey(name)] { done(status); });
      return;
    }
    io_->Post([this, name, done = std::move(done)]() mutable {
      // Resolved on an I/O thread: a name may need the channel's catalog.
      absl::StatusOr<std::string> resolved = Resolve(name);
      if (!resolved.ok()) return done(resolved.status());
      const std::string key = *resolved;
      absl::StatusOr<std::optional<CachedResult>> local = TryLocal(key);
      if (!local.ok()) return done(local.status());
      if (local->has_value()) {
        Count(&CacheStats::hits);
        return done(std::move(**local));
      }
      Count(&CacheStats::misses);
      downloads_->Join(key, /*urgent=*/true,
                       [done = std::move(done)](DownloadCoordinator::Result r) { done(std::move(r)); });
    });
  }

  // Prefetch of names (or keys) with a priority: names are resolved on an
  // I/O thread, then joined as background flights.
  void PrefetchNames(const std::vector<std::string>& names, int priority, const PrefetchCallback& done) {
    for (const std::string& name : names) {
      io_->Post([this, name, priority, done] {
        absl::StatusOr<std::string> key = Resolve(name);
        if (!key.ok()) {
          if (done) done(name, key.status());
          return;
        }
        {
          std::lock_guard lock(mu_);
          if (nodes_.contains(*key)) {
            if (done) done(name, absl::OkStatus());
            return;
          }
          prefetch_keys_[name] = *key;
        }
        downloads_->Join(*key, /*urgent=*/false, [this, done, name](DownloadCoordinator::Result r) {
          {
            std::lock_guard lock(mu_);
            prefetch_keys_.erase(name);
          }
          if (done) done(name, r.status());
        }, priority);
      });
    }
  }

  int CancelPrefetch(const std::vector<std::string>& names) {
    int cancelled = 0;
    for (const std::string& name : names) {
      std::string key = name;
      {
        std::lock_guard lock(mu_);
        if (auto it = prefetch_keys_.find(name); it != prefetch_keys_.end()) key = it->second;
      }
      if (downloads_->Cancel(key)) ++cancelled;
    }
    return cancelled;
  }

  absl::StatusOr<std::string> CatalogJson(bool force_refresh) {
    if (catalog_ == nullptr) {
      return absl::FailedPreconditionError("no release channel: set CacheOptions.mirrors and channel");
    }
    absl::StatusOr<delivery::ResolvedCatalog> current = catalog_->Current(force_refresh);
    if (!current.ok()) return current.status();
    return delivery::CatalogToJson(*current->catalog);
  }

  void Prefetch(const std::vector<std::string>& keys, const PrefetchCallback& done) {
    for (const std::string& key : keys) {
      if (!IsCacheKey(key)) {
        if (done) io_->Post([done, key] { done(key, InvalidKey(key)); });
        continue;
      }
      bool known;
      {
        std::lock_guard lock(mu_);
        known = nodes_.contains(key);
      }
      if (known) {
        if (done) io_->Post([done, key] { done(key, absl::OkStatus()); });
        continue;
      }
      downloads_->Join(key, /*urgent=*/false, [done, key](DownloadCoordinator::Result r) {
        if (done) done(key, r.status());
      });
    }
  }

  absl::StatusOr<LookupResult> Lookup(const fs::path& model, const BakeSettings& settings) {
    if (options_.server.empty()) {
      return absl::FailedPreconditionError("Lookup needs a farm: CacheOptions.server is empty");
    }
    absl::StatusOr<v1::BakeParameters> parameters = ToBakeParameters(settings);
    if (!parameters.ok()) return parameters.status();
    absl::StatusOr<MeshFiles> files = CollectMeshFiles(model, {.follow_symlinks = settings.follow_symlinks});
    if (!files.ok()) return files.status();
    absl::StatusOr<v1::MeshInput> mesh = HashMesh(*files);
    if (!mesh.ok()) return mesh.status();
    absl::StatusOr<Transport*> transport = transport_.Get();
    if (!transport.ok()) return transport.status();
    v1::SubmitBakeRequest request;
    *request.mutable_mesh() = std::move(*mesh);
    *request.mutable_parameters() = *parameters;
    absl::StatusOr<v1::LookupBakeResponse> response = (*transport)->LookupBake(request);
    if (!response.ok()) return response.status();
    return LookupResult{response->cache_key(), response->found()};
  }

  std::vector<CacheEntryInfo> List() {
    LoadNewEntries();
    std::lock_guard lock(mu_);
    std::vector<CacheEntryInfo> out;
    for (const LruIndex::Item& item : lru_.Items()) {
      auto it = nodes_.find(item.key);
      out.push_back(CacheEntryInfo{item.key, layout_.EntryDir(item.key), item.size_bytes, item.last_used,
                                   it != nodes_.end() && !it->second.pin.expired()});
    }
    return out;
  }

  absl::StatusOr<GarbageReport> CollectGarbage(int64_t max_bytes, bool verify) {
    GarbageReport report;
    if (absl::Status s = EnsureLayout(); !s.ok()) return s;
    LoadNewEntries();
    if (verify) VerifyAll(&report);
    Trim(max_bytes < 0 ? options_.max_bytes : max_bytes, &report);
    RemoveStaleFiles(options_.partial_max_age_seconds, &report);
    return report;
  }

  CacheStats Stats() {
    std::lock_guard lock(mu_);
    CacheStats stats = stats_;
    stats.entries = static_cast<int64_t>(lru_.size());
    stats.bytes = lru_.total_bytes();
    stats.pinned_entries = 0;
    for (const auto& [key, node] : nodes_) stats.pinned_entries += node.pin.expired() ? 0 : 1;
    return stats;
  }

 private:
  // What this process knows of one installed entry.
  struct Node {
    EntryRecord record;                     // identities updated as hits re-check them
    std::shared_ptr<const EntryView> view;  // built on first hit
    std::weak_ptr<EntryPin> pin;            // alive while handles are
    bool verified = false;                  // digests checked by this process
    int64_t persisted_touch = 0;            // last use written to disk, Unix seconds
  };

  void Count(int64_t CacheStats::*counter, int64_t n = 1) {
    std::lock_guard lock(mu_);
    stats_.*counter += n;
  }

  // Adds entries present on disk but not in the index (installed by another
  // process, or before this object opened); drops unreadable ones.
  // Also forgets entries no longer on disk that nothing here uses (evicted
  // by another process, or the directory deleted).
  void LoadNewEntries() {
    std::vector<std::string> unknown;
    std::vector<std::string> unlisted;
    {
      std::vector<std::string> keys = layout_.ListEntryKeys();
      const std::unordered_set<std::string> listed(keys.begin(), keys.end());
      std::lock_guard lock(mu_);
      for (std::string& key : keys) {
        if (!nodes_.contains(key)) unknown.push_back(std::move(key));
      }
      for (const auto& [key, node] : nodes_) {
        if (!listed.contains(key) && node.pin.expired()) unlisted.push_back(key);
      }
    }
    for (const std::string& key : unlisted) {
      // Looked at again: it may have been installed since the listing.
      if (fs::exists(layout_.EntryDir(key) / kEntryRecordName)) continue;
      std::lock_guard lock(mu_);
      auto it = nodes_.find(key);
      if (it == nodes_.end() || !it->second.pin.expired()) continue;
      nodes_.erase(it);
      lru_.Erase(key);
    }
    struct Loaded {
      EntryRecord record;
      int64_t last_used;
    };
    std::vector<Loaded> loaded;
    for (const std::string& key : unknown) {
      const fs::path dir = layout_.EntryDir(key);
      absl::StatusOr<EntryRecord> record = ReadEntryRecord(dir);
      if (!record.ok() || record->key != key) {
        if (record.ok() || record.status().code() != absl::StatusCode::kNotFound || fs::exists(dir)) {
          SdkLog().warn("cache: dropping unreadable entry {}: {}", dir.string(),
                        record.ok() ? std::string("key mismatch") : record.status().ToString());
          Count(&CacheStats::corrupt_entries);
          (void)RemoveEntryDir(layout_, dir);
        }
        continue;
      }
      loaded.push_back({std::move(*record), EntryLastUsed(dir)});
    }
    std::sort(loaded.begin(), loaded.end(), [](const Loaded& a, const Loaded& b) { return a.last_used < b.last_used; });
    std::lock_guard lock(mu_);
    for (Loaded& l : loaded) {
      if (nodes_.contains(l.record.key)) continue;
      const std::string key = l.record.key;
      lru_.Insert(key, l.record.TotalBytes(), l.last_used);
      Node& node = nodes_[key];
      node.record = std::move(l.record);
      node.persisted_touch = l.last_used;
    }
  }

  // Forgets `key` in memory (the caller deals with its files).
  void Forget(const std::string& key) {
    std::lock_guard lock(mu_);
    nodes_.erase(key);
    lru_.Erase(key);
  }

  // The pinned, checked local copy of `key`, or nullopt when there is none
  // (a damaged one is removed first). Errors only for unexpected local I/O.
  // `installed`: this process has just installed the entry and recorded
  // its files' identities, which need no second look.
  absl::StatusOr<std::optional<CachedResult>> TryLocal(const std::string& key, bool downloaded = false,
                                                       bool installed = false) {
    const fs::path dir = layout_.EntryDir(key);
    bool known;
    {
      std::lock_guard lock(mu_);
      known = nodes_.contains(key);
    }
    if (!known) {
      // Perhaps installed by another process since we looked.
      absl::StatusOr<EntryRecord> record = ReadEntryRecord(dir);
      if (!record.ok()) {
        if (record.status().code() != absl::StatusCode::kNotFound) {
          SdkLog().warn("cache: dropping unreadable entry {}: {}", dir.string(), record.status().ToString());
          Count(&CacheStats::corrupt_entries);
          (void)RemoveEntryDir(layout_, dir);
        }
        return std::nullopt;
      }
      std::lock_guard lock(mu_);
      if (!nodes_.contains(key)) {
        lru_.Insert(key, record->TotalBytes(), EntryLastUsed(dir));
        nodes_[key].record = std::move(*record);
      }
    }

    std::shared_ptr<EntryPin> pin;
    {
      std::lock_guard lock(mu_);
      auto it = nodes_.find(key);
      if (it == nodes_.end()) return std::nullopt;  // evicted meanwhile
      pin = it->second.pin.lock();
    }
    if (pin == nullptr) {
      absl::StatusOr<std::unique_ptr<EntryLock>> lock = EntryLock::Shared(dir);
      if (!lock.ok()) {  // evicted by another process
        Forget(key);
        return std::nullopt;
      }
      auto fresh = std::make_shared<EntryPin>();
      fresh->lock = std::move(*lock);
      std::lock_guard guard(mu_);
      auto it = nodes_.find(key);
      if (it == nodes_.end()) return std::nullopt;
      pin = it->second.pin.lock();  // another thread may have pinned it first
      if (pin == nullptr) {
        pin = fresh;
        it->second.pin = pin;
      }
    }

    EntryRecord record;
    bool digest;
    std::shared_ptr<const EntryView> view;
    {
      std::lock_guard lock(mu_);
      auto it = nodes_.find(key);
      if (it == nodes_.end()) return std::nullopt;
      record = it->second.record;
      digest = options_.hit_verification == HitVerification::kDigestEveryGet ||
               (options_.hit_verification == HitVerification::kDigestOncePerProcess && !it->second.verified);
      view = it->second.view;
    }
    absl::Status check = installed && !digest ? absl::OkStatus()
                                              : CheckEntryFiles(dir, record, digest ? FileCheck::kDigest
                                                                                    : FileCheck::kMetadata);
    if (check.code() == absl::StatusCode::kNotFound || check.code() == absl::StatusCode::kDataLoss) {
      // A file gone from an installed entry is damage too (something deleted
      // part of it): counted and said, not silently fetched again.
      SdkLog().warn("cache: {} is damaged ({}); fetching it again", key, check.ToString());
      Count(&CacheStats::corrupt_entries);
      Forget(key);
      // Damaged files are useless to every holder, pinned or not.
      (void)RemoveEntryDir(layout_, dir);
      return std::nullopt;
    }
    if (!check.ok()) return check;
    if (view == nullptr) {
      absl::StatusOr<std::shared_ptr<const EntryView>> built = BuildView(dir, record);
      if (!built.ok()) return built.status();
      view = *built;
    }

    const int64_t now = NowUnixSeconds();
    bool persist = false;
    {
      std::lock_guard lock(mu_);
      auto it = nodes_.find(key);
      if (it != nodes_.end()) {
        it->second.record = std::move(record);
        it->second.verified = it->second.verified || digest;
        it->second.view = view;
        // Last use reaches the disk at most once a second per entry: LRU
        // order across restarts needs no finer grain, and hits stay cheap.
        persist = it->second.persisted_touch != now;
        it->second.persisted_touch = now;
      }
      lru_.Touch(key, now);
    }
    if (persist) TouchEntry(dir);
    auto rep = std::make_shared<CachedResult::Rep>();
    rep->view = std::move(view);
    rep->pin = std::move(pin);
    rep->downloaded = downloaded;
    return std::optional<CachedResult>(CachedResult(std::move(rep)));
  }

  static absl::StatusOr<std::shared_ptr<const EntryView>> BuildView(const fs::path& dir, const EntryRecord& record) {
    auto view = std::make_shared<EntryView>();
    view->key = record.key;
    view->dir = dir;
    view->manifest_path = dir / kManifestFileName;
    view->layout = record.layout;
    view->frames = record.frames;
    view->resolution = record.resolution;
    for (const EntryFile& f : record.files) {
      view->files.push_back(
          CachedFile{f.semantic, dir / f.name, f.sha256, f.size_bytes, f.width, f.height, f.format});
      view->size_bytes += f.size_bytes;
    }
    absl::StatusOr<std::string> text = ReadSmallFile(view->manifest_path, kMaxManifestBytes);
    if (!text.ok()) return text.status();
    view->manifest_json = std::move(*text);
    ManifestSummary summary = SummarizeManifest(view->manifest_json);
    view->product = std::move(summary.product);
    view->view_count = summary.view_count;
    view->texture_array = summary.texture_array;
    return std::shared_ptr<const EntryView>(std::move(view));
  }

  // Rebuilds the directory layout when someone deleted it (or part of it)
  // under this cache, so that a running game recovers without a restart.
  absl::Status EnsureLayout() {
    if (layout_.Intact()) return absl::OkStatus();
    std::lock_guard lock(layout_mu_);
    if (layout_.Intact()) return absl::OkStatus();
    SdkLog().warn("cache: {} lost its layout (deleted under a running cache?); rebuilding it",
                  layout_.root().string());
    return layout_.Init();
  }

  // A flight's work: local copy if one appeared, else download and install.
  DownloadCoordinator::Result Download(const std::string& key, CancelSource& flight_cancel) {
    if (cancel_.cancelled()) return cancel_.error();
    if (flight_cancel.cancelled()) return flight_cancel.error();
    // The flight ends when the cache shuts down, too.
    CancelSource::Registration shutdown = cancel_.OnCancel([&flight_cancel] { flight_cancel.Cancel(); });
    absl::StatusOr<std::optional<CachedResult>> local = TryLocal(key);
    if (!local.ok()) return local.status();
    if (local->has_value()) return **local;
    if (absl::Status s = EnsureLayout(); !s.ok()) return s;
    absl::StatusOr<InstallOutcome> installed = InstallFromBestSources(key, &flight_cancel);
    if (!installed.ok()) {
      // A cache shutting down answers with its own reason.
      if (absl::IsCancelled(installed.status()) && cancel_.cancelled()) return cancel_.error();
      return installed.status();
    }
    // This process downloaded the result when it moved some of its bytes
    // over the network; a Get that found them all on disk (another process's
    // download, finished or installed while we waited) did not.
    const bool downloaded = installed->bytes_downloaded > 0;
    // The pin taken before the entry became visible: no evictor, in this
    // process or another, can take it before the caller holds it.
    auto pin = std::make_shared<EntryPin>();
    pin->lock = std::move(installed->pin);
    {
      std::lock_guard lock(mu_);
      if (downloaded) stats_.downloads += 1;
      stats_.bytes_downloaded += installed->bytes_downloaded;
      stats_.bytes_resumed += installed->bytes_resumed;
      if (!nodes_.contains(key)) {  // else another thread found the entry first and knows it
        lru_.Insert(key, installed->record.TotalBytes(), NowUnixSeconds());
        Node& node = nodes_[key];
        node.record = std::move(installed->record);
        // Every byte was just hashed on its way in.
        node.verified = !installed->raced;
      }
      Node& node = nodes_[key];
      if (std::shared_ptr<EntryPin> existing = node.pin.lock(); existing != nullptr) {
        pin = std::move(existing);  // one pin per entry and process
      } else {
        node.pin = pin;
      }
    }
    absl::StatusOr<std::optional<CachedResult>> result = TryLocal(key, downloaded, !installed->raced);
    pin.reset();  // `result` holds it now
    if (!result.ok()) return result.status();
    if (!result->has_value()) {
      return absl::InternalError(absl::StrCat("cache: ", key, " vanished right after its install"));
    }
    Trim(options_.max_bytes, nullptr);  // the new entry is pinned by `result`
    return **result;
  }

  // The cache key of `name`: a key as is, or an asset name of the channel's
  // catalog.
  absl::StatusOr<std::string> Resolve(const std::string& name) {
    if (IsCacheKey(name)) return name;
    if (catalog_ == nullptr) return InvalidKey(name);
    if (absl::Status s = delivery::ValidateAssetName(name); !s.ok()) return s;
    absl::StatusOr<delivery::ResolvedCatalog> current = catalog_->Current();
    if (!current.ok()) return current.status();
    auto it = current->catalog->assets.find(name);
    if (it == current->catalog->assets.end()) {
      return absl::NotFoundError(absl::StrCat("asset \"", name, "\" is not in channel ", options_.channel,
                                              " (catalog ", current->catalog_sha256.substr(0, 12), ", ",
                                              current->catalog->assets.size(), " assets)"));
    }
    return it->second.cache_key;
  }

  // The catalog entry listing `key`, when the channel's catalog has one.
  std::optional<delivery::CatalogAsset> AssetForKey(const std::string& key) {
    if (catalog_ == nullptr) return std::nullopt;
    absl::StatusOr<delivery::ResolvedCatalog> current = catalog_->Current();
    if (!current.ok()) return std::nullopt;
    for (const auto& [name, asset] : current->catalog->assets) {
      if (asset.cache_key == key) return asset;
    }
    return std::nullopt;
  }

  // Mirrors first (for a result the channel's catalog lists), the farm last
  // (when configured); the farm alone for anything else.
  absl::StatusOr<InstallOutcome> InstallFromBestSources(const std::string& key, const CancelSource* cancel) {
    auto farm_reader = [this](const v1::Digest& digest, int64_t offset, Sha256& hash,
                              const std::function<absl::Status(std::string_view)>& sink,
                              const CancelSource* c) -> absl::Status {
      absl::StatusOr<Transport*> transport = transport_.Get();
      if (!transport.ok()) return transport.status();
      return ResumeBlobDownload(**transport, digest, offset, hash, sink, c);
    };
    std::optional<delivery::CatalogAsset> asset = AssetForKey(key);
    if (!asset.has_value()) {
      if (options_.server.empty()) {
        return absl::NotFoundError(absl::StrCat(key, ": not in channel ", options_.channel,
                                                "'s catalog, and no farm is configured (CacheOptions.server)"));
      }
      // The farm's HTTP front end alone when one is named; gRPC connects
      // only for what it cannot give.
      if (farm_http_.has_value()) {
        auto over_http = InstallOverFarmHttp(*farm_http_, farm_reader, absl::StrCat("server ", options_.server),
                                             layout_, key, hooks_.download, cancel);
        if (over_http.has_value()) return *std::move(over_http);
      }
      absl::StatusOr<Transport*> transport = transport_.Get();
      if (!transport.ok()) return transport.status();
      return DownloadAndInstall(**transport, layout_, key, hooks_.download, cancel);
    }
    InstallPlan plan;
    plan.listing = delivery::ManifestFromAsset(*asset);
    plan.listing_source = absl::StrCat("channel ", options_.channel, "'s catalog");
    for (const std::string& mirror : options_.mirrors) {
      HttpReadOptions read;
      read.stall_seconds = options_.rpc_timeout_seconds;
      read.max_attempts = options_.max_attempts;
      read.ca_file = options_.mirror_ca_file;
      plan.sources.push_back(
          {absl::StrCat("mirror ", mirror),
           [mirror, read](const v1::Digest& digest, int64_t offset, Sha256& hash,
                          const std::function<absl::Status(std::string_view)>& sink,
                          const CancelSource* c) mutable -> absl::Status {
             read.cancel = c;
             return ReadVerified(delivery::JoinUrl(mirror, delivery::BlobPath(digest.hash())),
                                           digest.hash(), digest.size_bytes(), offset, hash, sink, read);
           },
           /*mirror=*/true});
    }
    if (!options_.server.empty()) {
      plan.sources.push_back({absl::StrCat("server ", options_.server), farm_reader, /*mirror=*/false});
    }
    return InstallFromSources(plan, layout_, key, hooks_.download, cancel);
  }

  // Evicts least recently used entries that no one uses until the total is
  // at most `cap`.
  void Trim(int64_t cap, GarbageReport* report) {
    std::vector<std::string> victims;
    {
      std::lock_guard lock(mu_);
      victims = lru_.Victims(cap, [&](const std::string& key) {
        auto it = nodes_.find(key);
        return it != nodes_.end() && !it->second.pin.expired();
      });
    }
    for (const std::string& key : victims) {
      const fs::path dir = layout_.EntryDir(key);
      // Fails while any process holds a pin, or when the entry is gone.
      std::unique_ptr<EntryLock> exclusive = EntryLock::TryExclusive(dir);
      if (exclusive == nullptr) {
        if (!fs::exists(dir / kEntryRecordName)) Forget(key);
        continue;
      }
      int64_t size = 0;
      {
        std::lock_guard lock(mu_);
        auto it = nodes_.find(key);
        if (it == nodes_.end() || !it->second.pin.expired()) continue;  // a Get pinned it meanwhile
        size = it->second.record.TotalBytes();
        nodes_.erase(it);
        lru_.Erase(key);
        stats_.evicted_entries += 1;
      }
      if (absl::Status s = RemoveEntryDir(layout_, dir); !s.ok()) SdkLog().warn("cache: {}", s.ToString());
      SdkLog().debug("cache: evicted {} ({} bytes)", key, size);
      if (report != nullptr) {
        report->evicted_entries += 1;
        report->evicted_bytes += size;
      }
    }
  }

  void VerifyAll(GarbageReport* report) {
    std::vector<std::pair<std::string, EntryRecord>> unpinned;
    {
      std::lock_guard lock(mu_);
      for (const auto& [key, node] : nodes_) {
        if (node.pin.expired()) unpinned.emplace_back(key, node.record);
      }
    }
    for (auto& [key, record] : unpinned) {
      const fs::path dir = layout_.EntryDir(key);
      absl::Status s = CheckEntryFiles(dir, record, FileCheck::kDigest);
      if (s.ok() || (s.code() != absl::StatusCode::kDataLoss && s.code() != absl::StatusCode::kNotFound)) continue;
      SdkLog().warn("cache: {} fails verification: {}", key, s.ToString());
      Forget(key);
      (void)RemoveEntryDir(layout_, dir);
      report->broken_entries += 1;
    }
  }

  // Partial downloads untouched for `max_age` seconds that no download is
  // using (their lock is free; see partial_download.h: a download links a
  // partial into its staging directory under that lock, so removing one
  // never breaks an install), and staging leftovers of crashed installs
  // (old, and not locked by a running install).
  void RemoveStaleFiles(double max_age, GarbageReport* report) {
    std::error_code ec;
    for (fs::directory_iterator it(layout_.PartialDir(), ec), end; !ec && it != end; it.increment(ec)) {
      const int64_t size = RemovePartialIfUnused(it->path(), nullptr, max_age);
      if (size >= 0 && report != nullptr) {
        report->removed_partials += 1;
        report->removed_partial_bytes += size;
      }
    }
    for (fs::directory_iterator it(layout_.StagingDir(), ec), end; !ec && it != end; it.increment(ec)) {
      const fs::path path = it->path();
      bool removed;
      if (path.filename().string().rfind("trash-", 0) == 0) {
        std::error_code rm;
        removed = fs::remove_all(path, rm) > 0;
      } else {
        removed = RemoveStagingIfUnused(path, kStagingMaxAgeSeconds);
      }
      if (removed && report != nullptr) report->removed_partials += 1;
    }
  }

  const CacheOptions options_;
  const CacheLayout layout_;
  const CacheTestHooks hooks_;
  LazyTransport transport_;
  const std::optional<FarmHttpEndpoint> farm_http_;  // named in the options (not advertised)
  // The release channel (CacheOptions::channel); null without one.
  std::unique_ptr<delivery::ChannelCatalog> catalog_;
  // Cancel() ends every download at once: backoff waits, a partial held by
  // another download, and the ReadBlob or GetResult in flight (TryCancel).
  CancelSource cancel_{"the cache is shutting down"};

  std::mutex layout_mu_;  // one rebuild at a time
  std::mutex mu_;
  std::unordered_map<std::string, Node> nodes_ ABSL_GUARDED_BY(mu_);
  LruIndex lru_ ABSL_GUARDED_BY(mu_);
  CacheStats stats_ ABSL_GUARDED_BY(mu_);
  // Prefetches by the name they were asked under, for CancelPrefetch.
  std::unordered_map<std::string, std::string> prefetch_keys_ ABSL_GUARDED_BY(mu_);

  // Destroyed first (see ~Impl): their threads call into the members above.
  std::unique_ptr<DownloadCoordinator> downloads_;
  std::unique_ptr<WorkQueue> io_;
};

Cache::Cache(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Cache::~Cache() = default;

absl::StatusOr<std::unique_ptr<Cache>> CacheFactory::Open(const CacheOptions& options, const CacheTestHooks& hooks) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  auto impl = std::make_unique<Cache::Impl>(options, hooks);
  if (absl::Status s = impl->Start(); !s.ok()) return s;
  return std::unique_ptr<Cache>(new Cache(std::move(impl)));
}

absl::StatusOr<std::unique_ptr<Cache>> Cache::Open(const CacheOptions& options) {
  return CacheFactory::Open(options, {});
}

absl::StatusOr<CachedResult> Cache::Get(const std::string& cache_key) { return impl_->Get(cache_key); }

void Cache::GetAsync(const std::string& cache_key, GetCallback done) { impl_->GetAsync(cache_key, std::move(done)); }

std::future<absl::StatusOr<CachedResult>> Cache::GetAsync(const std::string& cache_key) {
  auto promise = std::make_shared<std::promise<absl::StatusOr<CachedResult>>>();
  std::future<absl::StatusOr<CachedResult>> future = promise->get_future();
  impl_->GetAsync(cache_key, [promise](absl::StatusOr<CachedResult> r) { promise->set_value(std::move(r)); });
  return future;
}

absl::StatusOr<LookupResult> Cache::Lookup(const std::filesystem::path& model, const BakeSettings& settings) {
  return impl_->Lookup(model, settings);
}

void Cache::Prefetch(const std::vector<std::string>& cache_keys, PrefetchCallback done) {
  impl_->Prefetch(cache_keys, done);
}

void Cache::Prefetch(const std::vector<std::string>& names, int priority, PrefetchCallback done) {
  impl_->PrefetchNames(names, priority, done);
}

int Cache::CancelPrefetch(const std::vector<std::string>& names) { return impl_->CancelPrefetch(names); }

absl::StatusOr<std::string> Cache::CatalogJson(bool force_refresh) { return impl_->CatalogJson(force_refresh); }

std::vector<CacheEntryInfo> Cache::List() { return impl_->List(); }

absl::StatusOr<GarbageReport> Cache::CollectGarbage(int64_t max_bytes, bool verify) {
  return impl_->CollectGarbage(max_bytes, verify);
}

CacheStats Cache::Stats() { return impl_->Stats(); }

const CacheOptions& Cache::options() const { return impl_->options(); }

}  // namespace impostor::sdk
