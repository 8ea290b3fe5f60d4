// Lets the server and worker accept GNU-style dashed flags (--local-workers)
// as well as Abseil's underscored names (--local_workers), which is what
// absl::ParseCommandLine understands. Rewrites the name part of every
// "--name[=value]" argument in place, stopping at a bare "--".
#ifndef IMPOSTOR_COMMON_FLAGS_FLAG_NAMES_H_
#define IMPOSTOR_COMMON_FLAGS_FLAG_NAMES_H_

#include <algorithm>
#include <cstring>
#include <string>

#include "absl/flags/usage_config.h"

namespace impostor {

// A flag name as users type it: Abseil's underscores as dashes
// ("local_workers" -> "local-workers"; no leading dashes added).
inline std::string DashedFlagName(std::string name) {
  std::replace(name.begin(), name.end(), '_', '-');
  return name;
}

inline void UnderscoreFlagNames(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    char* arg = argv[i];
    if (std::strcmp(arg, "--") == 0) break;
    if (arg[0] != '-' || arg[1] != '-') continue;
    for (char* c = arg + 2; *c != '\0' && *c != '='; ++c) {
      if (*c == '-') *c = '_';
    }
  }
}

// --help lists every flag of the binary (Abseil's default shows only flags
// defined in a file named after the program).
inline void ShowAllFlagsInHelp() {
  absl::FlagsUsageConfig config;
  config.contains_helpshort_flags = [](absl::string_view) { return true; };
  config.contains_help_flags = [](absl::string_view) { return true; };
  absl::SetFlagsUsageConfig(config);
}

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_FLAGS_FLAG_NAMES_H_
