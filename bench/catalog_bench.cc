// catalog_bench: what reading a release's catalog costs a game client
// (issue 40). A game resolves asset names through its channel's catalog,
// fetched at start and again whenever the channel moves; a shipped game's
// catalog lists every impostor of the build (thousands), so its parse is
// start-up time and peak memory on a player's machine. Builds a catalog of
// --assets assets (4 files each, as a hemi-octahedral atlas result), then
// times ParseCatalog on it. Not a test: nothing is asserted.
//
//   catalog_bench [--assets N] [--reps R]
#include <malloc.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "bench/bench_args.h"
#include "bench/median_time.h"
#include "client/delivery/catalog.h"

namespace {

using impostor::delivery::Catalog;
using impostor::delivery::CatalogAsset;
using impostor::delivery::CatalogFile;

// 64 hex characters from `seed` (xorshift: digests need only look real).
std::string FakeDigest(uint64_t seed) {
  std::string hex;
  uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
  for (int i = 0; i < 64; ++i) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    hex.push_back("0123456789abcdef"[x & 15]);
  }
  return hex;
}

Catalog MakeCatalog(int assets) {
  Catalog catalog;
  catalog.schema_version = 1;
  catalog.created_at = "2026-12-03T00:00:00Z";
  catalog.baker_version = "0.2.0";
  const char* names[] = {"albedo_alpha.png", "normal_depth.png", "orm.png", "manifest.json"};
  for (int i = 0; i < assets; ++i) {
    CatalogAsset a;
    a.cache_key = FakeDigest(8 * i);
    a.product = "atlas";
    a.layout = "hemi-octahedral";
    a.frames = 12;
    a.resolution = 2048;
    a.baker_version = "0.2.0";
    a.manifest_sha256 = FakeDigest(8 * i + 1);
    a.manifest_size_bytes = 4000;
    for (int f = 0; f < 4; ++f) {
      CatalogFile file;
      file.name = names[f];
      file.semantic = f == 3 ? "manifest" : "map";
      file.sha256 = f == 3 ? a.manifest_sha256 : FakeDigest(8 * i + 2 + f);
      file.size_bytes = f == 3 ? a.manifest_size_bytes : 1 << 20;
      file.media_type = f == 3 ? "application/json" : "image/png";
      file.width = f == 3 ? 0 : 2048;
      file.height = file.width;
      file.format = f == 3 ? "json" : "rgba8";
      a.files.push_back(std::move(file));
    }
    catalog.assets.emplace(absl::StrCat("forest/tree_", i), std::move(a));
  }
  return catalog;
}

// The process's resident set: now, or its peak since ResetPeakRss.
double RssMb(const char* field) {
  std::FILE* f = std::fopen("/proc/self/status", "r");
  if (f == nullptr) return 0;
  char line[256];
  double kb = 0;
  while (std::fgets(line, sizeof line, f) != nullptr) {
    if (std::strncmp(line, field, std::strlen(field)) == 0) kb = std::atof(line + std::strlen(field));
  }
  std::fclose(f);
  return kb / 1024.0;
}

// Gives freed memory back and restarts the peak from what is resident now
// (Linux: "5" to clear_refs resets VmHWM), so the peak measures one parse.
void ResetPeakRss() {
  ::malloc_trim(0);
  if (std::FILE* f = std::fopen("/proc/self/clear_refs", "w")) {
    std::fputs("5", f);
    std::fclose(f);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int assets = 10000;
  int reps = 5;
  impostor::bench::BenchArgs("catalog_bench", "ParseCatalog's time and memory on a release catalog of N assets")
      .Int("--assets", &assets, "assets in the catalog, 4 files each (default 10000)")
      .Int("--reps", &reps, "parses timed; the median is printed (default 5)")
      .ParseOrExit(argc, argv);
  const std::string text = impostor::delivery::CatalogToJson(MakeCatalog(assets));
  size_t parsed = 0;
  const double seconds = impostor::bench::MedianSeconds(reps, [&] {
    absl::StatusOr<Catalog> catalog = impostor::delivery::ParseCatalog(text, "catalog_bench");
    if (!catalog.ok()) {
      std::fprintf(stderr, "catalog_bench: %s\n", catalog.status().ToString().c_str());
      std::exit(1);
    }
    parsed = catalog->assets.size();
  });
  // Memory: one more parse from a trimmed heap, its result kept; the
  // result's own size is what stays resident once the heap is trimmed again.
  ResetPeakRss();
  const double before = RssMb("VmRSS:");
  absl::StatusOr<Catalog> kept = impostor::delivery::ParseCatalog(text, "catalog_bench");
  const double peak = RssMb("VmHWM:") - before;
  ::malloc_trim(0);
  const double result = RssMb("VmRSS:") - before;
  std::printf("catalog_bench: %zu assets, %.2f MB of JSON: ParseCatalog median %.1f ms (%.0f MB/s) over %d runs; "
              "resident memory +%.0f MB at the parse's peak, +%.0f MB for the parsed catalog\n",
              parsed, static_cast<double>(text.size()) / 1e6, seconds * 1e3,
              static_cast<double>(text.size()) / 1e6 / seconds, reps, peak, result);
  return 0;
}
