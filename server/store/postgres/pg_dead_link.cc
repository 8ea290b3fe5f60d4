#include "server/store/postgres/pg_dead_link.h"

#include <algorithm>

#include "absl/strings/str_cat.h"

namespace impostor {

absl::Status ValidateDeadLinkSeconds(const std::string& field, int seconds) {
  if (seconds < kMinDeadLinkSeconds || seconds > kMaxDeadLinkSeconds) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", seconds, " is out of range ", kMinDeadLinkSeconds,
                                                   "..", kMaxDeadLinkSeconds, " (seconds)"));
  }
  return absl::OkStatus();
}

PgDeadLinkSettings DeadLinkSettings(int dead_link_seconds) {
  const int s = std::clamp(dead_link_seconds, kMinDeadLinkSeconds, kMaxDeadLinkSeconds);
  // Keepalive: quiet for half the budget, then three probes in the other
  // half, so an idle connection is given up after about S.
  return {.connect_timeout_s = s,
          .keepalives_idle_s = std::max(1, s / 2),
          .keepalives_interval_s = std::max(1, s / 6),
          .keepalives_count = 3,
          .tcp_user_timeout_ms = s * 1000};
}

std::vector<std::pair<std::string, std::string>> DeadLinkConnectParams(const PgDeadLinkSettings& s) {
  return {{"connect_timeout", std::to_string(s.connect_timeout_s)},
          {"keepalives", "1"},
          {"keepalives_idle", std::to_string(s.keepalives_idle_s)},
          {"keepalives_interval", std::to_string(s.keepalives_interval_s)},
          {"keepalives_count", std::to_string(s.keepalives_count)},
          {"tcp_user_timeout", std::to_string(s.tcp_user_timeout_ms)}};
}

std::string DeadLinkSessionSql(const PgDeadLinkSettings& s) {
  // source = 'default': nobody (postgresql.conf, ALTER ROLE/DATABASE, the
  // URL's options=-c) chose a value; those choices are kept.
  return absl::StrCat("SELECT count(set_config(d.name, d.value, false)) FROM (VALUES ('tcp_keepalives_idle', '",
                      s.keepalives_idle_s, "'), ('tcp_keepalives_interval', '", s.keepalives_interval_s,
                      "'), ('tcp_keepalives_count', '", s.keepalives_count, "'), ('tcp_user_timeout', '",
                      s.tcp_user_timeout_ms,
                      "')) AS d(name, value) JOIN pg_settings p ON p.name = d.name WHERE p.source = 'default'");
}

}  // namespace impostor
