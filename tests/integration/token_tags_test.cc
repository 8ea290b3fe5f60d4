// Default required tags per token (issue 44) against a real server with
// --auth token and real workers (lavapipe): every bake submitted with a token
// made by `impostor-server token create --require-tag team-forest` requires
// that tag besides the request's own, so a worker with only the request's tag
// is never leased it while one with both bakes it. The tags are not part of
// the cache key: the result is then served to any token, tags or not.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

fs::path WriteTokenFile(const fs::path& dir, const std::string& name, const std::string& token) {
  const fs::path path = dir / (name + ".token");
  std::ofstream(path) << token << "\n";
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write);
  return path;
}

grpc::Status Submit(ServerProcess& server, const v1::SubmitBakeRequest& request, v1::SubmitBakeResponse* response) {
  auto ctx = ContextWithin();
  return server.bake().SubmitBake(ctx.get(), request, response);
}

TEST(TokenTags, ATokensDefaultTagKeepsItsBakesOffAWorkerWithoutIt) {
  ServerProcess server(0, {"--auth=token"});
  const fs::path dir = NewTempDir("token_tags");
  const ToolRun created =
      RunTool({(BinaryDir() / "impostor-server").string(), "token", "create", "--data=" + server.data_dir().string(),
               "--role=submitter", "--name=forest-ci", "--require-tag=team-forest"},
              kStartTimeout);
  ASSERT_EQ(created.exit_code, 0) << created.err;
  const std::string forest = created.out.substr(0, created.out.find('\n'));
  const std::string artist = CreateToken(server.data_dir(), "submitter", "artist");
  const std::string gpu_node = CreateToken(server.data_dir(), "worker", "gpu-node");
  const std::string forest_node = CreateToken(server.data_dir(), "worker", "forest-node");
  ASSERT_FALSE(artist.empty() || gpu_node.empty() || forest_node.empty());

  // A worker with the request's tag but not the token's, polling before the
  // bake is submitted and all the while it waits.
  auto gpu = StartWorker(server.address(), {"--name=gpu-node", "--tags=gpu",
                                            "--token-file=" + WriteTokenFile(dir, "gpu-node", gpu_node).string()});
  server.UseToken(forest);
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  request.mutable_parameters()->set_frames(3);
  request.mutable_parameters()->set_resolution(64);
  request.add_required_tags("gpu");
  v1::SubmitBakeResponse submitted;
  ASSERT_TRUE(Submit(server, request, &submitted).ok());
  ASSERT_FALSE(submitted.cached());

  // The union of both lists is what placement waits for (the gpu worker
  // asked and was refused), never a failed attempt on it.
  const std::string wanted = "waiting for a worker tagged gpu, team-forest";
  const v1::Job waiting = WatchUntil(server.bake(), submitted.job_id(), [&](const v1::Job& j) {
    return j.stage().rfind(wanted, 0) == 0 || IsTerminalState(j.state());
  });
  ASSERT_EQ(waiting.stage().rfind(wanted, 0), 0u) << waiting.stage();
  EXPECT_EQ(waiting.state(), v1::JOB_STATE_QUEUED);
  EXPECT_EQ(waiting.attempts(), 0u);

  auto forest_worker =
      StartWorker(server.address(), {"--name=forest-node", "--tags=gpu,team-forest",
                                     "--token-file=" + WriteTokenFile(dir, "forest-node", forest_node).string()});
  const v1::Job done = WatchToEnd(server.bake(), submitted.job_id());
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  // A worker's id is its --name and its pid.
  EXPECT_EQ(done.worker_id().rfind("forest-node-", 0), 0u) << done.worker_id();
  EXPECT_EQ(done.attempts(), 1u);
  for (const v1::JobAttempt& a : done.attempt_history()) {
    EXPECT_EQ(a.worker_id().rfind("forest-node-", 0), 0u) << a.worker_id();
  }
  EXPECT_TRUE(gpu->Running()) << "the gpu worker was polling all along";

  // Cached for everyone: the token's tags, like the request's, are not in
  // the key, and no tagged worker needs to be there any more.
  forest_worker->KillAndReap();
  for (const std::string& token : {forest, artist}) {
    server.UseToken(token);
    v1::SubmitBakeResponse again;
    v1::SubmitBakeRequest untagged = request;
    untagged.clear_required_tags();
    ASSERT_TRUE(Submit(server, untagged, &again).ok());
    EXPECT_TRUE(again.cached()) << (token == forest ? "forest-ci" : "artist");
    EXPECT_EQ(again.cache_key(), submitted.cache_key());
  }

  // Together the request's and the token's tags stay within 16.
  server.UseToken(forest);
  v1::SubmitBakeRequest crowded = request;
  crowded.clear_required_tags();
  for (int i = 0; i < 16; ++i) crowded.add_required_tags("t" + std::to_string(i));
  v1::SubmitBakeResponse refused;
  const grpc::Status over = Submit(server, crowded, &refused);
  EXPECT_EQ(over.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(over.error_message().find("token 'forest-ci''s 1 default tags make 17, over the limit of 16"),
            std::string::npos)
      << over.error_message();
}

}  // namespace
}  // namespace impostor::testing
