// The game-client side of the bake farm: impostors fetched on demand through
// a local content-addressed cache. The first Get of a cache key downloads the
// result (every file checked against its SHA-256 and size, then installed
// atomically); every later Get is answered from disk without network traffic.
//
// Like client.h, this header exposes no gRPC or protobuf type.
//
// Typical use in an engine:
//
//   impostor::sdk::CacheOptions options;
//   options.server = "bake.example.com:50051";
//   options.dir = "/home/me/.cache/impostor";
//   auto cache = impostor::sdk::Cache::Open(options);
//   if (!cache.ok()) return cache.status();
//   // On a loader thread (blocks until local or downloaded):
//   auto result = (*cache)->Get(key);
//   // Or from the game thread (never blocks it):
//   (*cache)->GetAsync(key, [](absl::StatusOr<impostor::sdk::CachedResult> r) { ... });
//   // Keep `result` alive while its files are in use: eviction skips it.
//
// A shipped game fetches from a published release through a CDN instead of
// the farm (release_format.md, installed in share/doc/impostor):
//
//   options.server = "";  // no farm: mirrors only
//   options.mirrors = {"https://cdn.example.com/impostors", "https://origin.example.com/impostors"};
//   options.channel = "release-1.4";
//   auto oak = (*cache)->Get("trees/oak");  // an asset name, resolved through the channel's catalog
//
// A plain C API over the same cache is in impostor_c.h.
#ifndef IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_CACHE_H_
#define IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_CACHE_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "impostor/client.h"

namespace impostor::sdk {

class CacheFactory;

// How much a local hit checks before it is trusted.
enum class HitVerification {
  // Each file's size, inode and modification time must equal what was
  // recorded when it was installed. Catches truncation, replacement and
  // (almost always) rewrites; costs a few stat() calls.
  kMetadata,
  // kMetadata, plus a full SHA-256 of every file the first time a result is
  // handed out by this Cache object (about 50 ms for a 2048² three-map
  // result); later hits in the same process check metadata only.
  kDigestOncePerProcess,
  // A full SHA-256 of every file on every Get. For tools, not for games.
  kDigestEveryGet,
};

// How a Cache is set up. Checked by Cache::Open (INVALID_ARGUMENT naming the
// field when out of range).
struct CacheOptions {
  // Address of the bake server as "host:port" (any gRPC target string), or
  // the addresses of several replicas of one farm, comma-separated
  // ("bake1:50051,bake2:50051"; see ClientOptions::server for failover).
  // Nothing connects to it until a Get misses or Lookup is called, so a
  // cache opens (and serves local hits) with the server down.
  // Empty: no farm (a shipped game that reads only `mirrors`; Lookup then
  // fails FAILED_PRECONDITION). Default: "localhost:50051". Must not be
  // empty unless `mirrors` are given.
  std::string server = "localhost:50051";

  // Base URLs of published release trees (`impostor publish`;
  // release_format.md), http:// or https://, tried in this order: a CDN
  // edge first, then the origin, e.g. {"https://cdn.example.com/impostors",
  // "http://farm:8080/releases"}. With `channel`, Get, GetAsync and
  // Prefetch also take asset names ("trees/oak"), resolved through the
  // channel's catalog; each file of a result the catalog lists comes from
  // the first mirror that gives it intact (verified as it streams; a cut
  // transfer resumes with a Range request), then from the farm when
  // `server` is set. A wrong byte, an error page, a truncated body, a
  // missing file or a stall (no byte for rpc_timeout_seconds) moves on to
  // the next source; nothing unverified is installed. Results the catalog
  // does not list come from the farm only. Default: none. Needs `channel`.
  std::vector<std::string> mirrors;

  // The release channel ("nightly", "release-1.4"): its catalog is fetched
  // from the mirrors on first need, refreshed (by ETag) when older than
  // catalog_refresh_seconds, and kept in `dir`, so that with every mirror
  // and the farm gone a game still resolves names it resolved before and
  // is served what it cached. Default: empty. Needs `mirrors`.
  std::string channel;

  // How long a fetched catalog is used before the channel is asked again,
  // seconds. Default: 60. Range: 0..86400.
  double catalog_refresh_seconds = 60;

  // An Ed25519 public key (PEM, `openssl pkey -pubout`): only catalogs
  // signed by its private key (`impostor publish --sign-key`) are accepted,
  // so a tampered mirror cannot swap content. Default: empty (unsigned
  // catalogs accepted; every file is still verified against the catalog).
  std::string catalog_public_key_file;

  // CA bundle (PEM) for https:// mirrors. Default: empty = the system's.
  std::string mirror_ca_file;

  // Directory of the cache; created if missing, and created again if it is
  // deleted while the cache runs (the next miss or CollectGarbage rebuilds
  // it). Several Cache objects, in this process or others, may share it
  // (installs are atomic renames, in-use results are locked against
  // eviction, and partial downloads are locked while in use: concurrent
  // Gets of one key, or of keys sharing files, share the bytes on disk and
  // all succeed), but one per process is the efficient way. Layout:
  // cache_layout.md (installed in share/doc/impostor).
  // Default: none. Required.
  std::filesystem::path dir;

  // Total size of installed results, in bytes, above which the least
  // recently used results are deleted. A result with a live CachedResult
  // handle is never deleted, so the total may exceed the cap while handles
  // pin more than it; a single result larger than the cap is still installed
  // and returned. The cap is enforced when the cache opens, after every
  // install and by CollectGarbage; a result released in between goes at the
  // next of those. Partial downloads kept for resuming are not counted (see
  // partial_max_age_seconds).
  // Default: 2 GiB. Range: >= 0 (0 keeps nothing that is not in use).
  int64_t max_bytes = int64_t{2} << 30;

  // Results downloaded at once, each on a thread of its own (started when
  // first needed, so a cache that never downloads holds none). Concurrent
  // Gets of the same key always share one download. Each download holds up
  // to 10 files open (a socket, its staging directory and up to 8 of the
  // result's files until they are synced). Default: 20. Range: 1..64.
  int max_parallel_downloads = 20;

  // Of those, how many Prefetch may occupy, so that a long prefetch list
  // never delays a Get the game is waiting for (Gets also jump the queue).
  // Default: 16. Range: 1..max_parallel_downloads.
  int max_parallel_prefetches = 16;

  // Threads that answer GetAsync from disk (hit checks, including hashing
  // under kDigestOncePerProcess). Default: 2. Range: 1..64.
  int io_threads = 2;

  // What a local hit checks; see HitVerification.
  // Default: kDigestOncePerProcess.
  HitVerification hit_verification = HitVerification::kDigestOncePerProcess;

  // Deadline of each unary RPC, in seconds; a download may take any time
  // while bytes keep arriving, and fails after this long without one (as
  // ClientOptions::rpc_timeout_seconds). Default: 30. Range: > 0.
  double rpc_timeout_seconds = 30;

  // Tries per RPC while the server answers UNAVAILABLE or DEADLINE_EXCEEDED,
  // with exponential backoff from 100 ms; a download's count starts over
  // whenever bytes arrive (as ClientOptions::max_attempts).
  // Default: 3. Range: >= 1.
  int max_attempts = 3;

  // How long a server this cache has reached may stay away, in seconds
  // (as ClientOptions::max_outage_seconds): a Get, Prefetch or Lookup under
  // way when the server goes down keeps retrying (downloads resume at the
  // byte already on disk) until the outage has lasted this long, then fails
  // with UNAVAILABLE; once it has, further misses fail after max_attempts
  // quick tries until the server answers again. Shorter than the CLI's
  // bake budget: a game's loader thread should not hang for minutes, and a
  // later Get tries again anyway. Never delays a cache that has not
  // connected yet (see connect_timeout_seconds).
  // Default: 30. Range: 0..86400 (0 = max_attempts alone decides).
  double max_outage_seconds = 30;

  // Told when the server stops and starts answering again (as
  // ClientOptions::on_connection_change), on a cache thread.
  // Default: empty.
  std::function<void(const ConnectionEvent&)> on_connection_change;

  // How long the first connection may take, in seconds; a refused
  // connection fails in about one second. After a failure, further network
  // calls within `offline_retry_seconds` fail at once with the same
  // UNAVAILABLE instead of trying again. Default: 5. Range: > 0.
  double connect_timeout_seconds = 5;
  // Default: 1. Range: >= 0.
  double offline_retry_seconds = 1;
  // Keepalive of the connection while a download is in flight: as
  // ClientOptions::keepalive_seconds. Default: 20. Range: 1..7200.
  int keepalive_seconds = 20;

  // Partial downloads (kept so that a broken transfer resumes where it
  // stopped, also after a restart) untouched for longer than this are
  // deleted when the cache opens and by Cache::CollectGarbage. One that a
  // download, in any process, is using is never deleted, whatever its age
  // (0 deletes all the others, resume data of killed downloads included).
  // Default: 7 days. Range: >= 0.
  double partial_max_age_seconds = 7 * 24 * 3600;

  // Transport security, as the ClientOptions fields of the same names
  // (README "Securing a farm: TLS"): tls_ca_file set = TLS trusting only
  // that CA; tls_cert_file + tls_key_file = mutual TLS; tls_server_name =
  // the name the server's certificate carries when it differs from the host
  // in `server`. Open checks the files (INVALID_ARGUMENT naming the field).
  // Default: all empty = plaintext.
  std::string tls_ca_file;
  std::string tls_cert_file;
  std::string tls_key_file;
  std::string tls_server_name;
  // Identity (issue 14): as ClientOptions::token_file and ::token (the file
  // wins, then the token, then $IMPOSTOR_TOKEN). Default: empty.
  std::string token_file;
  std::string token;
  // The farm's HTTP front end, as ClientOptions::farm_http: a miss then
  // downloads the result's large files from it (verified, resumed from the
  // partial file), and over gRPC those it cannot give intact. Empty =
  // $IMPOSTOR_FARM_HTTP, else the one the farm advertises (impostor-server
  // --http-advertise); "none" = none. Open checks it (INVALID_ARGUMENT
  // naming this field). Given here or in the variable, a miss of a result
  // the catalog does not list reads the listing from it too
  // (/api/v1/results/KEY/manifest) and every file, so no gRPC channel is
  // opened unless the front end cannot give a file (or the listing: the
  // farm is then asked over gRPC as without it). Default: empty.
  std::string farm_http;
};

// One file of a cached result.
struct CachedFile {
  // "albedo_alpha", "normal_depth", "orm", or "manifest" for manifest.json.
  std::string semantic;
  std::filesystem::path path;
  std::string sha256;  // lowercase hex
  int64_t size_bytes = 0;
  // The manifest's width, height and format of the file: pixels and
  // "png_rgba8" / "png_rgba16" for map images; for other files what their
  // product's manifest says (cards.glb: the card count x 1; manifest.json
  // and views.json: 0 x 0, "json"). manifest_format.md (share/doc/impostor).
  uint32_t width = 0;
  uint32_t height = 0;
  std::string format;
};

// A result in the cache, pinned: while any copy of this handle is alive the
// result's files are not deleted by eviction (in this process or, through a
// shared file lock, any other using the same directory).
//
// Copyable and cheap (a shared pointer); copies share one pin. Thread-safe
// to read and copy from any thread. It may outlive its Cache.
class CachedResult {
 public:
  CachedResult();
  ~CachedResult();
  CachedResult(const CachedResult&);
  CachedResult& operator=(const CachedResult&);
  CachedResult(CachedResult&&) noexcept;
  CachedResult& operator=(CachedResult&&) noexcept;

  // False for a default-constructed handle.
  bool valid() const;

  const std::string& key() const;
  // The directory holding the result's files.
  const std::filesystem::path& dir() const;
  // manifest.json (format: manifest_format.md, share/doc/impostor) and its text.
  const std::filesystem::path& manifest_path() const;
  const std::string& manifest_json() const;
  // Every map image in manifest order, then manifest.json.
  const std::vector<CachedFile>& files() const;
  // The map with `semantic`, or nullptr.
  const CachedFile* map(const std::string& semantic) const;
  // Sum of the files' sizes.
  int64_t size_bytes() const;
  // The manifest's `layout` ("octahedral", "hemi-octahedral",
  // "azimuth-elevation", "ring-top" or "billboard"), `frames` (frames per
  // axis; the atlas grid side for ring-top and billboard) and `resolution`
  // (atlas side, pixels). With view_count(), what
  // impostor::sdk::AtlasLayoutFromManifest (impostor/runtime.h) takes.
  const std::string& layout() const;
  uint32_t frames() const;
  uint32_t resolution() const;
  // The manifest's `product`: "atlas", "surfels", "cards" or "lod-chain"
  // (whose impostor level is an atlas). Only "atlas" and "lod-chain"
  // results have views for the runtime math.
  const std::string& product() const;
  // Length of the manifest's `views` (the atlas's frames; 0 for cards and
  // surfels).
  uint32_t view_count() const;
  // True when the maps are texture arrays (baked with texture_array /
  // `impostor bake --array`): each map a strip one tile wide with one tile
  // per view, so files()' width is the tile and height view_count() tiles.
  // Load them as arrays of view_count() layers: a frame's layer is its
  // index and its UV is the frame UV (FrameUvToAtlasUv is for atlases).
  bool texture_array() const;
  // True when this Get (or the download it joined) fetched some of the
  // result's bytes over the network; false when they were all on disk
  // already: installed, or downloaded by another process (or Cache object)
  // whose download this Get waited for.
  bool downloaded() const;

  struct Rep;  // private
  explicit CachedResult(std::shared_ptr<const Rep> rep);

 private:
  std::shared_ptr<const Rep> rep_;
};

// Answer of Cache::Lookup.
struct LookupResult {
  // The cache key the mesh and settings map to (64 hex chars), found or not.
  std::string cache_key;
  // True when the server has a result baked under cache_key; Get(cache_key)
  // then succeeds.
  bool found = false;
};

// One installed result, as Cache::List reports it.
struct CacheEntryInfo {
  std::string key;
  std::filesystem::path dir;
  int64_t size_bytes = 0;
  // Last time a Get returned it (or it was installed), Unix seconds.
  int64_t last_used_unix_seconds = 0;
  // Handles of this process pin it.
  bool in_use = false;
};

// Counters since the Cache was opened, and the current footprint.
struct CacheStats {
  int64_t entries = 0;
  int64_t bytes = 0;           // installed results
  int64_t pinned_entries = 0;  // with live handles in this process
  int64_t hits = 0;            // Gets answered from disk
  int64_t misses = 0;          // Gets that needed the network (shared or not)
  // Results of which this object fetched bytes over the network (those
  // whose CachedResult::downloaded() is true); a miss answered by another
  // process's download counts as a miss only.
  int64_t downloads = 0;
  int64_t bytes_downloaded = 0;  // received over the network by this object
  // Bytes of unfinished partial files (downloads interrupted earlier, in any
  // process) that this object completed instead of fetching them again.
  // Partial files another download had finished count as neither.
  int64_t bytes_resumed = 0;
  int64_t corrupt_entries = 0; // local results found damaged (a file changed or gone, an unreadable record) and dropped
  int64_t evicted_entries = 0;
};

// What Cache::CollectGarbage removed.
struct GarbageReport {
  int64_t evicted_entries = 0;
  int64_t evicted_bytes = 0;
  int64_t broken_entries = 0;    // failed verification (with verify) or unreadable
  int64_t removed_partials = 0;  // stale partial downloads and staging leftovers
  int64_t removed_partial_bytes = 0;
};

// The cache. Owns a pool of download threads and a pool of I/O threads, and
// a lazily opened connection to the server.
//
// Thread-safety: every method may be called from any thread, concurrently.
// Callbacks run on the cache's own threads; they may call the cache again,
// but must not block for long (they hold up the pool). Destroying the Cache
// cancels queued and running downloads (their callbacks get CANCELLED, with
// partial files kept for resuming) and waits for running callbacks; handles
// stay valid. A GetAsync or Prefetch callback may destroy the Cache itself
// (the last thing it does with it): the destructor then waits for the other
// threads, and the one running that callback ends when it returns.
class Cache {
 public:
  // Validates `options`, creates options.dir, loads the index of installed
  // results and trims it to max_bytes. Does not contact the server.
  // INVALID_ARGUMENT (bad option), INTERNAL (the directory is unusable, or
  // was written by an incompatible version).
  static absl::StatusOr<std::unique_ptr<Cache>> Open(const CacheOptions& options);

  ~Cache();
  Cache(const Cache&) = delete;
  Cache& operator=(const Cache&) = delete;

  // The result under `cache_key`: from disk when present and intact (no
  // network traffic), else downloaded, verified, installed and returned.
  // Blocks the caller until then. A damaged local copy is dropped and
  // downloaded again. Concurrent Gets of one key share one download; so do,
  // through the files on disk, Gets in other processes sharing the
  // directory, for as long as the download they wait for keeps writing (one
  // that has written nothing for 5 seconds, e.g. its process is stopped in
  // a debugger, is not waited for any longer: this Get then downloads the
  // file itself).
  // `cache_key` may also be an asset name of the configured channel
  // ("trees/oak"; see CacheOptions::mirrors): it is resolved through the
  // channel's catalog first.
  // Errors: INVALID_ARGUMENT (not 64 lowercase hex chars, nor a valid asset
  // name with a channel configured), NOT_FOUND (nothing baked under that
  // key; an asset name the channel's catalog does not list),
  // PERMISSION_DENIED (the catalog's signature fails), UNAVAILABLE (not cached and the server
  // cannot be reached: fast when it was never reached, see
  // connect_timeout_seconds; after max_outage_seconds when it went away
  // during the download), DATA_LOSS (the
  // server's bytes do not match their digests), INTERNAL (local disk),
  // RESOURCE_EXHAUSTED (the cache's disk or quota is full: the message names
  // the path and the free space; nothing half-written is left, results
  // already cached are still served, and a Get once space returns works),
  // CANCELLED (the Cache is being destroyed), or an RPC's error.
  absl::StatusOr<CachedResult> Get(const std::string& cache_key);

  // Get without blocking the caller: `done` is called exactly once, on a
  // cache thread, with what Get would return.
  using GetCallback = std::function<void(absl::StatusOr<CachedResult>)>;
  void GetAsync(const std::string& cache_key, GetCallback done);
  // The same as a future.
  std::future<absl::StatusOr<CachedResult>> GetAsync(const std::string& cache_key);

  // The cache key a bake of `model` with `settings` would have, and whether
  // the server has it baked, without baking or uploading: the model's files
  // are hashed locally and the server asked (BakeService.LookupBake).
  // Errors: as Client::SubmitBake for the model and settings, UNAVAILABLE
  // when the server is unreachable, or an RPC's error.
  absl::StatusOr<LookupResult> Lookup(const std::filesystem::path& model, const BakeSettings& settings);

  // Downloads `cache_keys` in the background, at most
  // max_parallel_prefetches at a time; keys already on disk are skipped
  // without network traffic. `done` (may be empty) is called once per key on
  // a cache thread with the outcome. Does not pin: a prefetched result may be
  // evicted again if the cap is too small to hold it.
  using PrefetchCallback = std::function<void(const std::string& cache_key, const absl::Status& status)>;
  void Prefetch(const std::vector<std::string>& cache_keys, PrefetchCallback done = {});

  // Prefetch for a game's streaming: keys or asset names (as Get takes
  // them), started in order of `priority` (higher first; equal ones in the
  // order asked), at most max_parallel_prefetches at once. Prefetching a
  // name again with another priority re-prioritises it while it waits.
  // `done` gets the name as given.
  void Prefetch(const std::vector<std::string>& names, int priority, PrefetchCallback done = {});

  // Drops prefetches no longer wanted (e.g. the camera turned away): a
  // queued one is removed and its callback answered CANCELLED; a running
  // one is cancelled, keeping the bytes it downloaded for a later resume. A
  // prefetch a Get is waiting for is left alone. Returns how many were
  // cancelled.
  int CancelPrefetch(const std::vector<std::string>& names);

  // Installed results, most recently used first.
  std::vector<CacheEntryInfo> List();

  // The channel's catalog as JSON (release_format.md), fetched or refreshed
  // as Get would. FAILED_PRECONDITION without mirrors and channel; else as
  // Get's resolution of a name.
  absl::StatusOr<std::string> CatalogJson(bool force_refresh = false);

  // Trims to `max_bytes` (< 0: options.max_bytes) by evicting least
  // recently used results not in use, removes stale partial downloads (see
  // partial_max_age_seconds) and staging leftovers of crashed installs
  // (never what a running download or install, in any process, uses), and
  // with `verify` re-hashes every result not in use and drops those that do
  // not match. Rebuilds the directory if it was deleted.
  absl::StatusOr<GarbageReport> CollectGarbage(int64_t max_bytes = -1, bool verify = false);

  CacheStats Stats();
  const CacheOptions& options() const;

  class Impl;  // private

 private:
  friend class CacheFactory;  // opens with test hooks (cache_testing.h, in the source tree)
  explicit Cache(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_CACHE_H_
