// The C API's options (impostor/impostor_c.h) and their extension
// (impostor_cache_options_ext): defaults mirror CacheOptions, and
// out-of-range values are refused naming the field.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "impostor/cache.h"
#include "impostor/impostor_c.h"

namespace {

namespace fs = std::filesystem;

TEST(CApiOptions, DefaultsMirrorCacheOptions) {
  impostor_cache_options o;
  impostor_cache_options_init(&o);
  const impostor::sdk::CacheOptions defaults;
  EXPECT_EQ(o.max_outage_seconds, defaults.max_outage_seconds);
  EXPECT_EQ(o.max_outage_seconds, 30);
  EXPECT_EQ(o.max_attempts, defaults.max_attempts);
  EXPECT_EQ(o.rpc_timeout_seconds, defaults.rpc_timeout_seconds);
  EXPECT_EQ(o.keepalive_seconds, defaults.keepalive_seconds);
  EXPECT_EQ(o.keepalive_seconds, 20);
  // Identity (issue 14): no token unless given (then $IMPOSTOR_TOKEN).
  EXPECT_EQ(o.token_file, nullptr);
  EXPECT_EQ(o.token, nullptr);
}

TEST(CApiOptions, OutageBudgetIsChecked) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_c_api_options_" + std::to_string(::getpid()));
  const std::string dir_string = dir.string();
  struct Case {
    const char* name;
    double max_outage_seconds;
    impostor_status expected;
  };
  for (const Case& c : {Case{"negative", -1, IMPOSTOR_INVALID_ARGUMENT},
                        Case{"over a day", 86401, IMPOSTOR_INVALID_ARGUMENT}, Case{"zero", 0, IMPOSTOR_OK},
                        Case{"a day", 86400, IMPOSTOR_OK}}) {
    impostor_cache_options o;
    impostor_cache_options_init(&o);
    o.dir = dir_string.c_str();
    o.max_outage_seconds = c.max_outage_seconds;
    impostor_cache* cache = nullptr;
    EXPECT_EQ(impostor_cache_open(&o, &cache), c.expected) << c.name << ": " << impostor_last_error();
    if (c.expected != IMPOSTOR_OK) {
      EXPECT_EQ(cache, nullptr) << c.name;
      EXPECT_NE(std::string(impostor_last_error()).find("max_outage_seconds"), std::string::npos)
          << c.name << ": " << impostor_last_error();
    }
    impostor_cache_close(cache);
  }
  fs::remove_all(dir);
}

TEST(CApiOptions, KeepaliveIsChecked) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_c_api_keepalive_" + std::to_string(::getpid()));
  const std::string dir_string = dir.string();
  for (int32_t seconds : {0, -1, 7201}) {
    impostor_cache_options o;
    impostor_cache_options_init(&o);
    o.dir = dir_string.c_str();
    o.keepalive_seconds = seconds;
    impostor_cache* cache = nullptr;
    EXPECT_EQ(impostor_cache_open(&o, &cache), IMPOSTOR_INVALID_ARGUMENT) << seconds;
    EXPECT_EQ(cache, nullptr);
    EXPECT_EQ(std::string(impostor_last_error()),
              "CacheOptions.keepalive_seconds: " + std::to_string(seconds) + " is out of range 1..7200 (seconds)");
    impostor_cache_close(cache);
  }
  for (int32_t seconds : {1, 7200}) {
    impostor_cache_options o;
    impostor_cache_options_init(&o);
    o.dir = dir_string.c_str();
    o.keepalive_seconds = seconds;
    impostor_cache* cache = nullptr;
    EXPECT_EQ(impostor_cache_open(&o, &cache), IMPOSTOR_OK) << seconds << ": " << impostor_last_error();
    impostor_cache_close(cache);
  }
  fs::remove_all(dir);
}

// impostor_cache_options_ext (hit_verification, io_threads,
// partial_max_age_seconds): what the C API lacked of CacheOptions.
TEST(CApiOptionsExt, DefaultsMirrorCacheOptions) {
  impostor_cache_options_ext ext;
  impostor_cache_options_ext_init(&ext);
  const impostor::sdk::CacheOptions defaults;
  EXPECT_EQ(ext.size, sizeof(impostor_cache_options_ext));
  EXPECT_EQ(ext.hit_verification, static_cast<int32_t>(defaults.hit_verification));
  EXPECT_EQ(ext.hit_verification, IMPOSTOR_HIT_VERIFY_DIGEST_ONCE_PER_PROCESS);
  EXPECT_EQ(ext.io_threads, defaults.io_threads);
  EXPECT_EQ(ext.io_threads, 2);
  EXPECT_EQ(ext.partial_max_age_seconds, defaults.partial_max_age_seconds);
  EXPECT_EQ(ext.partial_max_age_seconds, 7 * 24 * 3600);
}

TEST(CApiOptionsExt, ValuesAreCheckedNamingTheField) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_c_api_ext_" + std::to_string(::getpid()));
  const std::string dir_string = dir.string();
  struct Case {
    const char* name;
    void (*set)(impostor_cache_options_ext*);
    impostor_status expected;
    const char* error;  // the start of impostor_last_error() when refused
  };
  const Case cases[] = {
      {"defaults", [](impostor_cache_options_ext*) {}, IMPOSTOR_OK, ""},
      {"metadata", [](impostor_cache_options_ext* e) { e->hit_verification = IMPOSTOR_HIT_VERIFY_METADATA; },
       IMPOSTOR_OK, ""},
      {"every get", [](impostor_cache_options_ext* e) { e->hit_verification = IMPOSTOR_HIT_VERIFY_DIGEST_EVERY_GET; },
       IMPOSTOR_OK, ""},
      {"hit_verification -1", [](impostor_cache_options_ext* e) { e->hit_verification = -1; },
       IMPOSTOR_INVALID_ARGUMENT,
       "impostor_cache_options_ext.hit_verification: -1 is not an impostor_hit_verification (0..2)"},
      {"hit_verification 3", [](impostor_cache_options_ext* e) { e->hit_verification = 3; },
       IMPOSTOR_INVALID_ARGUMENT,
       "impostor_cache_options_ext.hit_verification: 3 is not an impostor_hit_verification (0..2)"},
      {"one io thread", [](impostor_cache_options_ext* e) { e->io_threads = 1; }, IMPOSTOR_OK, ""},
      {"64 io threads", [](impostor_cache_options_ext* e) { e->io_threads = 64; }, IMPOSTOR_OK, ""},
      {"no io thread", [](impostor_cache_options_ext* e) { e->io_threads = 0; }, IMPOSTOR_INVALID_ARGUMENT,
       "CacheOptions.io_threads: must be in 1..64, got 0"},
      {"65 io threads", [](impostor_cache_options_ext* e) { e->io_threads = 65; }, IMPOSTOR_INVALID_ARGUMENT,
       "CacheOptions.io_threads: must be in 1..64, got 65"},
      {"partials kept for 0 s", [](impostor_cache_options_ext* e) { e->partial_max_age_seconds = 0; }, IMPOSTOR_OK,
       ""},
      {"negative partial age", [](impostor_cache_options_ext* e) { e->partial_max_age_seconds = -1; },
       IMPOSTOR_INVALID_ARGUMENT, "CacheOptions.partial_max_age_seconds: must be >= 0, got -1"},
      {"not initialised", [](impostor_cache_options_ext* e) { e->size = sizeof(size_t); }, IMPOSTOR_INVALID_ARGUMENT,
       "impostor_cache_open_ext: ext->size is 8, at least "},
  };
  for (const Case& c : cases) {
    impostor_cache_options o;
    impostor_cache_options_init(&o);
    o.dir = dir_string.c_str();
    impostor_cache_options_ext ext;
    impostor_cache_options_ext_init(&ext);
    c.set(&ext);
    impostor_cache* cache = nullptr;
    EXPECT_EQ(impostor_cache_open_ext(&o, &ext, &cache), c.expected) << c.name << ": " << impostor_last_error();
    if (c.expected != IMPOSTOR_OK) {
      EXPECT_EQ(cache, nullptr) << c.name;
      EXPECT_EQ(std::string(impostor_last_error()).rfind(c.error, 0), 0u) << c.name << ": " << impostor_last_error();
    }
    impostor_cache_close(cache);
  }
  // No ext at all: every one of its settings at its default.
  impostor_cache_options o;
  impostor_cache_options_init(&o);
  o.dir = dir_string.c_str();
  impostor_cache* cache = nullptr;
  EXPECT_EQ(impostor_cache_open_ext(&o, nullptr, &cache), IMPOSTOR_OK) << impostor_last_error();
  impostor_cache_close(cache);
  fs::remove_all(dir);
}

// partial_max_age_seconds reaches the cache: a partial download an hour old
// outlives an open with the default (7 days) and not one with a minute.
TEST(CApiOptionsExt, PartialMaxAgeSecondsDecidesWhichPartialsAnOpenDeletes) {
  const fs::path dir = fs::temp_directory_path() / ("impostor_c_api_partials_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string dir_string = dir.string();
  const fs::path partial = dir / "partial" / (std::string(64, 'a') + "-1000.part");
  fs::create_directories(partial.parent_path());
  std::ofstream(partial) << std::string(500, 'x');
  fs::last_write_time(partial, fs::file_time_type::clock::now() - std::chrono::hours(1));

  auto open_and_close = [&](double partial_max_age_seconds) {
    impostor_cache_options o;
    impostor_cache_options_init(&o);
    o.dir = dir_string.c_str();
    impostor_cache_options_ext ext;
    impostor_cache_options_ext_init(&ext);
    if (partial_max_age_seconds >= 0) ext.partial_max_age_seconds = partial_max_age_seconds;
    impostor_cache* cache = nullptr;
    EXPECT_EQ(impostor_cache_open_ext(&o, &ext, &cache), IMPOSTOR_OK) << impostor_last_error();
    impostor_cache_close(cache);
  };
  open_and_close(-1);  // the default
  EXPECT_TRUE(fs::exists(partial)) << "an hour-old partial is deleted after 7 days only";
  open_and_close(60);
  EXPECT_FALSE(fs::exists(partial)) << "an hour-old partial is stale after a minute";
  fs::remove_all(dir);
}

}  // namespace
