// --log-level values (common/util/log_level.h).
#include "common/util/log_level.h"

#include <gtest/gtest.h>

namespace impostor {
namespace {

TEST(ValidateLogLevel, SpdlogNamesPassAndAnythingElseIsNamed) {
  for (const char* ok : {"trace", "debug", "info", "warn", "warning", "error", "err", "critical", "off"}) {
    EXPECT_TRUE(ValidateLogLevel("--log-level", ok).ok()) << ok;
  }
  for (const char* bad : {"loud", "", "INFO", "verbose", "info "}) {
    const absl::Status s = ValidateLogLevel("--log-level", bad);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(s.message().find("--log-level: \"" + std::string(bad) + "\" is not a log level"), std::string::npos)
        << s;
  }
}

}  // namespace
}  // namespace impostor
