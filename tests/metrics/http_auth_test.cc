// The HTTP side of a farm run with --auth token (issues 14 and 16): nothing
// but /healthz, /readyz and /login answers without a token; reader,
// submitter and admin tokens see the dashboard, the API and /metrics, a
// worker token does not; /login turns a good token into an HttpOnly cookie;
// a job's uploaded mesh is readable only by its submitter or an admin.
#include <gtest/gtest.h>

#include "tests/support/server_process.h"
#include "tests/metrics/http_test_client.h"

namespace impostor {
namespace {

using testing::AssetsDir;
using testing::ContextWithin;
using testing::CreateToken;
using testing::ServerProcess;

using Http = testing::HttpTestClient;
using testing::HttpPort;

class HttpAuth : public ::testing::Test {
 protected:
  HttpAuth() : server_(/*local_workers=*/0, {"--auth=token", "--http-listen=127.0.0.1:0"}), http_(HttpPort(server_)) {}
  ServerProcess server_;
  Http http_;
};

TEST_F(HttpAuth, NothingButHealthAndLoginAnswersWithoutAToken) {
  EXPECT_EQ(http_.Status("/healthz"), 200);
  EXPECT_EQ(http_.Status("/readyz"), 200);
  EXPECT_EQ(http_.Status("/login"), 200);
  for (const char* path :
       {"/metrics", "/api/v1/summary", "/api/v1/jobs", "/api/v1/workers", "/api/v1/pools", "/api/v1/results"}) {
    auto res = http_.Get(path);
    ASSERT_TRUE(res) << path;
    EXPECT_EQ(res->status, 401) << path;
    EXPECT_NE(res->get_header_value("WWW-Authenticate").find("Bearer"), std::string::npos) << path;
    EXPECT_NE(res->body.find("no token"), std::string::npos) << path << ": " << res->body;
  }
  // A browser page goes to the login form instead.
  auto page = http_.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 303);
  EXPECT_EQ(page->get_header_value("Location"), "/login");
}

TEST_F(HttpAuth, ReaderSubmitterAndAdminSeeTheFarmAWorkerTokenDoesNot) {
  for (const char* role : {"reader", "submitter", "admin"}) {
    const std::string token = CreateToken(server_.data_dir(), role, std::string("http-") + role);
    ASSERT_FALSE(token.empty());
    EXPECT_EQ(http_.Status("/metrics", token), 200) << role;
    EXPECT_EQ(http_.Status("/api/v1/summary", token), 200) << role;
    EXPECT_EQ(http_.Status("/api/v1/jobs", token), 200) << role;
  }
  const std::string worker = CreateToken(server_.data_dir(), "worker", "http-worker");
  auto res = http_.Get("/api/v1/summary", worker);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403);
  EXPECT_NE(res->body.find("role worker"), std::string::npos) << res->body;
  EXPECT_EQ(res->body.find(worker), std::string::npos) << "the secret is echoed";

  const std::string unknown = "imp_AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA";
  res = http_.Get("/metrics", unknown);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 401);
  EXPECT_EQ(res->body.find(unknown), std::string::npos) << "the secret is echoed";
  // Each refusal is one log line, as on the gRPC side; never the secret.
  EXPECT_TRUE(server_.process().WaitForLog("event=auth_refused listener=http method=GET path=\"/metrics\"", 1,
                                           std::chrono::seconds(10)))
      << server_.process().Stderr();
  EXPECT_TRUE(server_.process().WaitForLog("event=auth_refused listener=http method=GET path=\"/api/v1/summary\"", 1,
                                           std::chrono::seconds(10)))
      << "the worker token's 403: " << server_.process().Stderr();
  EXPECT_EQ(server_.process().Stderr().find(unknown), std::string::npos) << "the secret is logged";
}

TEST_F(HttpAuth, LoginSetsAnHttpOnlyCookieThatOpensThePagesAndRefusesABadToken) {
  const std::string reader = CreateToken(server_.data_dir(), "reader", "browser");
  auto bad = http_.client.Post("/login", "token=imp_not-a-real-token", "application/x-www-form-urlencoded");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 401);
  EXPECT_TRUE(bad->get_header_value("Set-Cookie").empty());
  EXPECT_NE(bad->body.find("id=\"login-error\""), std::string::npos) << bad->body;

  auto good = http_.client.Post("/login", "token=" + reader, "application/x-www-form-urlencoded");
  ASSERT_TRUE(good);
  EXPECT_EQ(good->status, 303);
  EXPECT_EQ(good->get_header_value("Location"), "/");
  const std::string set_cookie = good->get_header_value("Set-Cookie");
  EXPECT_EQ(set_cookie.rfind("impostor_token=" + reader + ";", 0), 0u) << set_cookie;
  EXPECT_NE(set_cookie.find("HttpOnly"), std::string::npos);
  EXPECT_NE(set_cookie.find("SameSite=Strict"), std::string::npos);

  const std::string cookie = "theme=dark; impostor_token=" + reader;
  auto summary = http_.Get("/api/v1/summary", "", cookie);
  ASSERT_TRUE(summary);
  EXPECT_EQ(summary->status, 200) << summary->body;
  auto page = http_.Get("/", "", cookie);
  ASSERT_TRUE(page);
  EXPECT_NE(page->status, 303);
  EXPECT_NE(page->status, 401);
}

TEST_F(HttpAuth, AJobsMeshIsReadableOnlyByItsSubmitterOrAnAdmin) {
  const std::string owner = CreateToken(server_.data_dir(), "submitter", "mesh-owner");
  const std::string other = CreateToken(server_.data_dir(), "submitter", "someone-else");
  const std::string reader = CreateToken(server_.data_dir(), "reader", "mesh-reader");
  const std::string admin = CreateToken(server_.data_dir(), "admin", "mesh-admin");
  server_.UseToken(owner);
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = testing::UploadGlb(server_.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  request.mutable_parameters()->set_frames(4);
  request.mutable_parameters()->set_resolution(128);
  v1::SubmitBakeResponse submitted;
  const grpc::Status s = server_.bake().SubmitBake(ContextWithin().get(), request, &submitted);
  ASSERT_TRUE(s.ok()) << s.error_message();

  const std::string mesh = "/api/v1/jobs/" + submitted.job_id() + "/mesh/" + request.mesh().entry().path();
  EXPECT_EQ(http_.Status(mesh, owner), 200);
  EXPECT_EQ(http_.Status(mesh, admin), 200);
  EXPECT_EQ(http_.Status(mesh, other), 403);
  auto res = http_.Get(mesh, reader);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 403);
  EXPECT_NE(res->body.find("only the token that submitted the job or an admin"), std::string::npos) << res->body;
  // The job itself (no mesh bytes) is on the dashboard for every reader,
  // but its input digests only for the submitter and admins: with a digest,
  // anyone could name the blob in a SubmitBake of their own and read it
  // back through that job's mesh.
  const std::string job = "/api/v1/jobs/" + submitted.job_id();
  const std::string digest = request.mesh().entry().digest().hash();
  for (const std::string* token : {&reader, &other}) {
    auto seen = http_.Get(job, *token);
    ASSERT_TRUE(seen);
    EXPECT_EQ(seen->status, 200);
    EXPECT_EQ(seen->body.find(digest), std::string::npos) << seen->body;
    EXPECT_NE(seen->body.find("\"digests_hidden\":true"), std::string::npos) << seen->body;
    auto listed = http_.Get("/api/v1/jobs", *token);
    ASSERT_TRUE(listed);
    EXPECT_EQ(listed->body.find(digest), std::string::npos) << listed->body;
  }
  for (const std::string* token : {&owner, &admin}) {
    auto seen = http_.Get(job, *token);
    ASSERT_TRUE(seen);
    EXPECT_NE(seen->body.find(digest), std::string::npos) << seen->body;
  }
}

}  // namespace
}  // namespace impostor
