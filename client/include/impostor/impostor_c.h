/* A plain C API over the impostor result cache (impostor/cache.h), for
 * engines and tools written in other languages (C#, Rust, Python through
 * ctypes). Opaque handles, status codes, no callbacks across threads other
 * than impostor_cache_get_async's and the log handler's
 * (impostor_set_log_handler).
 *
 * Status codes are the canonical ones (absl::StatusCode = grpc::StatusCode):
 * IMPOSTOR_OK 0, IMPOSTOR_CANCELLED 1, IMPOSTOR_INVALID_ARGUMENT 3,
 * IMPOSTOR_NOT_FOUND 5, IMPOSTOR_INTERNAL 13, IMPOSTOR_UNAVAILABLE 14,
 * IMPOSTOR_DATA_LOSS 15, ...; impostor_last_error() gives the message of the
 * last failure on the calling thread.
 *
 * Thread-safety: a cache may be used from any thread concurrently. A result
 * handle may be read from any thread and must be released exactly once; the
 * strings it returns live as long as it does. Releasing a result unpins it
 * (it may then be evicted); it may outlive its cache.
 *
 *   impostor_cache_options o;
 *   impostor_cache_options_init(&o);
 *   o.server = "bake.example.com:50051";
 *   o.dir = "/home/me/.cache/impostor";
 *   impostor_cache* cache;
 *   if (impostor_cache_open(&o, &cache) != IMPOSTOR_OK) { puts(impostor_last_error()); ... }
 *   impostor_result* r;
 *   if (impostor_cache_get(cache, key, &r) == IMPOSTOR_OK) {
 *     load_texture(impostor_result_map_path(r, "albedo_alpha"));
 *     impostor_result_release(r);
 *   }
 *   impostor_cache_close(cache);
 */
#ifndef IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_IMPOSTOR_C_H_
#define IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_IMPOSTOR_C_H_

#include <stddef.h>
#include <stdint.h>

/* Every function below is exported from libimpostor.so even though the
 * library hides all other symbols. */
#if defined(__GNUC__)
#define IMPOSTOR_C_EXPORT __attribute__((visibility("default")))
#else
#define IMPOSTOR_C_EXPORT
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef enum impostor_status {
  IMPOSTOR_OK = 0,
  IMPOSTOR_CANCELLED = 1,
  IMPOSTOR_UNKNOWN = 2,
  IMPOSTOR_INVALID_ARGUMENT = 3,
  IMPOSTOR_DEADLINE_EXCEEDED = 4,
  IMPOSTOR_NOT_FOUND = 5,
  IMPOSTOR_RESOURCE_EXHAUSTED = 8, /* the cache's disk or quota is full */
  IMPOSTOR_FAILED_PRECONDITION = 9,
  IMPOSTOR_INTERNAL = 13,
  IMPOSTOR_UNAVAILABLE = 14,
  IMPOSTOR_DATA_LOSS = 15
  /* Other canonical codes may appear; treat unknown values as errors. */
} impostor_status;

typedef struct impostor_cache impostor_cache;
typedef struct impostor_result impostor_result;

/* Mirrors impostor::sdk::CacheOptions (see impostor/cache.h for each
 * field's meaning, default and range). Always fill it with
 * impostor_cache_options_init first, then change what you need. Strings are
 * copied by impostor_cache_open. */
typedef struct impostor_cache_options {
  const char* server;             /* default "localhost:50051"; replicas: "a:50051,b:50051" */
  const char* dir;                /* required */
  int64_t max_bytes;              /* default 2 GiB; >= 0 */
  int32_t max_parallel_downloads; /* default 20; 1..64 */
  int32_t max_parallel_prefetches;/* default 16; 1..max_parallel_downloads */
  double connect_timeout_seconds; /* default 5; > 0 */
  double rpc_timeout_seconds;     /* default 30; > 0 */
  int32_t max_attempts;           /* default 3; >= 1 */
  /* How long a server the cache has reached may stay away while a get,
   * prefetch or lookup keeps retrying, seconds. Default 30; 0..86400
   * (0 = max_attempts alone decides). Added after max_attempts: callers that
   * fill the struct with impostor_cache_options_init get the default. */
  double max_outage_seconds;
  /* Transport security, as CacheOptions' tls_* fields (README "Securing a
   * farm: TLS"): paths of PEM files, NULL = not given. tls_ca_file set =
   * TLS trusting only that CA; tls_cert_file + tls_key_file = mutual TLS;
   * tls_server_name = the name the server's certificate carries when it
   * differs from the host in `server`. All NULL (the default) = plaintext.
   * impostor_cache_open checks the files (IMPOSTOR_INVALID_ARGUMENT naming
   * the field). Added after max_outage_seconds, as above. */
  const char* tls_ca_file;
  const char* tls_cert_file;
  const char* tls_key_file;
  const char* tls_server_name;
  /* Identity (issue 14): a file holding the bearer token, or the token
   * itself; NULL = none (then $IMPOSTOR_TOKEN is used). The file wins.
   * Added after max_outage_seconds; init sets both NULL. */
  const char* token_file;
  const char* token;
  /* Keepalive while a download is in flight (issue 15), as CacheOptions'
   * keepalive_seconds: ping the server after this many quiet seconds and
   * give the connection up when no answer comes within min(it, 10) s, so a
   * download over a link that died without a reset moves on in seconds.
   * Default 20; 1..7200 (IMPOSTOR_INVALID_ARGUMENT naming the field).
   * Added after token; init sets the default. */
  int32_t keepalive_seconds;
} impostor_cache_options;

IMPOSTOR_C_EXPORT void impostor_cache_options_init(impostor_cache_options* options);

/* Opens (creates) the cache directory; does not contact the server. On
 * success *out must be closed with impostor_cache_close. Every setting not
 * in impostor_cache_options has its default: impostor_cache_open_ext sets
 * those too. */
IMPOSTOR_C_EXPORT impostor_status impostor_cache_open(const impostor_cache_options* options, impostor_cache** out);

/* What a local hit checks before it is trusted (impostor::sdk::
 * HitVerification, impostor/cache.h). */
typedef enum impostor_hit_verification {
  /* Each file's size, inode and modification time as recorded when it was
   * installed: catches truncation, replacement and (almost always)
   * rewrites; a few stat() calls. */
  IMPOSTOR_HIT_VERIFY_METADATA = 0,
  /* The metadata, plus a SHA-256 of every file the first time a result is
   * handed out by this cache object (about 50 ms for a 2048^2 three-map
   * result); later hits check metadata only. The default. */
  IMPOSTOR_HIT_VERIFY_DIGEST_ONCE_PER_PROCESS = 1,
  /* A SHA-256 of every file on every get. For tools, not for games. */
  IMPOSTOR_HIT_VERIFY_DIGEST_EVERY_GET = 2
} impostor_hit_verification;

/* The CacheOptions settings that impostor_cache_options lacks. They are a
 * struct of their own because impostor_cache_options carries no size: a
 * field appended to it would be read past the end of the struct that a
 * program built against an older header passes. This one carries its size,
 * as impostor_bake_settings does: initialise it with
 * impostor_cache_options_ext_init, change what you need and pass it to
 * impostor_cache_open_ext. A later library may append fields; it reads
 * only those within `size` and gives the others their defaults.
 *
 *   impostor_cache_options_ext ext;
 *   impostor_cache_options_ext_init(&ext);
 *   ext.hit_verification = IMPOSTOR_HIT_VERIFY_METADATA;
 *   status = impostor_cache_open_ext(&o, &ext, &cache);
 */
typedef struct impostor_cache_options_ext {
  size_t size; /* sizeof(impostor_cache_options_ext); set by _init */
  /* What a local hit checks: an impostor_hit_verification. Default
   * IMPOSTOR_HIT_VERIFY_DIGEST_ONCE_PER_PROCESS; 0..2. */
  int32_t hit_verification;
  /* Threads that answer impostor_cache_get_async from disk (hit checks,
   * hashing included). Default 2; 1..64. */
  int32_t io_threads;
  /* Partial downloads (kept so that a broken download resumes where it
   * stopped, also after a restart) untouched for longer than this many
   * seconds are deleted when the cache opens; one a download is using, in
   * any process, never is. Default 604800 (7 days); >= 0 (0 deletes every
   * one not in use). */
  double partial_max_age_seconds;
  /* Releases (CacheOptions::mirrors, channel, catalog_refresh_seconds,
   * catalog_public_key_file, mirror_ca_file; impostor/cache.h). `mirrors`:
   * base URLs of published release trees, comma-separated, tried in order
   * ("https://cdn.example.com/impostors,https://origin.example.com/impostors");
   * with `channel`, impostor_cache_get and the prefetches also take asset
   * names ("trees/oak"). With mirrors, options->server may be NULL or ""
   * (no farm). NULL = not given; catalog_refresh_seconds default 60,
   * 0..86400. Added after partial_max_age_seconds: read only when `size`
   * covers them. */
  const char* mirrors;
  const char* channel;
  double catalog_refresh_seconds;
  const char* catalog_public_key_file;
  const char* mirror_ca_file;
  /* The farm's HTTP front end (CacheOptions::farm_http): a miss downloads a
   * result's large files from it, verified, and over gRPC what it cannot
   * give intact. "http://bake.example.com:8080" or an https:// proxy; NULL
   * = $IMPOSTOR_FARM_HTTP, else none; "none" = none. Added after
   * mirror_ca_file: read only when `size` covers it. */
  const char* farm_http;
} impostor_cache_options_ext;

IMPOSTOR_C_EXPORT void impostor_cache_options_ext_init(impostor_cache_options_ext* ext);

/* impostor_cache_open with the settings of `ext` too; `ext` NULL = their
 * defaults (impostor_cache_open). IMPOSTOR_INVALID_ARGUMENT naming the
 * field for a value out of range, and for an ext->size smaller than this
 * struct's first version (ext not initialised). */
IMPOSTOR_C_EXPORT impostor_status impostor_cache_open_ext(const impostor_cache_options* options,
                                                          const impostor_cache_options_ext* ext,
                                                          impostor_cache** out);

/* Cancels pending downloads (their callbacks get IMPOSTOR_CANCELLED), waits
 * for callbacks running on other threads, and frees the cache. NULL is a
 * no-op. May be called from inside impostor_cache_get_async's callback (a
 * program that shuts the cache down once its last request is answered):
 * the cache is closed when it returns, the callback goes on, and the
 * cache's thread it runs on ends once it returns. */
IMPOSTOR_C_EXPORT void impostor_cache_close(impostor_cache* cache);

/* Blocking Get: the result under the 64-hex-character key (or, with a
 * release channel configured, an asset name), from disk or downloaded. On success *out must be released with impostor_result_release. */
IMPOSTOR_C_EXPORT impostor_status impostor_cache_get(impostor_cache* cache, const char* key, impostor_result** out);

/* Non-blocking Get: `done` is called once, on a cache thread, with the
 * status, the result (NULL unless IMPOSTOR_OK; the callee owns it and must
 * release it) and `user_data`. The error message is available through
 * impostor_last_error() inside the callback. */
typedef void (*impostor_get_callback)(impostor_status status, impostor_result* result, void* user_data);
IMPOSTOR_C_EXPORT void impostor_cache_get_async(impostor_cache* cache, const char* key, impostor_get_callback done, void* user_data);

/* Background download of `count` keys; keys already cached are skipped. */
IMPOSTOR_C_EXPORT void impostor_cache_prefetch(impostor_cache* cache, const char* const* keys, size_t count);

/* Prefetch for streaming (Cache::Prefetch(names, priority)): keys or asset
 * names, higher `priority` first; prefetching a name again re-prioritises
 * it. impostor_cache_cancel_prefetch drops those no longer wanted (queued
 * ones at once, running ones keep their bytes for a resume) and returns how
 * many it cancelled. */
IMPOSTOR_C_EXPORT void impostor_cache_prefetch_priority(impostor_cache* cache, const char* const* names, size_t count,
                                                        int32_t priority);
IMPOSTOR_C_EXPORT int32_t impostor_cache_cancel_prefetch(impostor_cache* cache, const char* const* names,
                                                         size_t count);

/* The key of an already-baked result for a model and settings, without
 * baking: `layout` "octahedral", "hemi-octahedral", "azimuth-elevation",
 * "ring-top" or "billboard" (NULL = default), `frames` and `resolution` 0 =
 * server default, every other setting its default. Writes 64 hex characters
 * and a NUL into key_out (65 bytes) and whether it is baked into *found. */
IMPOSTOR_C_EXPORT impostor_status impostor_cache_lookup(impostor_cache* cache, const char* model_path, const char* layout,
                                      uint32_t frames, uint32_t resolution, char key_out[65], int* found);

/* The settings of a bake as impostor_cache_lookup_settings takes them (the
 * C view of impostor::sdk::BakeSettings, impostor/client.h): NULL, 0 and -1
 * mean the server's default. Initialise with impostor_bake_settings_init,
 * then set what differs: `size` lets a later library add fields without
 * breaking a caller built against this header. */
typedef struct impostor_bake_settings {
  size_t size;            /* sizeof(impostor_bake_settings); set by _init */
  const char* layout;     /* as impostor_cache_lookup's; NULL = "octahedral" */
  uint32_t frames;        /* 0 = default (12; azimuth-elevation 11) */
  uint32_t resolution;    /* 0 = default (2048) */
  uint32_t ring_views;    /* ring-top only; 0 = default (24) */
  uint32_t supersampling; /* 0 = default (2) */
  const char* product;    /* "atlas", "surfels", "lod-chain" or "cards"; NULL = "atlas" */
  const char* preset;     /* surfels only; NULL = default ("vegetation") */
  uint32_t point_budget;  /* surfels only; 0 = from the preset */
  int32_t quality_views;  /* atlas and lod-chain: -1 = default (16), 0 = no quality pass */
} impostor_bake_settings;
IMPOSTOR_C_EXPORT void impostor_bake_settings_init(impostor_bake_settings* settings);
/* impostor_cache_lookup for any settings. INVALID_ARGUMENT for a NULL
 * argument or a `size` smaller than the first version's. */
IMPOSTOR_C_EXPORT impostor_status impostor_cache_lookup_settings(impostor_cache* cache, const char* model_path,
                                               const impostor_bake_settings* settings, char key_out[65],
                                               int* found);

/* Accessors; valid until impostor_result_release. */
IMPOSTOR_C_EXPORT const char* impostor_result_key(const impostor_result* result);
IMPOSTOR_C_EXPORT const char* impostor_result_dir(const impostor_result* result);
IMPOSTOR_C_EXPORT const char* impostor_result_manifest_path(const impostor_result* result);
/* Map images then manifest.json. */
IMPOSTOR_C_EXPORT size_t impostor_result_file_count(const impostor_result* result);
IMPOSTOR_C_EXPORT const char* impostor_result_file_path(const impostor_result* result, size_t index);
IMPOSTOR_C_EXPORT const char* impostor_result_file_semantic(const impostor_result* result, size_t index);
/* The path of the map with `semantic` ("albedo_alpha", "normal_depth",
 * "orm"), or NULL. */
IMPOSTOR_C_EXPORT const char* impostor_result_map_path(const impostor_result* result, const char* semantic);
IMPOSTOR_C_EXPORT int64_t impostor_result_size_bytes(const impostor_result* result);
/* The manifest's `product` ("atlas", "surfels", "cards", "lod-chain"),
 * `layout`, `frames` (the grid side for ring-top and billboard),
 * `resolution` and number of `views`: what the runtime math needs
 * (impostor/runtime.h, AtlasLayoutFromManifest). */
IMPOSTOR_C_EXPORT const char* impostor_result_product(const impostor_result* result);
IMPOSTOR_C_EXPORT const char* impostor_result_layout(const impostor_result* result);
IMPOSTOR_C_EXPORT uint32_t impostor_result_frames(const impostor_result* result);
IMPOSTOR_C_EXPORT uint32_t impostor_result_resolution(const impostor_result* result);
IMPOSTOR_C_EXPORT uint32_t impostor_result_view_count(const impostor_result* result);
/* 1 when the maps are texture arrays (one layer per view, see
 * CachedResult::texture_array in impostor/cache.h), 0 for atlases. */
IMPOSTOR_C_EXPORT int impostor_result_texture_array(const impostor_result* result);
/* 1 when this Get downloaded it, 0 when it came from disk. */
IMPOSTOR_C_EXPORT int impostor_result_downloaded(const impostor_result* result);
IMPOSTOR_C_EXPORT void impostor_result_release(impostor_result* result);

/* The SDK's log lines (impostor/log.h): a damaged cache entry fetched again
 * or an unreadable one dropped (IMPOSTOR_LOG_WARNING), retries, resumed
 * downloads and failovers (IMPOSTOR_LOG_DEBUG). By default they go to
 * stderr at IMPOSTOR_LOG_WARNING and above. */
typedef enum impostor_log_level {
  IMPOSTOR_LOG_DEBUG = 0,
  IMPOSTOR_LOG_INFO = 1,
  IMPOSTOR_LOG_WARNING = 2,
  IMPOSTOR_LOG_ERROR = 3,
  IMPOSTOR_LOG_OFF = 4 /* as min_level: no line at all */
} impostor_log_level;

/* Receives one line: its level (an impostor_log_level, never
 * IMPOSTOR_LOG_OFF), its text (no timestamp, no trailing newline;
 * valid only during the call) and the `user` pointer given with it. */
typedef void (*impostor_log_fn)(int level, const char* message, void* user);

/* Sends every SDK line at `min_level` or above to `fn` instead of stderr;
 * `fn` NULL restores stderr (with `min_level` still applying:
 * impostor_set_log_handler(NULL, IMPOSTOR_LOG_OFF, NULL) silences the SDK,
 * (NULL, IMPOSTOR_LOG_WARNING, NULL) is the default). Process-wide, for
 * every cache, and may be called at any time from any thread, before
 * impostor_cache_open too. IMPOSTOR_INVALID_ARGUMENT (and no change) for a
 * min_level outside IMPOSTOR_LOG_DEBUG..IMPOSTOR_LOG_OFF.
 *
 * `fn` is called on whichever thread logs, often a cache thread, one call
 * at a time. Once this function returns, the handler it replaced is not
 * running and is never called again (so its `user` data may be freed then),
 * unless it is called from inside that handler. `fn` must not wait for a
 * thread that logs or calls impostor_set_log_handler (so no blocking call
 * such as impostor_cache_get from inside it), should return quickly, and
 * must not unwind (a C# or Rust callback must catch its own exceptions or
 * panics). */
IMPOSTOR_C_EXPORT impostor_status impostor_set_log_handler(impostor_log_fn fn, int min_level, void* user);

/* "OK", "NOT_FOUND", ... for a status code. */
IMPOSTOR_C_EXPORT const char* impostor_status_name(impostor_status status);
/* The message of the last failed call on this thread ("" if none). */
IMPOSTOR_C_EXPORT const char* impostor_last_error(void);

#ifdef __cplusplus
}
#endif

#endif /* IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_IMPOSTOR_C_H_ */
