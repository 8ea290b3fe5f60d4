// The C API's options (impostor/impostor_c.h): defaults mirror CacheOptions,
// and out-of-range values are refused naming the field.
#include <unistd.h>

#include <filesystem>
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

}  // namespace
