// A throwaway PostgreSQL server for tests: `initdb` into a new temporary
// directory, `postgres` started with `pg_ctl -w` (which returns once the
// server accepts connections), stopped and the directory removed by the
// destructor. Reusable by any test that needs a real database (the JobStore
// contract suite, the multi-replica and multi-host tests).
//
// Binaries: /usr/lib/postgresql/15/bin (Debian's postgresql-15), or
// $IMPOSTOR_PG_BIN. As root, every binary runs as the `postgres` user through
// `runuser -u postgres --` (PostgreSQL refuses to run as root), so the
// directory is created owned by that user.
//
// Listening: by default only on a Unix socket inside the temporary
// directory (no TCP port, nothing another test can collide with); with
// Options::tcp_address also on that address and a free port (for tests whose
// servers run in other network namespaces).
//
// Usage:
//   auto pg = PostgresInstance::Start();
//   if (!pg.ok()) GTEST_SKIP() or FAIL() << pg.status();
//   (*pg)->CreateDatabase("jobs");
//   OpenJobStore({.database_url = (*pg)->Url("jobs")});
#ifndef IMPOSTOR_TESTS_SUPPORT_POSTGRES_INSTANCE_H_
#define IMPOSTOR_TESTS_SUPPORT_POSTGRES_INSTANCE_H_

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor::testing {

class PostgresInstance {
 public:
  struct Options {
    // '' = Unix socket only; else also listen on this IPv4 address.
    std::string tcp_address;
    // TCP port; 0 = a free one (found by binding port 0 on tcp_address).
    int port = 0;
    // The database user's password ('' = trust authentication). With a
    // password, TCP connections must give it (md5/scram); the Unix socket
    // stays trusted.
    std::string password;
    // fsync off (the default) makes tests faster; benchmarks that compare
    // with SQLite's fsynced commits turn it on.
    bool fsync = false;
    // Prepended to the command that starts the server (pg_ctl start), e.g.
    // {"ip", "netns", "exec", NS} to run it on a test host made by
    // tests/support/netns.h (then tcp_address is that host's address and
    // `port` must be given: a free port cannot be probed from here). The
    // Unix socket and psql (Query) still work from the test's namespace.
    std::vector<std::string> start_prefix;
  };

  // FAILED_PRECONDITION when the PostgreSQL binaries are missing; INTERNAL
  // with the tool's output when initdb or the start fails.
  static absl::StatusOr<std::unique_ptr<PostgresInstance>> Start(const Options& options);
  static absl::StatusOr<std::unique_ptr<PostgresInstance>> Start() { return Start(Options()); }
  ~PostgresInstance();
  PostgresInstance(const PostgresInstance&) = delete;
  PostgresInstance& operator=(const PostgresInstance&) = delete;

  // A libpq URL for `database` as the superuser `postgres`: over the Unix
  // socket, or over TCP (with the password) when `tcp` is true.
  std::string Url(const std::string& database = "postgres", bool tcp = false) const;
  // CREATE DATABASE `name` (letters, digits, '_').
  absl::Status CreateDatabase(const std::string& name);
  // Runs one SQL statement through psql on the Unix socket; returns its
  // unaligned, tuples-only output (e.g. "3\n" for SELECT count(*)).
  absl::StatusOr<std::string> Query(const std::string& database, const std::string& sql);

  // Stops the server (pg_ctl stop -m fast: every client is disconnected)
  // and starts it again on the same directory, port and socket.
  absl::Status Restart();
  absl::Status Stop();
  absl::Status StartAgain();

  const std::filesystem::path& directory() const { return dir_; }
  int port() const { return port_; }

 private:
  PostgresInstance() = default;
  // `prefix` goes before runuser (`ip netns exec` needs root).
  absl::StatusOr<std::string> Run(const std::vector<std::string>& argv,
                                  const std::vector<std::string>& prefix = {});

  std::filesystem::path dir_;      // the temporary directory (data/, socket, log)
  std::filesystem::path bin_dir_;
  Options options_;
  int port_ = 5432;
  bool running_ = false;
  bool as_postgres_user_ = false;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_POSTGRES_INSTANCE_H_
