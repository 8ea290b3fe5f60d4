// A --log-level value spdlog knows: its from_str silently turns an unknown
// name into "off", so a daemon given a typo would run without a single log
// line. The error names the flag, the value and the names accepted, for the
// one line a daemon prints before exiting 2.
#ifndef IMPOSTOR_COMMON_UTIL_LOG_LEVEL_H_
#define IMPOSTOR_COMMON_UTIL_LOG_LEVEL_H_

#include <string_view>

#include "absl/status/status.h"

namespace impostor {

// trace, debug, info, warn (warning), error (err), critical or off.
absl::Status ValidateLogLevel(std::string_view flag, std::string_view value);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_UTIL_LOG_LEVEL_H_
