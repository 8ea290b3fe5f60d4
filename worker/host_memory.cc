#include "worker/host_memory.h"

#include <sys/resource.h>

#include <algorithm>
#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace impostor {
namespace fs = std::filesystem;
namespace {

// cgroup v1 writes "no limit" as the largest page-aligned int64.
constexpr int64_t kNoLimitAbove = int64_t{1} << 62;

std::optional<std::string> ReadFile(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The value of "key: N kB" or "key N" in a /proc or memory.stat text, bytes.
std::optional<int64_t> FieldBytes(absl::string_view text, absl::string_view key, int64_t unit) {
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    if (!absl::ConsumePrefix(&line, key)) continue;
    if (!absl::ConsumePrefix(&line, ":") && !absl::ConsumePrefix(&line, " ")) continue;
    line = absl::StripAsciiWhitespace(absl::StripSuffix(absl::StripAsciiWhitespace(line), "kB"));
    int64_t value = 0;
    if (absl::SimpleAtoi(line, &value)) return value * unit;
  }
  return std::nullopt;
}

// A limit file's number; nullopt for "max", a v1 "no limit" or no file.
std::optional<int64_t> LimitIn(const fs::path& file) {
  const std::optional<std::string> text = ReadFile(file);
  int64_t value = 0;
  if (!text || !absl::SimpleAtoi(absl::StripAsciiWhitespace(*text), &value) || value >= kNoLimitAbove) {
    return std::nullopt;
  }
  return value;
}

struct Bound {
  int64_t total = 0;
  int64_t available = 0;
  std::string total_name;
  std::string available_name;
};

// One cgroup hierarchy's files. `stat_key`: the page cache the kernel
// reclaims before it kills (not counted as in use).
struct CgroupFiles {
  const char* limit;
  const char* usage;
  const char* stat_key;
};
constexpr CgroupFiles kCgroupV2{"memory.max", "memory.current", "inactive_file"};
constexpr CgroupFiles kCgroupV1{"memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file"};

// The tightest limit on `dir` and the cgroups above it, up to `root`.
std::optional<Bound> CgroupBound(const fs::path& root, const std::string& path, const CgroupFiles& files) {
  std::optional<Bound> best;
  for (fs::path dir = fs::path(path).relative_path();; dir = dir.parent_path()) {
    const fs::path here = root / dir;
    if (const std::optional<int64_t> limit = LimitIn(here / files.limit); limit && (!best || *limit < best->total)) {
      int64_t used = LimitIn(here / files.usage).value_or(0);
      if (const std::optional<std::string> stat = ReadFile(here / "memory.stat")) {
        used -= FieldBytes(*stat, files.stat_key, 1).value_or(0);
      }
      const std::string name = absl::StrCat("cgroup ", files.limit);
      best = Bound{*limit, *limit - std::max<int64_t>(used, 0), name, absl::StrCat(name, " less ", files.usage)};
    }
    if (dir.empty()) break;
  }
  return best;
}

// The cgroup limits of this process (/proc/self/cgroup: "0::/path" for v2,
// "N:memory:/path" for v1's memory controller).
std::vector<Bound> CgroupBounds(const HostMemorySources& sources) {
  std::vector<Bound> bounds;
  const std::optional<std::string> text = ReadFile(sources.proc / "self/cgroup");
  if (!text) return bounds;
  for (absl::string_view line : absl::StrSplit(*text, '\n', absl::SkipEmpty())) {
    const std::vector<absl::string_view> parts = absl::StrSplit(line, absl::MaxSplits(':', 2));
    if (parts.size() != 3) continue;
    std::optional<Bound> bound;
    if (parts[0] == "0" && parts[1].empty()) {
      // v2 alone at the mount, or beside v1 (hybrid) under "unified".
      const fs::path root = fs::exists(sources.cgroup / "cgroup.controllers") ? sources.cgroup
                                                                               : sources.cgroup / "unified";
      bound = CgroupBound(root, std::string(parts[2]), kCgroupV2);
    } else {
      for (absl::string_view controller : absl::StrSplit(parts[1], ',')) {
        if (controller == "memory") bound = CgroupBound(sources.cgroup / "memory", std::string(parts[2]), kCgroupV1);
      }
    }
    if (bound) bounds.push_back(*bound);
  }
  return bounds;
}

std::optional<Bound> AddressSpaceBound(const HostMemorySources& sources) {
  int64_t limit = sources.address_space_limit;
  if (limit == kAddressSpaceLimitOfProcess) {
    rlimit r{};
    limit = ::getrlimit(RLIMIT_AS, &r) == 0 && r.rlim_cur != RLIM_INFINITY ? static_cast<int64_t>(r.rlim_cur) : 0;
  }
  if (limit <= 0) return std::nullopt;
  const std::optional<std::string> status = ReadFile(sources.proc / "self/status");
  const int64_t in_use = status ? FieldBytes(*status, "VmSize", 1024).value_or(0) : 0;
  return Bound{limit, limit - in_use, "RLIMIT_AS", "RLIMIT_AS less VmSize"};
}

}  // namespace

absl::StatusOr<HostMemory> MeasureHostMemory(const HostMemorySources& sources) {
  const fs::path meminfo_path = sources.proc / "meminfo";
  const std::optional<std::string> meminfo = ReadFile(meminfo_path);
  const std::optional<int64_t> mem_total = meminfo ? FieldBytes(*meminfo, "MemTotal", 1024) : std::nullopt;
  if (!mem_total) return absl::InternalError(absl::StrCat("cannot read MemTotal from ", meminfo_path.string()));
  HostMemory out{.total_bytes = *mem_total,
                 .available_bytes = FieldBytes(*meminfo, "MemAvailable", 1024).value_or(*mem_total),
                 .total_bound = "MemTotal",
                 .available_bound = "MemAvailable"};
  std::vector<Bound> bounds = CgroupBounds(sources);
  if (std::optional<Bound> address_space = AddressSpaceBound(sources)) bounds.push_back(*address_space);
  for (const Bound& b : bounds) {
    if (b.total < out.total_bytes) {
      out.total_bytes = b.total;
      out.total_bound = b.total_name;
    }
    if (b.available < out.available_bytes) {
      out.available_bytes = b.available;
      out.available_bound = b.available_name;
    }
  }
  out.available_bytes = std::clamp<int64_t>(out.available_bytes, 0, out.total_bytes);
  return out;
}

}  // namespace impostor
