#include "client/base/local_io_error.h"

#include <cstring>

#include "absl/strings/str_cat.h"
#include "common/util/disk_space.h"
#include "impostor/client.h"

namespace impostor::sdk {

absl::Status LocalIoError(std::string_view what, const std::filesystem::path& path, int err) {
  const std::string text = absl::StrCat(std::string(what), " ", path.string(), ": ", std::strerror(err));
  if (!IsDiskFull(err)) return absl::InternalError(text);
  return absl::ResourceExhaustedError(
      absl::StrCat(text, " (", FreeSpaceText(path), "); free space and try again"));
}

bool IsLocalDiskFull(const absl::Status& status) {
  return status.code() == absl::StatusCode::kResourceExhausted && !GetRpcErrorInfo(status).has_value();
}

bool IsLocalFailure(const absl::Status& status) {
  return IsLocalDiskFull(status) || (absl::IsInternal(status) && !GetRpcErrorInfo(status).has_value());
}

}  // namespace impostor::sdk
