// HttpGet keeps one libcurl handle per thread and sets the options shared
// by every transfer once: what one call asks for (a Range, an
// If-None-Match) must not leak into the next call on the same thread. A
// real HTTP server (cpp-httplib on loopback) records what each request
// carried.
#include <httplib.h>

#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "client/transport/http_get.h"

namespace impostor::sdk {
namespace {

constexpr char kBody[] = "0123456789";

struct Seen {
  std::string range;
  std::string if_none_match;
};

class RecordingServer {
 public:
  RecordingServer() {
    server_.Get("/file", [this](const httplib::Request& req, httplib::Response& res) {
      Seen seen{req.get_header_value("Range"), req.get_header_value("If-None-Match")};
      {
        std::lock_guard lock(mu_);
        seen_.push_back(seen);
      }
      res.set_header("ETag", "\"v1\"");
      if (seen.if_none_match == "\"v1\"") {
        res.status = 304;
        return;
      }
      // httplib answers a Range itself: 206 from the asked offset.
      res.set_content(kBody, "application/octet-stream");
    });
    server_.set_keep_alive_timeout(1);  // the destructor waits out kept-alive connections
    port_ = server_.bind_to_any_port("127.0.0.1");
    thread_ = std::thread([this] { server_.listen_after_bind(); });
    // bind_to_any_port listens already: connections queue until the loop runs.
  }
  ~RecordingServer() {
    server_.stop();
    thread_.join();
  }
  std::string url() const { return absl::StrCat("http://127.0.0.1:", port_, "/file"); }
  std::vector<Seen> seen() {
    std::lock_guard lock(mu_);
    return seen_;
  }

 private:
  httplib::Server server_;
  std::thread thread_;
  int port_ = 0;
  std::mutex mu_;
  std::vector<Seen> seen_;
};

absl::StatusOr<HttpGetResult> Get(const std::string& url, const HttpGetOptions& options, std::string* body) {
  body->clear();
  return HttpGet(url, options, [body](std::string_view data) {
    body->append(data);
    return absl::OkStatus();
  });
}

TEST(HttpGet, EachCallSendsOnlyItsOwnRangeAndValidator) {
  RecordingServer server;
  ASSERT_GT(server.url().size(), 0u);
  std::string body;
  // All on this thread, so all on one handle (and one kept-alive connection).
  HttpGetOptions revalidate;
  revalidate.if_none_match = "\"v1\"";
  absl::StatusOr<HttpGetResult> not_modified = Get(server.url(), revalidate, &body);
  ASSERT_TRUE(not_modified.ok()) << not_modified.status();
  EXPECT_EQ(not_modified->status, 304);
  EXPECT_EQ(body, "");

  HttpGetOptions resume;
  resume.offset = 4;
  absl::StatusOr<HttpGetResult> partial = Get(server.url(), resume, &body);
  ASSERT_TRUE(partial.ok()) << partial.status();
  EXPECT_EQ(partial->status, 206);
  EXPECT_EQ(partial->range_start, 4);
  EXPECT_EQ(body, "456789");

  absl::StatusOr<HttpGetResult> whole = Get(server.url(), HttpGetOptions{}, &body);
  ASSERT_TRUE(whole.ok()) << whole.status();
  EXPECT_EQ(whole->status, 200);
  EXPECT_EQ(whole->range_start, 0);
  EXPECT_EQ(whole->etag, "\"v1\"");
  EXPECT_EQ(body, kBody);

  const std::vector<Seen> seen = server.seen();
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[0].if_none_match, "\"v1\"");
  EXPECT_EQ(seen[0].range, "");
  EXPECT_EQ(seen[1].if_none_match, "");
  EXPECT_EQ(seen[1].range, "bytes=4-");
  EXPECT_EQ(seen[2].if_none_match, "");
  EXPECT_EQ(seen[2].range, "");
}

}  // namespace
}  // namespace impostor::sdk
