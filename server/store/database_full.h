// How many writes this process's job databases (SQLite's files, PostgreSQL)
// refused for a full disk (DATABASE_FULL), counted where the refusal is
// made (SqliteError, PgStatementError). The lease sweep reads it: while the
// database refuses writes, no worker's heartbeat or result can be recorded,
// so a lease deadline passing then says nothing about the worker
// (BakeScheduler::LeaseExpiryDeferred). Process-wide, like the disk.
#ifndef IMPOSTOR_SERVER_STORE_DATABASE_FULL_H_
#define IMPOSTOR_SERVER_STORE_DATABASE_FULL_H_

#include <atomic>
#include <cstdint>

namespace impostor {

inline std::atomic<uint64_t>& DatabaseFullRefusals() {
  static std::atomic<uint64_t> refusals{0};
  return refusals;
}

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_STORE_DATABASE_FULL_H_
