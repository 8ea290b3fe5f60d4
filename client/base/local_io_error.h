// The client's errors for local file I/O (the result cache, `fetch --out`):
// a full disk or quota (ENOSPC, EDQUOT) is RESOURCE_EXHAUSTED naming the
// path and the free space left, so the user knows where to make room and
// that trying again then works; anything else is INTERNAL naming the path.
#ifndef IMPOSTOR_CLIENT_BASE_LOCAL_IO_ERROR_H_
#define IMPOSTOR_CLIENT_BASE_LOCAL_IO_ERROR_H_

#include <filesystem>
#include <string_view>

#include "absl/status/status.h"

namespace impostor::sdk {

// "<what> <path>: <strerror(err)>", plus for a full disk " (N bytes free on
// its filesystem); free space and try again".
absl::Status LocalIoError(std::string_view what, const std::filesystem::path& path, int err);

// True for a LocalIoError of a full disk (not a server's RESOURCE_EXHAUSTED).
bool IsLocalDiskFull(const absl::Status& status);

// True for a failure of this machine's own files (a LocalIoError, or an
// INTERNAL that no server sent): the same whichever source the bytes come
// from, so no other source is tried for it.
bool IsLocalFailure(const absl::Status& status);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_BASE_LOCAL_IO_ERROR_H_
