#include "server/disk_full.h"

#include <sys/statvfs.h>

#include <cerrno>

#include "absl/strings/str_cat.h"

namespace impostor {

bool IsDiskFull(int error_number) { return error_number == ENOSPC || error_number == EDQUOT; }

int64_t FreeBytes(const std::filesystem::path& path) {
  std::filesystem::path p = path;
  struct statvfs st {};
  // The file itself may not exist (a failed create): ask its folder.
  while (::statvfs(p.c_str(), &st) != 0) {
    if (!p.has_parent_path() || p.parent_path() == p) return -1;
    p = p.parent_path();
  }
  return static_cast<int64_t>(st.f_bavail) * static_cast<int64_t>(st.f_frsize);
}

absl::Status DiskFullError(std::string_view what, const std::filesystem::path& path, std::string_view cause) {
  const int64_t free_bytes = FreeBytes(path);
  const std::string free_text =
      free_bytes < 0 ? "free space unknown" : absl::StrCat(free_bytes, " bytes free on its filesystem");
  return absl::ResourceExhaustedError(absl::StrCat(std::string(what), " ", path.string(), ": ", std::string(cause),
                                                   " (", free_text,
                                                   "); free space or raise the quota: the server recovers by itself"));
}

}  // namespace impostor
