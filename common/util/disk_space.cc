#include "common/util/disk_space.h"

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

std::string FreeSpaceText(const std::filesystem::path& path) {
  const int64_t free_bytes = FreeBytes(path);
  return free_bytes < 0 ? std::string("free space unknown") : absl::StrCat(free_bytes, " bytes free on its filesystem");
}

}  // namespace impostor
