// --http-listen parsing and the JSON API's query parameters: every bad
// value is refused with a message naming the flag or parameter.
#include <gtest/gtest.h>

#include "server/http/api_params.h"
#include "server/http/listen_address.h"

namespace impostor {
namespace {

TEST(ListenAddress, ParsesGoodValues) {
  struct Case {
    const char* text;
    const char* host;
    int port;
  };
  for (const Case& c : {Case{"127.0.0.1:0", "127.0.0.1", 0}, Case{"0.0.0.0:8080", "0.0.0.0", 8080},
                        Case{"localhost:65535", "localhost", 65535}, Case{"[::1]:9090", "::1", 9090}}) {
    auto a = ParseListenAddress(c.text, "--http-listen");
    ASSERT_TRUE(a.ok()) << c.text << ": " << a.status();
    EXPECT_EQ(a->host, c.host) << c.text;
    EXPECT_EQ(a->port, c.port) << c.text;
  }
}

TEST(ListenAddress, RefusesBadValuesNamingTheFlag) {
  struct Case {
    const char* text;
    const char* expect;
  };
  for (const Case& c : {Case{"8080", "has no port"}, Case{":8080", "has no host"}, Case{"host:", "port"},
                        Case{"host:65536", "0..65535"}, Case{"host:-1", "0..65535"}, Case{"host:80a", "0..65535"},
                        Case{"host:123456", "0..65535"}, Case{"::1:80", "IPv6"}, Case{"a b:80", "invalid host"}}) {
    auto a = ParseListenAddress(c.text, "--http-listen");
    ASSERT_FALSE(a.ok()) << c.text;
    EXPECT_EQ(a.status().code(), absl::StatusCode::kInvalidArgument) << c.text;
    const std::string message(a.status().message());
    EXPECT_NE(message.find("--http-listen"), std::string::npos) << c.text << ": " << message;
    EXPECT_NE(message.find(c.expect), std::string::npos) << c.text << ": " << message;
  }
}

QueryParams Q(std::initializer_list<std::pair<const std::string, std::string>> list) { return QueryParams(list); }

TEST(ApiParams, PageSize) {
  EXPECT_EQ(*ParsePageSize(Q({})), kDefaultPageSize);
  EXPECT_EQ(*ParsePageSize(Q({{"page_size", "1"}})), 1);
  EXPECT_EQ(*ParsePageSize(Q({{"page_size", "500"}})), 500);
  for (const char* bad : {"0", "501", "-3", "ten", "", "1.5", "99999999999999"}) {
    auto n = ParsePageSize(Q({{"page_size", bad}}));
    ASSERT_FALSE(n.ok()) << bad;
    EXPECT_NE(std::string(n.status().message()).find("page_size"), std::string::npos) << n.status();
    EXPECT_NE(std::string(n.status().message()).find("1..500"), std::string::npos) << n.status();
  }
}

TEST(ApiParams, StateFilter) {
  EXPECT_EQ(*ParseStateFilter(Q({})), v1::JOB_STATE_UNSPECIFIED);
  EXPECT_EQ(*ParseStateFilter(Q({{"state", "all"}})), v1::JOB_STATE_UNSPECIFIED);
  EXPECT_EQ(*ParseStateFilter(Q({{"state", "running"}})), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(*ParseStateFilter(Q({{"state", "cancelled"}})), v1::JOB_STATE_CANCELLED);
  for (const char* bad : {"RUNNING", "done", "", "unspecified"}) {
    auto s = ParseStateFilter(Q({{"state", bad}}));
    ASSERT_FALSE(s.ok()) << bad;
    EXPECT_NE(std::string(s.status().message()).find("state: "), std::string::npos) << s.status();
  }
}

TEST(ApiParams, PageTokensRoundTripAndBadOnesAreRefused) {
  const JobStore::JobCursor cursor{1234, "job-abc"};
  auto back = ParseJobPageToken(Q({{"page_token", JobPageToken(cursor)}}));
  ASSERT_TRUE(back.ok() && back->has_value()) << back.status();
  EXPECT_EQ((*back)->created_ms, 1234);
  EXPECT_EQ((*back)->job_id, "job-abc");
  const std::string key(64, 'a');
  auto result = ParseResultPageToken(Q({{"page_token", ResultPageToken({99, key})}}));
  ASSERT_TRUE(result.ok() && result->has_value()) << result.status();
  EXPECT_EQ((*result)->cache_key, key);
  for (const char* bad : {"nodot", ".job", "12.", "-5.job", "x.job"}) {
    auto t = ParseJobPageToken(Q({{"page_token", bad}}));
    ASSERT_FALSE(t.ok()) << bad;
    EXPECT_NE(std::string(t.status().message()).find("page_token"), std::string::npos) << t.status();
  }
  EXPECT_FALSE(ParseResultPageToken(Q({{"page_token", "12.notakey"}})).ok());
}

TEST(ApiParams, UnknownOrRepeatedParametersAreRefused) {
  EXPECT_TRUE(CheckKnownParams(Q({{"state", "queued"}}), {"state", "page_size"}).ok());
  auto unknown = CheckKnownParams(Q({{"stat", "queued"}}), {"state", "page_size"});
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(std::string(unknown.message()).find("\"stat\": unknown query parameter"), std::string::npos) << unknown;
  auto twice = CheckKnownParams(Q({{"state", "queued"}, {"state", "failed"}}), {"state"});
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(std::string(twice.message()).find("state: given more than once"), std::string::npos) << twice;
}

}  // namespace
}  // namespace impostor
