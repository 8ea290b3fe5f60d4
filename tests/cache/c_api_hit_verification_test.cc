// impostor_cache_options_ext.hit_verification reaches the cache: a map
// rewritten in place with its modification time put back (so that size,
// inode and mtime still match) is served as it is under
// IMPOSTOR_HIT_VERIFY_METADATA and DIGEST_ONCE_PER_PROCESS (the result was
// hashed once already, as it was installed), and caught and fetched again
// under DIGEST_EVERY_GET. Against a real impostor-server.
#include <fcntl.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "impostor/impostor_c.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

// Rewrites the byte at `at` of `path` in place, then puts the file's
// modification time back: only hashing can tell.
void DamageKeepingMetadata(const fs::path& path, std::streamoff at = 100) {
  struct stat before;
  ASSERT_EQ(::stat(path.c_str(), &before), 0);
  fs::permissions(path, fs::perms::owner_write, fs::perm_options::add);
  {
    std::fstream io(path, std::ios::in | std::ios::out | std::ios::binary);
    io.seekg(at);
    char c = 0;
    io.get(c);
    io.seekp(at);
    io.put(static_cast<char>(c ^ 0x20));
  }
  const struct timespec times[2] = {before.st_atim, before.st_mtim};
  ASSERT_EQ(::utimensat(AT_FDCWD, path.c_str(), times, 0), 0);
  fs::permissions(path, fs::perms(before.st_mode) & fs::perms::mask, fs::perm_options::replace);
}

TEST(CApiHitVerification, OnlyDigestEveryGetCatchesAMapRewrittenInPlace) {
  ServerProcess server(0);
  const std::string address = server.address();
  struct Case {
    const char* name;
    impostor_hit_verification verification;
    bool caught;  // the second get fetched the result again
  };
  uint32_t seed = 90;
  for (const Case& c : {Case{"metadata", IMPOSTOR_HIT_VERIFY_METADATA, false},
                        Case{"digest once per process", IMPOSTOR_HIT_VERIFY_DIGEST_ONCE_PER_PROCESS, false},
                        Case{"digest every get", IMPOSTOR_HIT_VERIFY_DIGEST_EVERY_GET, true}}) {
    const PublishedResult published = PublishResult(server, {32 << 10, 16 << 10, 8 << 10}, seed++);
    const fs::path dir = NewTempDir(std::string("c_api_hit_") + std::to_string(seed));
    const std::string dir_text = dir.string();
    impostor_cache_options options;
    impostor_cache_options_init(&options);
    options.server = address.c_str();
    options.dir = dir_text.c_str();
    impostor_cache_options_ext ext;
    impostor_cache_options_ext_init(&ext);
    ext.hit_verification = c.verification;
    impostor_cache* cache = nullptr;
    ASSERT_EQ(impostor_cache_open_ext(&options, &ext, &cache), IMPOSTOR_OK) << c.name << ": " << impostor_last_error();

    impostor_result* first = nullptr;
    ASSERT_EQ(impostor_cache_get(cache, published.key.c_str(), &first), IMPOSTOR_OK)
        << c.name << ": " << impostor_last_error();
    EXPECT_EQ(impostor_result_downloaded(first), 1) << c.name;
    const fs::path albedo = impostor_result_map_path(first, "albedo_alpha");
    impostor_result_release(first);
    DamageKeepingMetadata(albedo);

    impostor_result* second = nullptr;
    ASSERT_EQ(impostor_cache_get(cache, published.key.c_str(), &second), IMPOSTOR_OK)
        << c.name << ": " << impostor_last_error();
    EXPECT_EQ(impostor_result_downloaded(second), c.caught ? 1 : 0) << c.name;
    const bool intact = ReadFileBytes(impostor_result_map_path(second, "albedo_alpha")) ==
                        published.files.at("albedo_alpha.png");
    EXPECT_EQ(intact, c.caught) << c.name << ": the map served is the damaged one unless hashing caught it";
    impostor_result_release(second);
    impostor_cache_close(cache);
    fs::remove_all(dir);
  }
}

}  // namespace
}  // namespace impostor::testing
