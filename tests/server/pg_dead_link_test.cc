// The dead-link settings of PostgreSQL connections (server/postgres/
// pg_dead_link.h): how one budget is split, its range, and that they reach
// both ends of a real TCP connection (the client's socket, the database
// backend's socket) unless the URL or the database's own settings say
// otherwise. What they buy over a cut link is tested across network
// namespaces: NetnsMultiHost.AReplicaCutOffFromTheDatabaseHandsOverMaintenance.
#include <libpq-fe.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <map>
#include <string>

#include <gtest/gtest.h>

#include "server/store/postgres/pg_connection_pool.h"
#include "server/store/postgres/pg_dead_link.h"
#include "tests/support/postgres_instance.h"

namespace impostor::testing {
namespace {

TEST(DeadLinkSettings, OneBudgetCoversConnectIdleAndUnacknowledgedBytes) {
  const PgDeadLinkSettings s = DeadLinkSettings(20);
  EXPECT_EQ(s.connect_timeout_s, 20);
  EXPECT_EQ(s.tcp_user_timeout_ms, 20000);
  EXPECT_EQ(s.keepalives_idle_s, 10);
  EXPECT_EQ(s.keepalives_interval_s, 3);
  EXPECT_EQ(s.keepalives_count, 3);
  // An idle connection is given up within the budget.
  EXPECT_LE(s.keepalives_idle_s + s.keepalives_interval_s * s.keepalives_count, 20);
  // The smallest budget still gives whole, positive seconds.
  const PgDeadLinkSettings small = DeadLinkSettings(kMinDeadLinkSeconds);
  EXPECT_EQ(small.connect_timeout_s, 2);
  EXPECT_EQ(small.keepalives_idle_s, 1);
  EXPECT_EQ(small.keepalives_interval_s, 1);
  EXPECT_EQ(DeadLinkSettings(0).connect_timeout_s, kMinDeadLinkSeconds) << "clamped";
  EXPECT_EQ(DeadLinkSettings(1'000'000).tcp_user_timeout_ms, kMaxDeadLinkSeconds * 1000) << "clamped";
}

TEST(DeadLinkSettings, OutOfRangeBudgetsAreRefusedNamingTheField) {
  EXPECT_TRUE(ValidateDeadLinkSeconds("--database-dead-link-seconds", 2).ok());
  EXPECT_TRUE(ValidateDeadLinkSeconds("--database-dead-link-seconds", 3600).ok());
  for (int bad : {-5, 0, 1, 3601}) {
    const absl::Status s = ValidateDeadLinkSeconds("--database-dead-link-seconds", bad);
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_EQ(s.message(), "--database-dead-link-seconds: " + std::to_string(bad) + " is out of range 2..3600 (seconds)");
  }
}

class DeadLinkOnTcp : public ::testing::Test {
 protected:
  void SetUp() override {
    PostgresInstance::Options options;
    options.tcp_address = "127.0.0.1";
    auto pg = PostgresInstance::Start(options);
    ASSERT_TRUE(pg.ok()) << pg.status();
    pg_ = std::move(*pg);
  }

  // What one pooled connection ended up with: libpq's keywords, the
  // client socket's options, and the backend's settings as it reads them
  // back from its own socket.
  struct Seen {
    std::map<std::string, std::string> libpq;
    int client_keepidle_s = -1;
    int client_user_timeout_ms = -1;
    std::map<std::string, std::string> backend;
  };
  Seen Look(const std::string& url, int dead_link_seconds) {
    Seen seen;
    auto pool = PgConnectionPool::Open({.url = url, .size = 1, .dead_link_seconds = dead_link_seconds});
    EXPECT_TRUE(pool.ok()) << pool.status();
    if (!pool.ok()) return seen;
    const absl::Status s = (*pool)->Run([&](PgSession& session) -> absl::Status {
      PQconninfoOption* info = PQconninfo(session.raw());
      for (PQconninfoOption* o = info; o != nullptr && o->keyword != nullptr; ++o) {
        if (o->val != nullptr) seen.libpq[o->keyword] = o->val;
      }
      PQconninfoFree(info);
      const int fd = PQsocket(session.raw());
      socklen_t len = sizeof(int);
      getsockopt(fd, IPPROTO_TCP, TCP_KEEPIDLE, &seen.client_keepidle_s, &len);
      len = sizeof(int);
      getsockopt(fd, IPPROTO_TCP, TCP_USER_TIMEOUT, &seen.client_user_timeout_ms, &len);
      auto rows = session.Exec("read settings",
                               "SELECT name, setting FROM pg_settings WHERE name IN ('tcp_keepalives_idle', "
                               "'tcp_keepalives_interval', 'tcp_keepalives_count', 'tcp_user_timeout')");
      if (!rows.ok()) return rows.status();
      for (int i = 0; i < rows->size(); ++i) seen.backend[rows->Text(i, 0)] = rows->Text(i, 1);
      return absl::OkStatus();
    });
    EXPECT_TRUE(s.ok()) << s;
    return seen;
  }

  std::unique_ptr<PostgresInstance> pg_;
};

TEST_F(DeadLinkOnTcp, BothEndsOfAConnectionGetTheBudget) {
  Seen seen = Look(pg_->Url("postgres", /*tcp=*/true), 12);
  EXPECT_EQ(seen.libpq["connect_timeout"], "12");
  EXPECT_EQ(seen.libpq["keepalives"], "1");
  EXPECT_EQ(seen.libpq["keepalives_count"], "3");
  // The kernel's view of the client socket.
  EXPECT_EQ(seen.client_keepidle_s, 6);
  EXPECT_EQ(seen.client_user_timeout_ms, 12000);
  // The backend's socket (PostgreSQL reads these back from it).
  EXPECT_EQ(seen.backend["tcp_keepalives_idle"], "6");
  EXPECT_EQ(seen.backend["tcp_keepalives_interval"], "2");
  EXPECT_EQ(seen.backend["tcp_keepalives_count"], "3");
  EXPECT_EQ(seen.backend["tcp_user_timeout"], "12000");
}

TEST_F(DeadLinkOnTcp, TheUrlAndTheDatabasesOwnSettingsWin) {
  // The URL sets the client's idle time and, through options=-c, the
  // backend's; the database sets the backend's probe count for everyone.
  ASSERT_TRUE(pg_->Query("postgres", "ALTER DATABASE postgres SET tcp_keepalives_count = 7").ok());
  Seen seen =
      Look(pg_->Url("postgres", /*tcp=*/true) + "?keepalives_idle=5&options=-c%20tcp_keepalives_idle%3D9", 12);
  EXPECT_EQ(seen.client_keepidle_s, 5);
  EXPECT_EQ(seen.libpq["keepalives_interval"], "2") << "the rest keeps the budget's values";
  EXPECT_EQ(seen.client_user_timeout_ms, 12000);
  EXPECT_EQ(seen.backend["tcp_keepalives_idle"], "9");
  EXPECT_EQ(seen.backend["tcp_keepalives_count"], "7");
  EXPECT_EQ(seen.backend["tcp_keepalives_interval"], "2");
  EXPECT_EQ(seen.backend["tcp_user_timeout"], "12000");
}

TEST_F(DeadLinkOnTcp, AUnixSocketConnectionStillOpens) {
  // TCP settings mean nothing on a Unix socket; setting them must not fail
  // the session setup (the contract suite runs there too).
  Seen seen = Look(pg_->Url("postgres"), 12);
  EXPECT_EQ(seen.libpq["connect_timeout"], "12");
  EXPECT_EQ(seen.backend["tcp_keepalives_idle"], "0") << "PostgreSQL reads TCP settings as 0 on a Unix socket";
}

}  // namespace
}  // namespace impostor::testing
