#include "server/blobs/disk_full.h"

#include "absl/strings/str_cat.h"

namespace impostor {

absl::Status DiskFullError(std::string_view what, const std::filesystem::path& path, std::string_view cause) {
  return absl::ResourceExhaustedError(absl::StrCat(std::string(what), " ", path.string(), ": ", std::string(cause),
                                                   " (", FreeSpaceText(path),
                                                   "); free space or raise the quota: the server recovers by itself"));
}

}  // namespace impostor
