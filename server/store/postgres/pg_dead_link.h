// How a replica and PostgreSQL notice that the link between them died
// without a reset (a pulled cable, a host powered off or cut off, a
// firewall that drops the flow), on both ends, within about
// `dead_link_seconds` (issue 15; --database-dead-link-seconds).
//
// Why it is needed: libpq and the kernel wait far too long by default. A
// connect to a black-holed address has no timeout; a statement sent into a
// dead link waits for TCP's retransmissions (~15 min), with the
// scheduler's lock held, so the whole replica stops answering; and the
// database keeps a vanished replica's session, with the maintenance
// advisory lock it holds, until the kernel's keepalive gives up (2 h of
// silence by default): no other replica would sweep expired leases for
// that long.
//
// What is set, from one number S (seconds):
//  - client side (libpq connection keywords): connect_timeout = S,
//    keepalives on with idle S/2, interval S/6 and 3 probes (an idle
//    connection, e.g. the LISTEN one, is given up after about S), and
//    tcp_user_timeout = S (a statement whose bytes go unacknowledged).
//  - server side (the session's own settings, which any user may set):
//    tcp_keepalives_idle/interval/count and tcp_user_timeout alike, so the
//    database ends a vanished replica's session (releasing its advisory
//    locks) after about S.
// The operator keeps the last word: the URL's own keywords
// (`?keepalives_idle=...&connect_timeout=...`) override the client side,
// and server settings given by the URL's `options=-c ...`, postgresql.conf,
// ALTER ROLE or ALTER DATABASE are left alone (only settings still at
// their built-in default are changed). On a Unix socket TCP settings do
// nothing (PostgreSQL reads them as 0); connect_timeout still applies.
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_PG_DEAD_LINK_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_PG_DEAD_LINK_H_

#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"

namespace impostor {

inline constexpr int kDefaultDeadLinkSeconds = 20;
inline constexpr int kMinDeadLinkSeconds = 2;  // libpq's connect_timeout takes no less
inline constexpr int kMaxDeadLinkSeconds = 3600;

// INVALID_ARGUMENT naming `field` and the range unless `seconds` is in
// kMinDeadLinkSeconds..kMaxDeadLinkSeconds.
absl::Status ValidateDeadLinkSeconds(const std::string& field, int seconds);

struct PgDeadLinkSettings {
  int connect_timeout_s = 0;
  int keepalives_idle_s = 0;
  int keepalives_interval_s = 0;
  int keepalives_count = 0;
  int tcp_user_timeout_ms = 0;
};

// The settings for `dead_link_seconds` (clamped into the valid range).
PgDeadLinkSettings DeadLinkSettings(int dead_link_seconds);

// libpq connection keywords and values (for PQconnectdbParams, placed
// before the expanded URL so that the URL's own keywords win).
std::vector<std::pair<std::string, std::string>> DeadLinkConnectParams(const PgDeadLinkSettings& s);

// One statement that sets the server-side settings for this session where
// they are still at their built-in default.
std::string DeadLinkSessionSql(const PgDeadLinkSettings& s);

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_PG_DEAD_LINK_H_
