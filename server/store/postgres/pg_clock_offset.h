// How far this server's clock is from the database's, which every replica
// on the database shares. Lease deadlines and the lease sweep's "now" are
// read on that one clock (this server's clock plus the offset), so a
// replica whose clock runs ahead cannot expire the others' leases and one
// running behind cannot write deadlines that are already past.
//
// The offset is measured from statements the engine runs anyway (the
// maintenance lock's, once a sweep): the database's clock_timestamp()
// against the midpoint of the local send and receive times, so its error
// is at most half a round trip. A measured difference over kClockSkewWarnMs
// is logged (event=clock_skew) once, and again when it is back within.
//
// Thread-safety: thread-safe.
#ifndef IMPOSTOR_SERVER_STORE_POSTGRES_PG_CLOCK_OFFSET_H_
#define IMPOSTOR_SERVER_STORE_POSTGRES_PG_CLOCK_OFFSET_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

namespace impostor {

// Beyond this the operator should fix the host's time (NTP): the farm stays
// correct, but logs and job times written by this replica are off.
inline constexpr int64_t kClockSkewWarnMs = 2000;

// SQL for the database's clock in Unix milliseconds.
inline constexpr const char* kDatabaseClockMsSql = "(extract(epoch FROM clock_timestamp()) * 1000)::bigint";

class PgClockOffset {
 public:
  // `local_clock_ms` reads this server's clock (Unix ms); null = the system
  // clock. Tests substitute a skewed one. `url` (redacted) is for logs.
  PgClockOffset(std::function<int64_t()> local_clock_ms, std::string url);

  int64_t LocalNowMs() const;
  // One sample: a statement sent at `sent_local_ms` answered the database's
  // clock `database_ms` and came back at `received_local_ms`.
  void Note(int64_t sent_local_ms, int64_t database_ms, int64_t received_local_ms);
  // The latest sample's database minus local time; 0 before any.
  int64_t offset_ms() const { return offset_ms_.load(); }

 private:
  const std::function<int64_t()> local_clock_ms_;
  const std::string url_;
  std::atomic<int64_t> offset_ms_{0};
  std::atomic<bool> skew_reported_{false};
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_POSTGRES_PG_CLOCK_OFFSET_H_
