#include "common/util/log_level.h"

#include <algorithm>
#include <array>
#include <string>

#include "absl/strings/str_cat.h"

namespace impostor {

absl::Status ValidateLogLevel(std::string_view flag, std::string_view value) {
  // spdlog's names, and the short forms its from_str also takes.
  static constexpr std::array<std::string_view, 9> kNames = {"trace", "debug", "info",     "warn", "warning",
                                                             "error", "err",   "critical", "off"};
  if (std::find(kNames.begin(), kNames.end(), value) != kNames.end()) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(std::string(flag), ": \"", std::string(value),
                                                 "\" is not a log level (trace, debug, info, warn, error, "
                                                 "critical or off)"));
}

}  // namespace impostor
