// impostor-server --http-releases as a real process on a real port (issue
// 40: the farm as an origin for game clients' mirrors), over a release tree
// each test writes itself: blobs and catalogs are immutable files named by
// their digest, channels are read afresh with a short max-age, ranges and
// If-None-Match work, nothing but the three path shapes is served (no
// traversal, no links out of the tree), a corrupt blob is never served,
// tokens are asked for only with --http-releases-require-token, and bad
// flags stop the start naming what is wrong; its connections send without
// Nagle's delay.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <httplib.h>

#include <cctype>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "tests/delivery/origin_tree_writer.h"
#include "tests/support/server_process.h"
#include "tests/metrics/http_test_client.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::BinaryDir;
using testing::ConnectTo;
using testing::CreateToken;
using testing::HttpPort;
using testing::RunTool;
using testing::ServerProcess;
using testing::TempReleaseTree;
using testing::ToolRun;

constexpr char kImmutable[] = "public, max-age=31536000, immutable";
constexpr char kChannelMaxAge[] = "public, max-age=10";

std::string Quoted(const std::string& s) { return "\"" + s + "\""; }

// What Publish wrote.
struct Published {
  std::string big, big_hex;  // a blob of several chunks
  std::string small, small_hex;
  std::string catalog, catalog_hex;
  std::string channel;                 // v1/channels/nightly.json
  std::string corrupt, corrupt_hex;    // a blob holding other bytes than its name says
  std::string corrupt_catalog_hex;     // the same for a catalog
  std::string secret, secret_hex;      // a file beside the tree, linked from inside it
};

// A release as `impostor publish` lays it out, plus what must not be served.
Published Publish(const TempReleaseTree& tree) {
  Published p;
  p.big.resize(300000);
  for (size_t i = 0; i < p.big.size(); ++i) p.big[i] = static_cast<char>(i * 131 + (i >> 9));
  p.big_hex = tree.AddBlob(p.big);
  p.small = "{\"schema\":\"impostor-manifest\"}";
  p.small_hex = tree.AddBlob(p.small);
  p.catalog = "{\"assets\":{\"trees/oak\":{\"files\":[{\"name\":\"albedo_alpha.png\",\"sha256\":\"" + p.big_hex +
              "\",\"size_bytes\":300000},{\"name\":\"manifest.json\",\"sha256\":\"" + p.small_hex +
              "\",\"size_bytes\":30}]}},\"schema\":\"impostor-catalog\",\"schema_version\":1}";
  p.catalog_hex = tree.AddCatalog(p.catalog);
  p.channel = "{\"catalog\":{\"sha256\":\"" + p.catalog_hex + "\",\"size_bytes\":" +
              std::to_string(p.catalog.size()) + "},\"channel\":\"nightly\",\"schema\":\"impostor-channel\"}";
  tree.SetChannel("nightly", p.channel);
  // A publish cut short leaves its temporary channel file: never served.
  tree.Write("v1/channels/stable.json.tmp", p.channel);

  p.corrupt = "these are not the bytes that were published";
  p.corrupt_hex = Sha256Hex("the bytes that were published");
  tree.Write(TempReleaseTree::BlobPath(p.corrupt_hex), p.corrupt);
  p.corrupt_catalog_hex = Sha256Hex("a catalog that was published");
  tree.Write(TempReleaseTree::CatalogPath(p.corrupt_catalog_hex), "{\"forged\":true}");

  p.secret = "a secret beside the release tree";
  p.secret_hex = Sha256Hex(p.secret);
  {
    std::ofstream out(tree.outside() / p.secret_hex, std::ios::binary);
    out << p.secret;
  }
  fs::create_directories((tree.root() / TempReleaseTree::BlobPath(p.secret_hex)).parent_path());
  fs::create_symlink(tree.outside() / p.secret_hex, tree.root() / TempReleaseTree::BlobPath(p.secret_hex));
  fs::create_directories(tree.root() / "v1/catalogs/sha256");
  fs::create_symlink(tree.outside(), tree.root() / "v1/catalogs/sha256" / p.secret_hex.substr(0, 2));
  return p;
}

std::string Url(const std::string& relative) { return "/releases/" + relative; }

// A server with HTTP on and the tree served; a client that sends paths as
// given (no %-encoding of its own).
class OriginServer {
 public:
  OriginServer(const TempReleaseTree& tree, std::vector<std::string> extra_args)
      : server_(0, tree.dir() / "data", "127.0.0.1:0", Args(tree, std::move(extra_args))),
        port_(HttpPort(server_)),
        http_("127.0.0.1", port_) {
    http_.set_read_timeout(30, 0);
    http_.set_url_encode(false);
  }
  ServerProcess& server() { return server_; }
  int port() const { return port_; }
  httplib::Result Get(const std::string& target, httplib::Headers headers = {}) {
    return http_.Get(target, headers);
  }
  httplib::Result Head(const std::string& target, httplib::Headers headers = {}) {
    return http_.Head(target, headers);
  }
  httplib::Result Post(const std::string& target) { return http_.Post(target, "{}", "application/json"); }
  int Status(const std::string& target, httplib::Headers headers = {}) {
    auto res = Get(target, std::move(headers));
    return res ? res->status : -1;
  }

 private:
  static std::vector<std::string> Args(const TempReleaseTree& tree, std::vector<std::string> extra) {
    std::vector<std::string> args = {"--http-listen=127.0.0.1:0", "--http-releases=" + tree.root().string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }

  ServerProcess server_;
  const int port_;
  httplib::Client http_;
};

class OriginTest : public ::testing::Test {
 protected:
  OriginTest() : tree_(Name()), published_(Publish(tree_)), origin_(tree_, {}) {}

  static std::string Name() { return ::testing::UnitTest::GetInstance()->current_test_info()->name(); }

  // Declared first: removed after the server is gone.
  TempReleaseTree tree_;
  const Published published_;
  OriginServer origin_;
};

TEST_F(OriginTest, ServesBlobsAndCatalogsAsImmutableFilesNamedByTheirDigest) {
  struct Case {
    std::string relative;
    std::string bytes;
    std::string hex;
    std::string content_type;
  };
  const Published& p = published_;
  for (const Case& c : {Case{TempReleaseTree::BlobPath(p.big_hex), p.big, p.big_hex, "application/octet-stream"},
                        Case{TempReleaseTree::BlobPath(p.small_hex), p.small, p.small_hex, "application/octet-stream"},
                        Case{TempReleaseTree::CatalogPath(p.catalog_hex), p.catalog, p.catalog_hex,
                             "application/json"}}) {
    SCOPED_TRACE(c.relative);
    // Asking for compression changes nothing: bytes go as stored.
    auto res = origin_.Get(Url(c.relative), {{"Accept-Encoding", "gzip, br"}});
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 200) << res->body;
    EXPECT_TRUE(res->body == c.bytes) << "the body is not the file's bytes (" << res->body.size() << " bytes)";
    EXPECT_EQ(res->get_header_value("Cache-Control"), kImmutable);
    EXPECT_EQ(res->get_header_value("ETag"), Quoted(c.hex));
    EXPECT_EQ(res->get_header_value("Accept-Ranges"), "bytes");
    // A game's page on another origin (impostor-three) may read it.
    EXPECT_EQ(res->get_header_value("Access-Control-Allow-Origin"), "*");
    EXPECT_EQ(res->get_header_value("Content-Type"), c.content_type);
    EXPECT_EQ(res->get_header_value("Content-Length"), std::to_string(c.bytes.size()));
    EXPECT_EQ(res->get_header_value("Content-Encoding"), "");

    auto head = origin_.Head(Url(c.relative));
    ASSERT_TRUE(head);
    EXPECT_EQ(head->status, 200);
    EXPECT_EQ(head->body, "");
    EXPECT_EQ(head->get_header_value("Content-Length"), std::to_string(c.bytes.size()));
    EXPECT_EQ(head->get_header_value("ETag"), Quoted(c.hex));
    EXPECT_EQ(head->get_header_value("Cache-Control"), kImmutable);

    // A query (a cache buster) is ignored.
    auto busted = origin_.Get(Url(c.relative) + "?v=2");
    ASSERT_TRUE(busted);
    EXPECT_EQ(busted->status, 200);
    EXPECT_TRUE(busted->body == c.bytes);
  }
}

TEST_F(OriginTest, ChannelsAreReadAfreshEachTimeWithAShortMaxAge) {
  const std::string url = Url(TempReleaseTree::ChannelPath("nightly"));
  auto res = origin_.Get(url);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200) << res->body;
  EXPECT_EQ(res->body, published_.channel);
  EXPECT_EQ(res->get_header_value("Cache-Control"), kChannelMaxAge);
  EXPECT_EQ(res->get_header_value("ETag"), Quoted(Sha256Hex(published_.channel)));
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(res->get_header_value("Content-Encoding"), "");
  auto head = origin_.Head(url);
  ASSERT_TRUE(head);
  EXPECT_EQ(head->status, 200);
  EXPECT_EQ(head->get_header_value("Content-Length"), std::to_string(published_.channel.size()));

  // A publish renames a new channel file over it: the next request sees it,
  // and the old ETag no longer matches.
  const std::string next =
      "{\"channel\":\"nightly\",\"catalog\":{\"sha256\":\"" + published_.catalog_hex + "\"},\"n\":2}";
  tree_.SetChannel("nightly", next);
  auto again = origin_.Get(url, {{"If-None-Match", Quoted(Sha256Hex(published_.channel))}});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 200);
  EXPECT_EQ(again->body, next);
  EXPECT_EQ(again->get_header_value("ETag"), Quoted(Sha256Hex(next)));
}

TEST_F(OriginTest, IfNoneMatchIsNotModifiedForEveryKind) {
  const Published& p = published_;
  struct Case {
    std::string relative;
    std::string etag;
    std::string cache_control;
  };
  for (const Case& c : {Case{TempReleaseTree::BlobPath(p.big_hex), Quoted(p.big_hex), kImmutable},
                        Case{TempReleaseTree::CatalogPath(p.catalog_hex), Quoted(p.catalog_hex), kImmutable},
                        Case{TempReleaseTree::ChannelPath("nightly"), Quoted(Sha256Hex(p.channel)), kChannelMaxAge}}) {
    SCOPED_TRACE(c.relative);
    for (const std::string& header : {c.etag, "W/" + c.etag, "\"something-else\", " + c.etag, std::string("*")}) {
      auto res = origin_.Get(Url(c.relative), {{"If-None-Match", header}});
      ASSERT_TRUE(res) << header;
      EXPECT_EQ(res->status, 304) << header;
      EXPECT_EQ(res->body, "") << header;
      EXPECT_EQ(res->get_header_value("ETag"), c.etag) << header;
      EXPECT_EQ(res->get_header_value("Cache-Control"), c.cache_control) << header;
    }
    // Before Range, as the RFC orders them.
    auto ranged = origin_.Get(Url(c.relative), {{"If-None-Match", c.etag}, {"Range", "bytes=0-3"}});
    ASSERT_TRUE(ranged);
    EXPECT_EQ(ranged->status, 304);
    auto other = origin_.Get(Url(c.relative), {{"If-None-Match", "\"something-else\""}});
    ASSERT_TRUE(other);
    EXPECT_EQ(other->status, 200);
  }
}

TEST_F(OriginTest, AnswersOneRangeWith206AndOneOutsideWith416) {
  const std::string& big = published_.big;
  const std::string url = Url(TempReleaseTree::BlobPath(published_.big_hex));
  const std::string size = std::to_string(big.size());
  struct Case {
    std::string range;
    size_t offset;
    size_t length;
  };
  const std::vector<Case> cases = {
      {"bytes=10-19", 10, 10},
      {"bytes=0-0", 0, 1},
      {"bytes=-5", big.size() - 5, 5},
      {"bytes=299990-", 299990, 10},
      {"bytes=299997-400000", 299997, 3},  // the last byte past the end is clamped
      {"bytes=-400000", 0, big.size()},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.range);
    auto res = origin_.Get(url, {{"Range", c.range}});
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 206);
    EXPECT_EQ(res->get_header_value("Content-Range"), "bytes " + std::to_string(c.offset) + "-" +
                                                          std::to_string(c.offset + c.length - 1) + "/" + size);
    EXPECT_EQ(res->get_header_value("Content-Length"), std::to_string(c.length));
    EXPECT_TRUE(res->body == big.substr(c.offset, c.length)) << res->body.size() << " bytes";
    EXPECT_EQ(res->get_header_value("ETag"), Quoted(published_.big_hex));
    EXPECT_EQ(res->get_header_value("Content-Type"), "application/octet-stream");
  }
  for (const char* range : {"bytes=300000-", "bytes=400000-400010"}) {
    auto res = origin_.Get(url, {{"Range", range}});
    ASSERT_TRUE(res) << range;
    EXPECT_EQ(res->status, 416) << range;
    EXPECT_EQ(res->get_header_value("Content-Range"), "bytes */" + size) << range;
    EXPECT_EQ(res->body, "") << range;
  }
  // Several ranges, or an If-Range naming another version: the whole file.
  for (const httplib::Headers& headers :
       {httplib::Headers{{"Range", "bytes=0-1,5-6"}},
        httplib::Headers{{"Range", "bytes=0-1"}, {"If-Range", "\"another-version\""}}}) {
    auto res = origin_.Get(url, headers);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 200);
    EXPECT_TRUE(res->body == big);
    EXPECT_EQ(res->get_header_value("Content-Type"), "application/octet-stream");
  }
  auto if_range = origin_.Get(url, {{"Range", "bytes=0-1"}, {"If-Range", Quoted(published_.big_hex)}});
  ASSERT_TRUE(if_range);
  EXPECT_EQ(if_range->status, 206);
  // A channel's bytes by range too (what was read for this request).
  auto channel = origin_.Get(Url(TempReleaseTree::ChannelPath("nightly")), {{"Range", "bytes=0-0"}});
  ASSERT_TRUE(channel);
  EXPECT_EQ(channel->status, 206);
  EXPECT_EQ(channel->body, "{");
}

TEST_F(OriginTest, MissingFilesAndEveryOtherPathAre404) {
  const Published& p = published_;
  const std::string hh = p.big_hex.substr(0, 2);
  std::string upper = p.big_hex;
  for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"missing blob", Url(TempReleaseTree::BlobPath(Sha256Hex("never published")))},
      {"missing catalog", Url(TempReleaseTree::CatalogPath(Sha256Hex("never published")))},
      {"missing channel", Url(TempReleaseTree::ChannelPath("beta"))},
      {"a catalog's name under blobs", Url(TempReleaseTree::BlobPath(p.catalog_hex))},
      {"the prefix alone", "/releases/"},
      {"the prefix without slash", "/releases"},
      {"a folder", "/releases/v1/"},
      {"a blob folder", "/releases/v1/blobs/sha256/" + hh + "/"},
      {"the channels folder", "/releases/v1/channels"},
      {"upper-case digest", "/releases/v1/blobs/sha256/" + upper.substr(0, 2) + "/" + upper},
      {"wrong prefix folder", "/releases/v1/blobs/sha256/zz/" + p.big_hex},
      {"temporary channel file", "/releases/v1/channels/stable.json.tmp"},
      {"dot-dot", "/releases/v1/../../../../etc/passwd"},
      {"dot-dot to the api", "/releases/../api/v1/summary"},
      {"dot-dot inside a blob path", "/releases/v1/blobs/sha256/../sha256/" + hh + "/" + p.big_hex},
      {"encoded dot-dot", "/releases/%2e%2e/%2e%2e/%2e%2e/etc/passwd"},
      {"encoded dot-dot upper case", "/releases/v1/channels/%2E%2E%2F%2E%2E%2Fnightly.json"},
      {"encoded slashes of a good path", "/releases/v1%2fchannels%2fnightly.json"},
      {"encoded dot of a good path", "/releases/v1/channels/nightly%2ejson"},
      {"encoded prefix", "/%72eleases/v1/channels/nightly.json"},
      {"encoded newline", "/releases/v1/channels/night%0Aly.json"},
      {"link to a file out of the tree", Url(TempReleaseTree::BlobPath(p.secret_hex))},
      {"link to a folder out of the tree", Url(TempReleaseTree::CatalogPath(p.secret_hex))},
  };
  for (const auto& [what, target] : cases) {
    auto res = origin_.Get(target);
    ASSERT_TRUE(res) << what;
    EXPECT_EQ(res->status, 404) << what << ": " << target << " answered " << res->body;
    EXPECT_EQ(res->body.find(p.secret), std::string::npos) << what;
    EXPECT_EQ(res->body.find("impostor-channel"), std::string::npos) << what;
    if (res->status == 404 && target.starts_with("/releases/")) {
      EXPECT_EQ(res->get_header_value("Cache-Control"), "no-store") << what;
    }
  }
  auto head = origin_.Head(Url(TempReleaseTree::BlobPath(Sha256Hex("never published"))));
  ASSERT_TRUE(head);
  EXPECT_EQ(head->status, 404);
  // Nothing but GET and HEAD.
  auto post = origin_.Post(Url(TempReleaseTree::ChannelPath("nightly")));
  ASSERT_TRUE(post);
  EXPECT_EQ(post->status, 404);
}

TEST_F(OriginTest, ACorruptBlobOrCatalogIsNeverServed) {
  const Published& p = published_;
  const std::string url = Url(TempReleaseTree::BlobPath(p.corrupt_hex));
  for (const httplib::Headers& headers :
       {httplib::Headers{}, httplib::Headers{{"Range", "bytes=0-3"}}, httplib::Headers{{"If-None-Match", "*"}}}) {
    auto res = origin_.Get(url, headers);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 500);
    EXPECT_NE(res->body.find(TempReleaseTree::BlobPath(p.corrupt_hex)), std::string::npos) << res->body;
    EXPECT_NE(res->body.find(p.corrupt_hex), std::string::npos) << res->body;
    EXPECT_NE(res->body.find(Sha256Hex(p.corrupt)), std::string::npos) << res->body;
    EXPECT_EQ(res->body.find(p.corrupt), std::string::npos) << "the corrupt bytes went out: " << res->body;
    EXPECT_EQ(res->get_header_value("Cache-Control"), "no-store");
    EXPECT_EQ(res->get_header_value("ETag"), "");
  }
  auto head = origin_.Head(url);
  ASSERT_TRUE(head);
  EXPECT_EQ(head->status, 500);
  auto catalog = origin_.Get(Url(TempReleaseTree::CatalogPath(p.corrupt_catalog_hex)));
  ASSERT_TRUE(catalog);
  EXPECT_EQ(catalog->status, 500);
  EXPECT_EQ(catalog->body.find("forged"), std::string::npos) << catalog->body;

  // One structured line per corrupt file, however often it is asked for:
  // each 500 is logged (event=http_error) after the check that refused it.
  testing::ChildProcess& log = origin_.server().process();
  ASSERT_TRUE(log.WaitForLog("event=http_error", 5, std::chrono::seconds(30))) << log.Stderr();
  EXPECT_EQ(log.CountInLog("event=release_blob_corrupt kind=blob path=\"" + TempReleaseTree::BlobPath(p.corrupt_hex) +
                           "\""),
            1)
      << log.Stderr();
  EXPECT_EQ(log.CountInLog("event=release_blob_corrupt kind=catalog"), 1) << log.Stderr();
  EXPECT_EQ(log.CountInLog("actual_sha256=" + Sha256Hex(p.corrupt)), 1) << log.Stderr();
  // The good files beside it still serve.
  EXPECT_EQ(origin_.Status(Url(TempReleaseTree::BlobPath(p.big_hex))), 200);
}

// --auth token: game clients carry no farm token, so /releases/ is open
// unless --http-releases-require-token; the rest of the HTTP side is not.
// The local port of a connected or bound socket.
int LocalPort(int fd) {
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0 || addr.sin_family != AF_INET) return -1;
  return ntohs(addr.sin_port);
}

int PeerPort(int fd) {
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  if (::getpeername(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0 || addr.sin_family != AF_INET) return -1;
  return ntohs(addr.sin_port);
}

// TCP_NODELAY of the socket that process `pid` accepted from our end
// `client_port` on its port `server_port`, read through a duplicate of its
// descriptor (pidfd_getfd: the test started the server, so it may), or
// nullopt when no such socket is found.
std::optional<bool> AcceptedNoDelay(pid_t pid, int server_port, int client_port) {
  const int pidfd = static_cast<int>(::syscall(SYS_pidfd_open, pid, 0));
  if (pidfd < 0) {
    ADD_FAILURE() << "pidfd_open(" << pid << "): " << std::strerror(errno);
    return std::nullopt;
  }
  std::optional<bool> found;
  for (const fs::directory_entry& entry : fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd")) {
    std::error_code ec;
    if (fs::read_symlink(entry.path(), ec).string().rfind("socket:", 0) != 0) continue;
    const int fd = static_cast<int>(::syscall(SYS_pidfd_getfd, pidfd, std::stoi(entry.path().filename()), 0));
    if (fd < 0) continue;  // closed since the listing
    if (LocalPort(fd) == server_port && PeerPort(fd) == client_port) {
      int on = 0;
      socklen_t len = sizeof on;
      if (::getsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, &len) == 0) found = on != 0;
    }
    ::close(fd);
  }
  ::close(pidfd);
  return found;
}

// cpp-httplib writes a response's headers and its body in separate sends;
// with Nagle's algorithm on, every request after a kept-alive connection's
// first waited for the client's delayed ACK (40 ms a file: curl fetching a
// result's 39 files from the farm on one connection took 1.05 s, 0.09 s
// without). Asserted on the accepted socket itself, not by a clock.
TEST_F(OriginTest, ConnectionsSendWithoutNaglesDelay) {
  const int port = origin_.port();
  const int fd = ConnectTo(port);
  ASSERT_GE(fd, 0) << std::strerror(errno);
  // An answer means the server has accepted the connection.
  const std::string request = "GET " + Url(TempReleaseTree::ChannelPath("nightly")) +
                              " HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  ASSERT_EQ(::send(fd, request.data(), request.size(), MSG_NOSIGNAL), static_cast<ssize_t>(request.size()));
  char answer[16] = {};
  ASSERT_GT(::recv(fd, answer, sizeof answer - 1, 0), 0);
  EXPECT_EQ(std::string(answer).rfind("HTTP/1.1 200", 0), 0u) << answer;
  const std::optional<bool> no_delay = AcceptedNoDelay(origin_.server().process().pid(), port, LocalPort(fd));
  ::close(fd);
  ASSERT_TRUE(no_delay.has_value()) << "the server's end of the connection was not found";
  EXPECT_TRUE(*no_delay) << "the server's end of an HTTP connection has Nagle's algorithm on (TCP_NODELAY 0)";
}

TEST(OriginTokenTest, ReleasesAreOpenByDefaultAndTheRestIsNot) {
  TempReleaseTree tree("token_open");
  const Published p = Publish(tree);
  OriginServer origin(tree, {"--auth=token"});
  EXPECT_EQ(origin.Status(Url(TempReleaseTree::BlobPath(p.big_hex))), 200);
  EXPECT_EQ(origin.Status(Url(TempReleaseTree::ChannelPath("nightly"))), 200);
  EXPECT_EQ(origin.Status("/api/v1/summary"), 401);
  EXPECT_EQ(origin.Status("/metrics"), 401);
  // A path that decodes to somewhere else is still only a release path.
  for (const char* target : {"/releases/..%2f..%2fapi%2fv1%2fsummary", "/releases/../api/v1/summary",
                             "/releases/%2e%2e/metrics", "/releases/../metrics"}) {
    auto res = origin.Get(target);
    ASSERT_TRUE(res) << target;
    EXPECT_EQ(res->status, 404) << target << ": " << res->body;
    EXPECT_EQ(res->body.find("jobs"), std::string::npos) << target << ": " << res->body;
  }
}

TEST(OriginTokenTest, RequireTokenAsksForAReaderTokenAsTheApiDoes) {
  TempReleaseTree tree("token_required");
  const Published p = Publish(tree);
  OriginServer origin(tree, {"--auth=token", "--http-releases-require-token"});
  const std::string blob = Url(TempReleaseTree::BlobPath(p.big_hex));
  const std::string channel = Url(TempReleaseTree::ChannelPath("nightly"));
  for (const std::string& target : {blob, channel}) {
    auto res = origin.Get(target);
    ASSERT_TRUE(res) << target;
    EXPECT_EQ(res->status, 401) << target;
    EXPECT_NE(res->get_header_value("WWW-Authenticate").find("Bearer"), std::string::npos) << target;
    EXPECT_EQ(res->body.find(p.channel), std::string::npos) << target;
  }
  const std::string reader = CreateToken(origin.server().data_dir(), "reader", "game-build");
  ASSERT_FALSE(reader.empty());
  auto res = origin.Get(blob, {{"Authorization", "Bearer " + reader}});
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_TRUE(res->body == p.big);
  EXPECT_EQ(origin.Status(channel, {{"Authorization", "Bearer " + reader}}), 200);
  const std::string worker = CreateToken(origin.server().data_dir(), "worker", "a-worker");
  ASSERT_FALSE(worker.empty());
  EXPECT_EQ(origin.Status(blob, {{"Authorization", "Bearer " + worker}}), 403);
}

TEST(OriginFlagsTest, BadFlagsStopTheStartNamingWhatIsWrong) {
  TempReleaseTree tree("flags");
  const std::string missing = (tree.dir() / "no-such-tree").string();
  const std::string not_a_tree = tree.outside().string();  // a folder without v1/
  struct Case {
    std::string what;
    std::vector<std::string> args;
    std::vector<std::string> says;
  };
  const std::vector<Case> cases = {
      {"no --http-listen", {"--http-releases=" + tree.root().string()}, {"--http-releases", "--http-listen"}},
      {"missing directory",
       {"--http-listen=127.0.0.1:0", "--http-releases=" + missing},
       {"--http-releases", missing}},
      {"no v1/",
       {"--http-listen=127.0.0.1:0", "--http-releases=" + not_a_tree},
       {"--http-releases", not_a_tree, "v1/"}},
      {"a file",
       {"--http-listen=127.0.0.1:0", "--http-releases=" + (tree.root() / "v1/channels/nightly.json").string()},
       {"--http-releases", "not a directory"}},
      {"require-token alone",
       {"--http-listen=127.0.0.1:0", "--http-releases-require-token"},
       {"--http-releases-require-token", "needs --http-releases"}},
  };
  tree.SetChannel("nightly", "{}");
  for (const Case& c : cases) {
    std::vector<std::string> argv = {(BinaryDir() / "impostor-server").string(), "--listen=127.0.0.1:0",
                                     "--data=" + (tree.dir() / "data").string()};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const ToolRun run = RunTool(argv, std::chrono::seconds(60));
    EXPECT_EQ(run.exit_code, 2) << c.what << ": " << run.err;
    for (const std::string& text : c.says) {
      EXPECT_NE(run.err.find(text), std::string::npos) << c.what << ": stderr does not say " << text << ":\n"
                                                       << run.err;
    }
    EXPECT_EQ(run.out.find("listening on"), std::string::npos) << c.what;
  }
}

}  // namespace
}  // namespace impostor
