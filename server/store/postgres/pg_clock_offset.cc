#include "server/store/postgres/pg_clock_offset.h"

#include <chrono>
#include <cstdlib>

#include <spdlog/spdlog.h>

namespace impostor {

PgClockOffset::PgClockOffset(std::function<int64_t()> local_clock_ms, std::string url)
    : local_clock_ms_(std::move(local_clock_ms)), url_(std::move(url)) {}

int64_t PgClockOffset::LocalNowMs() const {
  if (local_clock_ms_) return local_clock_ms_();
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

void PgClockOffset::Note(int64_t sent_local_ms, int64_t database_ms, int64_t received_local_ms) {
  const int64_t offset = database_ms - (sent_local_ms + received_local_ms) / 2;
  offset_ms_ = offset;
  const bool skewed = std::llabs(offset) > kClockSkewWarnMs;
  if (skewed == skew_reported_.exchange(skewed)) return;
  if (skewed) {
    spdlog::warn("event=clock_skew url={} offset_ms={} threshold_ms={} round_trip_ms={} "
                 "action=\"lease times follow the database's clock; fix this host's time\"",
                 url_, offset, kClockSkewWarnMs, received_local_ms - sent_local_ms);
  } else {
    spdlog::info("event=clock_skew_resolved url={} offset_ms={}", url_, offset);
  }
}

}  // namespace impostor
