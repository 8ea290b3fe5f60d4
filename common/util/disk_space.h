// Full disks, as the server and the client both report them: which errno
// values mean "no space" and how much space is left, so a RESOURCE_EXHAUSTED
// error can name the free space where the write failed.
#ifndef IMPOSTOR_COMMON_UTIL_DISK_SPACE_H_
#define IMPOSTOR_COMMON_UTIL_DISK_SPACE_H_

#include <cstdint>
#include <filesystem>
#include <string>

namespace impostor {

// True for the errno values of a full filesystem or an exhausted quota
// (ENOSPC, EDQUOT).
bool IsDiskFull(int error_number);

// Bytes an unprivileged writer may still use on the filesystem holding
// `path` (its nearest existing ancestor); -1 when unknown.
int64_t FreeBytes(const std::filesystem::path& path);

// "N bytes free on its filesystem", or "free space unknown".
std::string FreeSpaceText(const std::filesystem::path& path);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_UTIL_DISK_SPACE_H_
