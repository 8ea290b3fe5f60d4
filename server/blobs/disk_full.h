// What the server says when its disk (or quota) is full: RESOURCE_EXHAUSTED
// naming the file it was writing and the space left, so an operator knows
// where to look. Writes that fail this way leave nothing half-written (see
// BlobStore and JobStore) and later writes succeed by themselves once space
// returns: there is no "disk full" mode to leave.
#ifndef IMPOSTOR_SERVER_BLOBS_DISK_FULL_H_
#define IMPOSTOR_SERVER_BLOBS_DISK_FULL_H_

#include <filesystem>
#include <string_view>

#include "absl/status/status.h"
#include "common/util/disk_space.h"  // IsDiskFull, FreeBytes

namespace impostor {

// RESOURCE_EXHAUSTED: "<what> <path>: <cause> (N bytes free on its
// filesystem); free space or raise the quota: the server recovers by
// itself".
absl::Status DiskFullError(std::string_view what, const std::filesystem::path& path, std::string_view cause);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_BLOBS_DISK_FULL_H_
