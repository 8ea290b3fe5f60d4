#include "worker/scratch_space.h"

#include <sys/stat.h>
#include <sys/statvfs.h>

#include <cerrno>
#include <cstring>
#include <set>
#include <string>
#include <system_error>
#include <utility>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

// The payload that marks ShortOnThisWorker: the code alone cannot say it
// (UNAVAILABLE is also a server outage, or memory that is taken now).
constexpr char kShortOnThisWorkerPayload[] = "type.impostor.dev/worker.ScratchShortOnThisWorker";

std::string WhatNeedsIt(const ScratchDemand& demand) {
  return absl::StrCat("(", demand.blob_count, demand.blob_count == 1 ? " distinct blob" : " distinct blobs",
                      " under ", demand.path_count, demand.path_count == 1 ? " path)" : " paths)");
}

// One resource (bytes or inodes) against its capacity and what is free.
absl::Status CheckOne(const char* unit, int64_t needed, int64_t capacity, int64_t available,
                      const ScratchDemand& demand, const fs::path& dir) {
  const std::string need = absl::StrCat("inputs need ", needed, " ", unit, " ", WhatNeedsIt(demand));
  if (needed > capacity) {
    return absl::ResourceExhaustedError(absl::StrCat(
        need, " but the worker's scratch ", dir.string(), " holds ", capacity, " ", unit, " in all (", available,
        " available): the job cannot fit on this worker; send smaller inputs or give the workers a larger --scratch"));
  }
  if (needed > available) {
    return ShortOnThisWorker(absl::StrCat(need, " but the worker's scratch ", dir.string(), " has ", available,
                                               " of its ", capacity, " ", unit,
                                               " available (other files hold the rest): another worker may take it"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ShortOnThisWorker(const std::string& message) {
  absl::Status status = absl::UnavailableError(message);
  status.SetPayload(kShortOnThisWorkerPayload, absl::Cord());
  return status;
}

bool IsShortOnThisWorker(const absl::Status& status) {
  return status.GetPayload(kShortOnThisWorkerPayload).has_value();
}

absl::StatusOr<ScratchSpace> MeasureScratch(const fs::path& dir) {
  struct statvfs st {};
  if (::statvfs(dir.c_str(), &st) != 0) {
    return absl::InternalError(absl::StrCat("cannot measure the scratch folder ", dir.string(), ": ",
                                            std::strerror(errno)));
  }
  const auto frsize = static_cast<int64_t>(st.f_frsize);
  // Blocks only root may use are not the worker's to count on.
  const auto reserved_blocks = static_cast<int64_t>(st.f_bfree) - static_cast<int64_t>(st.f_bavail);
  const auto reserved_inodes = static_cast<int64_t>(st.f_ffree) - static_cast<int64_t>(st.f_favail);
  return ScratchSpace{
      .capacity_bytes = (static_cast<int64_t>(st.f_blocks) - reserved_blocks) * frsize,
      .available_bytes = static_cast<int64_t>(st.f_bavail) * frsize,
      .block_bytes = frsize > 0 ? frsize : 4096,
      .capacity_inodes = static_cast<int64_t>(st.f_files) - reserved_inodes,
      .available_inodes = static_cast<int64_t>(st.f_favail),
  };
}

absl::Status CheckInputsFit(const ScratchDemand& demand, const ScratchSpace& space, const fs::path& dir) {
  if (auto s = CheckOne("bytes", demand.bytes, space.capacity_bytes, space.available_bytes, demand, dir); !s.ok()) {
    return s;
  }
  if (space.capacity_inodes <= 0) return absl::OkStatus();
  return CheckOne("inodes", demand.inodes, space.capacity_inodes, space.available_inodes, demand, dir);
}

ScratchHeld BytesHeldUnder(const fs::path& dir) {
  ScratchHeld held;
  std::set<std::pair<dev_t, ino_t>> seen;
  auto count = [&](const fs::path& p) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0 || !seen.emplace(st.st_dev, st.st_ino).second) return;
    held.bytes += static_cast<int64_t>(st.st_blocks) * 512;  // st_blocks is in 512-byte units
    ++held.inodes;
  };
  count(dir);
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec), end;
       !ec && it != end; it.increment(ec)) {
    count(it->path());
  }
  return held;
}

}  // namespace impostor
