#include "worker/input_links.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/util/log_escape.h"
#include "worker/scratch_file.h"
#include "worker/scratch_shortage.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

// The link errors that mean "this filesystem will not hard-link these",
// not "this path is wrong".
bool CannotHardLinkHere(int error_number) {
  return error_number == EXDEV || error_number == EPERM || error_number == EMLINK || error_number == ENOTSUP;
}

absl::Status LinkError(std::string_view what, const fs::path& path, int error_number) {
  if (error_number == EEXIST) {
    return absl::InvalidArgumentError(
        absl::StrCat("input ", path.string(), " is listed twice: another input already holds its path"));
  }
  return ScratchWriteError(what, path, error_number);
}

}  // namespace

absl::Status LinkInputCopies(const fs::path& written, std::span<const fs::path> others) {
  bool told = false;
  for (const fs::path& path : others) {
    if (auto s = MakeInputFolder(path); !s.ok()) return s;
    if (::link(written.c_str(), path.c_str()) == 0) continue;
    const int link_error = errno;
    if (!CannotHardLinkHere(link_error)) return LinkError("link", path, link_error);
    if (!std::exchange(told, true)) {
      spdlog::warn("event=input_symlinked blob_path=\"{}\" copies={} reason=\"{}\"", EscapeUntrusted(written.string()), others.size(),
                   std::strerror(link_error));
    }
    if (::symlink(fs::absolute(written).c_str(), path.c_str()) != 0) return LinkError("symlink", path, errno);
  }
  return absl::OkStatus();
}

}  // namespace impostor
