// The C API (impostor/impostor_c.h): a thin shim over impostor::sdk::Cache.
// Every C object wraps its C++ counterpart; strings handed out are owned by
// the result object. Errors are also kept per thread for impostor_last_error.
#include "impostor/impostor_c.h"

#include <cstddef>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "impostor/cache.h"
#include "impostor/log.h"

struct impostor_cache {
  std::unique_ptr<impostor::sdk::Cache> cache;
};

struct impostor_result {
  impostor::sdk::CachedResult result;
  // C strings of the paths (std::filesystem::path::c_str() is char on Linux,
  // but these copies keep the API independent of that).
  std::string dir;
  std::string manifest_path;
  std::vector<std::string> file_paths;
};

namespace {

// impostor_log_level is impostor::sdk::LogLevel.
static_assert(static_cast<int>(impostor::sdk::LogLevel::kDebug) == IMPOSTOR_LOG_DEBUG);
static_assert(static_cast<int>(impostor::sdk::LogLevel::kInfo) == IMPOSTOR_LOG_INFO);
static_assert(static_cast<int>(impostor::sdk::LogLevel::kWarning) == IMPOSTOR_LOG_WARNING);
static_assert(static_cast<int>(impostor::sdk::LogLevel::kError) == IMPOSTOR_LOG_ERROR);
static_assert(static_cast<int>(impostor::sdk::LogLevel::kOff) == IMPOSTOR_LOG_OFF);

// impostor_hit_verification is impostor::sdk::HitVerification.
static_assert(static_cast<int>(impostor::sdk::HitVerification::kMetadata) == IMPOSTOR_HIT_VERIFY_METADATA);
static_assert(static_cast<int>(impostor::sdk::HitVerification::kDigestOncePerProcess) ==
              IMPOSTOR_HIT_VERIFY_DIGEST_ONCE_PER_PROCESS);
static_assert(static_cast<int>(impostor::sdk::HitVerification::kDigestEveryGet) ==
              IMPOSTOR_HIT_VERIFY_DIGEST_EVERY_GET);

// The size of impostor_cache_options_ext's first version, which ends with
// partial_max_age_seconds: the least a caller may pass. Fields appended
// later do not change it.
constexpr size_t kFirstOptionsExtSize =
    offsetof(impostor_cache_options_ext, partial_max_age_seconds) + sizeof(double);

thread_local std::string last_error;

impostor_status Report(const absl::Status& status) {
  last_error = status.ok() ? std::string() : std::string(status.message());
  return static_cast<impostor_status>(static_cast<int>(status.code()));
}

impostor_result* Wrap(impostor::sdk::CachedResult result) {
  auto* r = new impostor_result();
  r->dir = result.dir().string();
  r->manifest_path = result.manifest_path().string();
  for (const auto& f : result.files()) r->file_paths.push_back(f.path.string());
  r->result = std::move(result);
  return r;
}

}  // namespace

extern "C" {

void impostor_cache_options_init(impostor_cache_options* options) {
  if (options == nullptr) return;
  static const impostor::sdk::CacheOptions defaults;
  std::memset(options, 0, sizeof(*options));
  options->server = "localhost:50051";
  options->dir = nullptr;
  options->max_bytes = defaults.max_bytes;
  options->max_parallel_downloads = defaults.max_parallel_downloads;
  options->max_parallel_prefetches = defaults.max_parallel_prefetches;
  options->connect_timeout_seconds = defaults.connect_timeout_seconds;
  options->rpc_timeout_seconds = defaults.rpc_timeout_seconds;
  options->max_attempts = defaults.max_attempts;
  options->max_outage_seconds = defaults.max_outage_seconds;
  options->keepalive_seconds = defaults.keepalive_seconds;
  // TLS: off (the memset left the tls_* pointers NULL).
}

impostor_status impostor_cache_open(const impostor_cache_options* options, impostor_cache** out) {
  return impostor_cache_open_ext(options, nullptr, out);
}

void impostor_cache_options_ext_init(impostor_cache_options_ext* ext) {
  if (ext == nullptr) return;
  static const impostor::sdk::CacheOptions defaults;
  *ext = impostor_cache_options_ext{};
  ext->size = sizeof(impostor_cache_options_ext);
  ext->hit_verification = static_cast<int32_t>(defaults.hit_verification);
  ext->io_threads = defaults.io_threads;
  ext->partial_max_age_seconds = defaults.partial_max_age_seconds;
  ext->catalog_refresh_seconds = defaults.catalog_refresh_seconds;
}

impostor_status impostor_cache_open_ext(const impostor_cache_options* options, const impostor_cache_options_ext* ext,
                                        impostor_cache** out) {
  if (options == nullptr || out == nullptr) {
    return Report(absl::InvalidArgumentError("impostor_cache_open: options and out are required"));
  }
  *out = nullptr;
  // Every field of the first version is read; one appended later is read
  // only when ext->size covers it.
  if (ext != nullptr && ext->size < kFirstOptionsExtSize) {
    return Report(absl::InvalidArgumentError(absl::StrCat(
        "impostor_cache_open_ext: ext->size is ", ext->size, ", at least ", kFirstOptionsExtSize,
        " expected (call impostor_cache_options_ext_init first)")));
  }
  impostor::sdk::CacheOptions o;
  if (ext != nullptr) {
    if (ext->hit_verification < IMPOSTOR_HIT_VERIFY_METADATA ||
        ext->hit_verification > IMPOSTOR_HIT_VERIFY_DIGEST_EVERY_GET) {
      return Report(absl::InvalidArgumentError(
          absl::StrCat("impostor_cache_options_ext.hit_verification: ", ext->hit_verification,
                       " is not an impostor_hit_verification (0..2)")));
    }
    o.hit_verification = static_cast<impostor::sdk::HitVerification>(ext->hit_verification);
    o.io_threads = ext->io_threads;
    o.partial_max_age_seconds = ext->partial_max_age_seconds;
    if (ext->size >= offsetof(impostor_cache_options_ext, mirror_ca_file) + sizeof(const char*)) {
      if (ext->mirrors != nullptr) {
        for (absl::string_view m : absl::StrSplit(ext->mirrors, ',', absl::SkipEmpty())) {
          o.mirrors.emplace_back(m);
        }
      }
      if (ext->channel != nullptr) o.channel = ext->channel;
      o.catalog_refresh_seconds = ext->catalog_refresh_seconds;
      if (ext->catalog_public_key_file != nullptr) o.catalog_public_key_file = ext->catalog_public_key_file;
      if (ext->mirror_ca_file != nullptr) o.mirror_ca_file = ext->mirror_ca_file;
    }
    if (ext->size >= offsetof(impostor_cache_options_ext, farm_http) + sizeof(const char*)) {
      if (ext->farm_http != nullptr) o.farm_http = ext->farm_http;
    }
  }
  if (options->server != nullptr) {
    o.server = options->server;
  } else if (!o.mirrors.empty()) {
    o.server.clear();  // a game reading releases only
  }
  if (options->dir != nullptr) o.dir = options->dir;
  o.max_bytes = options->max_bytes;
  o.max_parallel_downloads = options->max_parallel_downloads;
  o.max_parallel_prefetches = options->max_parallel_prefetches;
  o.connect_timeout_seconds = options->connect_timeout_seconds;
  o.rpc_timeout_seconds = options->rpc_timeout_seconds;
  o.max_attempts = options->max_attempts;
  o.max_outage_seconds = options->max_outage_seconds;
  o.keepalive_seconds = options->keepalive_seconds;
  // TLS (see impostor_c.h).
  if (options->tls_ca_file != nullptr) o.tls_ca_file = options->tls_ca_file;
  if (options->tls_cert_file != nullptr) o.tls_cert_file = options->tls_cert_file;
  if (options->tls_key_file != nullptr) o.tls_key_file = options->tls_key_file;
  if (options->tls_server_name != nullptr) o.tls_server_name = options->tls_server_name;
  if (options->token_file != nullptr) o.token_file = options->token_file;
  if (options->token != nullptr) o.token = options->token;
  auto cache = impostor::sdk::Cache::Open(o);
  if (!cache.ok()) return Report(cache.status());
  *out = new impostor_cache{std::move(*cache)};
  return Report(absl::OkStatus());
}

void impostor_cache_close(impostor_cache* cache) { delete cache; }

impostor_status impostor_cache_get(impostor_cache* cache, const char* key, impostor_result** out) {
  if (cache == nullptr || key == nullptr || out == nullptr) {
    return Report(absl::InvalidArgumentError("impostor_cache_get: cache, key and out are required"));
  }
  *out = nullptr;
  auto result = cache->cache->Get(key);
  if (!result.ok()) return Report(result.status());
  *out = Wrap(std::move(*result));
  return Report(absl::OkStatus());
}

void impostor_cache_get_async(impostor_cache* cache, const char* key, impostor_get_callback done, void* user_data) {
  if (done == nullptr) return;
  if (cache == nullptr || key == nullptr) {
    done(Report(absl::InvalidArgumentError("impostor_cache_get_async: cache and key are required")), nullptr,
         user_data);
    return;
  }
  cache->cache->GetAsync(key, [done, user_data](absl::StatusOr<impostor::sdk::CachedResult> result) {
    if (!result.ok()) {
      done(Report(result.status()), nullptr, user_data);
      return;
    }
    impostor_result* wrapped = Wrap(std::move(*result));
    done(Report(absl::OkStatus()), wrapped, user_data);
  });
}

void impostor_cache_prefetch(impostor_cache* cache, const char* const* keys, size_t count) {
  if (cache == nullptr || keys == nullptr) return;
  std::vector<std::string> list;
  for (size_t i = 0; i < count; ++i) {
    if (keys[i] != nullptr) list.emplace_back(keys[i]);
  }
  cache->cache->Prefetch(list);
}

namespace {
std::vector<std::string> Names(const char* const* names, size_t count) {
  std::vector<std::string> list;
  for (size_t i = 0; names != nullptr && i < count; ++i) {
    if (names[i] != nullptr) list.emplace_back(names[i]);
  }
  return list;
}
}  // namespace

void impostor_cache_prefetch_priority(impostor_cache* cache, const char* const* names, size_t count,
                                      int32_t priority) {
  if (cache == nullptr) return;
  cache->cache->Prefetch(Names(names, count), priority);
}

int32_t impostor_cache_cancel_prefetch(impostor_cache* cache, const char* const* names, size_t count) {
  if (cache == nullptr) return 0;
  return cache->cache->CancelPrefetch(Names(names, count));
}

impostor_status impostor_cache_lookup(impostor_cache* cache, const char* model_path, const char* layout,
                                      uint32_t frames, uint32_t resolution, char key_out[65], int* found) {
  impostor_bake_settings settings;
  impostor_bake_settings_init(&settings);
  settings.layout = layout;
  settings.frames = frames;
  settings.resolution = resolution;
  return impostor_cache_lookup_settings(cache, model_path, &settings, key_out, found);
}

void impostor_bake_settings_init(impostor_bake_settings* settings) {
  if (settings == nullptr) return;
  *settings = impostor_bake_settings{};
  settings->size = sizeof(impostor_bake_settings);
  settings->quality_views = -1;
}

impostor_status impostor_cache_lookup_settings(impostor_cache* cache, const char* model_path,
                                               const impostor_bake_settings* settings, char key_out[65],
                                               int* found) {
  if (cache == nullptr || model_path == nullptr || settings == nullptr || key_out == nullptr || found == nullptr) {
    return Report(absl::InvalidArgumentError(
        "impostor_cache_lookup_settings: cache, model_path, settings, key_out, found required"));
  }
  // The first version's fields; a later header's caller may pass more.
  if (settings->size < sizeof(impostor_bake_settings)) {
    return Report(absl::InvalidArgumentError(absl::StrCat(
        "impostor_cache_lookup_settings: settings->size is ", settings->size, ", at least ",
        sizeof(impostor_bake_settings), " expected (call impostor_bake_settings_init first)")));
  }
  impostor::sdk::BakeSettings s;
  if (settings->layout != nullptr) s.layout = settings->layout;
  s.frames = settings->frames;
  s.resolution = settings->resolution;
  if (settings->ring_views != 0) s.ring_views = settings->ring_views;
  if (settings->supersampling != 0) s.supersampling = settings->supersampling;
  if (settings->product != nullptr) s.product = settings->product;
  if (settings->preset != nullptr) s.preset = settings->preset;
  if (settings->point_budget != 0) s.point_budget = settings->point_budget;
  if (settings->quality_views >= 0) s.quality_views = static_cast<uint32_t>(settings->quality_views);
  auto looked = cache->cache->Lookup(model_path, s);
  if (!looked.ok()) return Report(looked.status());
  std::snprintf(key_out, 65, "%s", looked->cache_key.c_str());
  *found = looked->found ? 1 : 0;
  return Report(absl::OkStatus());
}

const char* impostor_result_product(const impostor_result* r) { return r ? r->result.product().c_str() : nullptr; }
const char* impostor_result_layout(const impostor_result* r) { return r ? r->result.layout().c_str() : nullptr; }
uint32_t impostor_result_frames(const impostor_result* r) { return r ? r->result.frames() : 0; }
uint32_t impostor_result_resolution(const impostor_result* r) { return r ? r->result.resolution() : 0; }
uint32_t impostor_result_view_count(const impostor_result* r) { return r ? r->result.view_count() : 0; }
int impostor_result_texture_array(const impostor_result* r) { return r && r->result.texture_array() ? 1 : 0; }

const char* impostor_result_key(const impostor_result* r) { return r ? r->result.key().c_str() : nullptr; }
const char* impostor_result_dir(const impostor_result* r) { return r ? r->dir.c_str() : nullptr; }
const char* impostor_result_manifest_path(const impostor_result* r) { return r ? r->manifest_path.c_str() : nullptr; }
size_t impostor_result_file_count(const impostor_result* r) { return r ? r->file_paths.size() : 0; }

const char* impostor_result_file_path(const impostor_result* r, size_t index) {
  return r && index < r->file_paths.size() ? r->file_paths[index].c_str() : nullptr;
}

const char* impostor_result_file_semantic(const impostor_result* r, size_t index) {
  return r && index < r->result.files().size() ? r->result.files()[index].semantic.c_str() : nullptr;
}

const char* impostor_result_map_path(const impostor_result* r, const char* semantic) {
  if (r == nullptr || semantic == nullptr) return nullptr;
  const auto& files = r->result.files();
  for (size_t i = 0; i < files.size(); ++i) {
    if (files[i].semantic == semantic && files[i].semantic != "manifest") return r->file_paths[i].c_str();
  }
  return nullptr;
}

int64_t impostor_result_size_bytes(const impostor_result* r) { return r ? r->result.size_bytes() : 0; }
int impostor_result_downloaded(const impostor_result* r) { return r && r->result.downloaded() ? 1 : 0; }
void impostor_result_release(impostor_result* r) { delete r; }

impostor_status impostor_set_log_handler(impostor_log_fn fn, int min_level, void* user) {
  if (min_level < IMPOSTOR_LOG_DEBUG || min_level > IMPOSTOR_LOG_OFF) {
    return Report(absl::InvalidArgumentError(absl::StrCat("impostor_set_log_handler: min_level ", min_level,
                                                          " is not an impostor_log_level (0..4)")));
  }
  impostor::sdk::LogHandler handler;
  if (fn != nullptr) {
    handler = [fn, user](impostor::sdk::LogLevel level, std::string_view message) {
      const std::string text(message);  // NUL-terminated for C
      fn(static_cast<int>(level), text.c_str(), user);
    };
  }
  impostor::sdk::SetLogHandler(std::move(handler), static_cast<impostor::sdk::LogLevel>(min_level));
  return Report(absl::OkStatus());
}

const char* impostor_status_name(impostor_status status) {
  switch (static_cast<int>(status)) {
    case 0: return "OK";
    case 1: return "CANCELLED";
    case 2: return "UNKNOWN";
    case 3: return "INVALID_ARGUMENT";
    case 4: return "DEADLINE_EXCEEDED";
    case 5: return "NOT_FOUND";
    case 6: return "ALREADY_EXISTS";
    case 7: return "PERMISSION_DENIED";
    case 8: return "RESOURCE_EXHAUSTED";
    case 9: return "FAILED_PRECONDITION";
    case 10: return "ABORTED";
    case 11: return "OUT_OF_RANGE";
    case 12: return "UNIMPLEMENTED";
    case 13: return "INTERNAL";
    case 14: return "UNAVAILABLE";
    case 15: return "DATA_LOSS";
    case 16: return "UNAUTHENTICATED";
  }
  return "UNKNOWN_CODE";
}

const char* impostor_last_error(void) { return last_error.c_str(); }

}  // extern "C"
