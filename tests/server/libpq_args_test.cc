// libpq's argument arrays and messages as this server passes and logs them
// (server/store/postgres/libpq_args.h), including a real refused connection's
// message, so the shape of what libpq actually prints is what is tested.
#include <libpq-fe.h>

#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "server/store/postgres/libpq_args.h"

namespace impostor::testing {
namespace {

TEST(LibpqKeywords, BothArraysAreNullTerminatedAndInOrder) {
  const std::vector<std::pair<std::string, std::string>> params = {{"connect_timeout", "2"},
                                                                    {"dbname", "postgresql://h/db"}};
  const LibpqKeywords args(params);
  EXPECT_STREQ(args.keywords()[0], "connect_timeout");
  EXPECT_STREQ(args.values()[0], "2");
  EXPECT_STREQ(args.keywords()[1], "dbname");
  EXPECT_STREQ(args.values()[1], "postgresql://h/db");
  EXPECT_EQ(args.keywords()[2], nullptr);
  EXPECT_EQ(args.values()[2], nullptr);
}

TEST(LibpqMessageLine, HintsFollowASemicolonAndNothingTrails) {
  EXPECT_EQ(LibpqMessageLine("connection to server failed: Connection refused\n\tIs the server running?\n"),
            "connection to server failed: Connection refused; Is the server running?");
  EXPECT_EQ(LibpqMessageLine("ERROR:  relation \"jobs\" does not exist\nLINE 1: SELECT\n"),
            "ERROR:  relation \"jobs\" does not exist; LINE 1: SELECT");
  EXPECT_EQ(LibpqMessageLine(""), "");
  EXPECT_EQ(LibpqMessageLine("\n\t \n"), "");
}

TEST(LibpqMessageLine, ARealRefusedConnectionReadsAsOneLine) {
  // Port 1 on loopback: nothing listens there, so libpq refuses at once.
  const LibpqKeywords args({{"host", "127.0.0.1"}, {"port", "1"}, {"connect_timeout", "2"}});
  PGconn* conn = PQconnectdbParams(args.keywords(), args.values(), /*expand_dbname=*/0);
  ASSERT_NE(conn, nullptr);
  ASSERT_EQ(PQstatus(conn), CONNECTION_BAD);
  const std::string raw = PQerrorMessage(conn);
  const std::string line = LibpqMessageLine(raw);
  PQfinish(conn);
  EXPECT_NE(raw.find('\n'), std::string::npos) << "libpq's own message spans lines: " << raw;
  EXPECT_EQ(line.find('\n'), std::string::npos) << line;
  EXPECT_EQ(line.find('\t'), std::string::npos) << line;
  EXPECT_NE(line.find("127.0.0.1"), std::string::npos) << line;
}

}  // namespace
}  // namespace impostor::testing
