#include "client/transport/client_options_check.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "common/net/keepalive.h"
#include "common/net/server_list.h"

namespace impostor::sdk {

absl::Status CheckClientOptions(const ClientOptions& o) {
  // !(x > 0) also catches NaN.
  if (auto targets = ParseServerList(o.server, "ClientOptions.server"); !targets.ok()) return targets.status();
  if (!(o.rpc_timeout_seconds > 0) || std::isinf(o.rpc_timeout_seconds)) {
    return absl::InvalidArgumentError(
        absl::StrCat("ClientOptions.rpc_timeout_seconds: must be > 0, got ", o.rpc_timeout_seconds));
  }
  if (auto s = ValidateKeepaliveSeconds("ClientOptions.keepalive_seconds", o.keepalive_seconds); !s.ok()) return s;
  if (!(o.connect_timeout_seconds > 0) || std::isinf(o.connect_timeout_seconds)) {
    return absl::InvalidArgumentError(
        absl::StrCat("ClientOptions.connect_timeout_seconds: must be > 0, got ", o.connect_timeout_seconds));
  }
  if (o.max_attempts < 1) {
    return absl::InvalidArgumentError(absl::StrCat("ClientOptions.max_attempts: must be >= 1, got ", o.max_attempts));
  }
  if (!(o.max_outage_seconds >= 0 && o.max_outage_seconds <= kMaxOutageSeconds)) {
    return absl::InvalidArgumentError(absl::StrCat("ClientOptions.max_outage_seconds: must be in 0..",
                                                   kMaxOutageSeconds, ", got ", o.max_outage_seconds));
  }
  return absl::OkStatus();
}

}  // namespace impostor::sdk
