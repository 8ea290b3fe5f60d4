// The attack issue 14 starts from, against a real server with --auth token
// and a real worker: a process that is not a worker leases the artist's job
// and completes it with a forged (magenta) result. Without a token it is
// UNAUTHENTICATED; with a reader or submitter token PERMISSION_DENIED; the
// job stays queued, the real worker bakes it, and the artist's `impostor
// bake --token-file` gets the real atlas. Also: --local-workers run on a
// worker token the server mints itself, never on a command line.
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using grpc::StatusCode;

fs::path WriteTokenFile(const fs::path& dir, const std::string& name, const std::string& token) {
  const fs::path path = dir / (name + ".token");
  std::ofstream(path) << token << "\n";
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write);
  return path;
}

// The forged manifest the attacker sends: every map and the manifest.json
// point at one magenta blob.
v1::Manifest Forged(const std::string& cache_key, const v1::Digest& magenta) {
  v1::Manifest m;
  m.set_format_version(1);
  m.set_cache_key(cache_key);
  m.set_frames(3);
  m.set_resolution(64);
  for (const char* semantic : {"albedo_alpha", "normal_depth", "orm"}) {
    v1::MapFile* map = m.add_maps();
    map->set_semantic(semantic);
    map->set_file(std::string(semantic) + ".png");
    *map->mutable_digest() = magenta;
  }
  *m.mutable_manifest_json() = magenta;
  return m;
}

TEST(AuthBake, ForgedResultIsRefusedAndTheRealBakeIsReturned) {
  ServerProcess server(0, {"--auth=token"});
  const fs::path dir = NewTempDir("auth_bake_tokens");
  const std::string submitter = CreateToken(server.data_dir(), "submitter", "artist");
  const std::string reader = CreateToken(server.data_dir(), "reader", "game");
  const std::string worker = CreateToken(server.data_dir(), "worker", "render-node-1");
  ASSERT_FALSE(submitter.empty() || reader.empty() || worker.empty());
  server.UseToken(submitter);

  const fs::path box = AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb";
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = UploadGlb(server.assets(), box);
  request.mutable_parameters()->set_frames(3);
  request.mutable_parameters()->set_resolution(64);
  v1::SubmitBakeResponse submitted;
  {
    auto ctx = ContextWithin();
    ASSERT_TRUE(server.bake().SubmitBake(ctx.get(), request, &submitted).ok());
  }
  ASSERT_FALSE(submitted.cached());

  // The attacker, on a channel of its own.
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  auto channel = grpc::CreateCustomChannel(server.address(), grpc::InsecureChannelCredentials(), args);
  auto workers = v1::WorkerService::NewStub(channel);
  auto assets = v1::AssetService::NewStub(channel);
  const std::string magenta = "\x89PNG\r\n\x1a\n forged magenta atlas";
  const v1::Digest magenta_digest = DigestOf(magenta);
  struct Attacker {
    const char* name;
    std::string authorization;
    StatusCode code;
  } attackers[] = {{"no token", "", StatusCode::UNAUTHENTICATED},
                   {"reader", "Bearer " + reader, StatusCode::PERMISSION_DENIED},
                   {"submitter", "Bearer " + submitter, StatusCode::PERMISSION_DENIED}};
  for (const Attacker& a : attackers) {
    auto lease_ctx = ContextWithAuthorization(a.authorization);
    v1::LeaseJobRequest lease;
    lease.set_worker_id("intruder");
    v1::LeaseJobResponse leased;
    const grpc::Status l = workers->LeaseJob(lease_ctx.get(), lease, &leased);
    EXPECT_EQ(l.error_code(), a.code) << "LeaseJob as " << a.name << ": " << l.error_message();
    EXPECT_FALSE(leased.has_job()) << a.name;

    auto complete_ctx = ContextWithAuthorization(a.authorization);
    v1::CompleteJobRequest complete;
    complete.set_job_id(submitted.job_id());
    complete.set_lease_id("lease-guessed");
    *complete.mutable_result() = Forged(submitted.cache_key(), magenta_digest);
    v1::CompleteJobResponse completed;
    const grpc::Status c = workers->CompleteJob(complete_ctx.get(), complete, &completed);
    EXPECT_EQ(c.error_code(), a.code) << "CompleteJob as " << a.name << ": " << c.error_message();
  }
  {
    // Readers cannot even upload the forged bytes.
    auto ctx = ContextWithAuthorization("Bearer " + reader);
    v1::UploadBlobResponse response;
    auto writer = assets->UploadBlob(ctx.get(), &response);
    v1::UploadBlobRequest chunk;
    *chunk.mutable_digest() = magenta_digest;
    chunk.set_data(magenta);
    writer->Write(chunk);
    writer->WritesDone();
    EXPECT_EQ(writer->Finish().error_code(), StatusCode::PERMISSION_DENIED);
  }
  {
    auto ctx = ContextWithin();
    v1::GetJobRequest get;
    get.set_job_id(submitted.job_id());
    v1::Job job;
    ASSERT_TRUE(server.bake().GetJob(ctx.get(), get, &job).ok());
    EXPECT_EQ(job.state(), v1::JOB_STATE_QUEUED);
    EXPECT_EQ(job.attempts(), 0u);
  }

  // The real worker, on its own token file.
  auto real = StartWorker(server.address(),
                          {"--token-file=" + WriteTokenFile(dir, "worker", worker).string(), "--max-jobs=1"});
  const v1::Job done = WatchToEnd(server.bake(), submitted.job_id());
  ASSERT_EQ(done.state(), v1::JOB_STATE_SUCCEEDED) << done.error().message();
  ASSERT_GT(done.result().maps_size(), 0);
  for (const auto& map : done.result().maps()) EXPECT_NE(map.digest().hash(), magenta_digest.hash()) << map.file();
  EXPECT_NE(done.worker_id(), "intruder");
  EXPECT_TRUE(server.process().WaitForLog("event=audit token=\"render-node-1\" role=worker rpc=CompleteJob"));

  // The artist's CLI, with its token file, gets the real atlas.
  const fs::path out = dir / "out";
  const fs::path submitter_file = WriteTokenFile(dir, "artist", submitter);
  const std::string cli = (BinaryDir() / "impostor").string();
  const ToolRun bake = RunTool({cli, "bake", box.string(), "--frames", "3", "--resolution", "64", "--out", out.string(),
                                "--json", "--server", server.address(), "--token-file", submitter_file.string()});
  ASSERT_EQ(bake.exit_code, 0) << bake.err;
  EXPECT_TRUE(nlohmann::json::parse(bake.out).at("cached").get<bool>());
  for (const auto& map : done.result().maps()) {
    EXPECT_EQ(DigestOf(ReadFileBytes(out / map.file())).hash(), map.digest().hash()) << map.file();
  }

  // Without a token, and with a reader's (IMPOSTOR_TOKEN), the CLI is refused
  // with the reason.
  const ToolRun anonymous = RunTool({cli, "bake", box.string(), "--frames", "3", "--resolution", "64", "--out",
                                     (dir / "anon").string(), "--server", server.address()},
                                    kExitTimeout, {"IMPOSTOR_TOKEN="});
  EXPECT_NE(anonymous.exit_code, 0);
  EXPECT_NE(anonymous.err.find("UNAUTHENTICATED"), std::string::npos) << anonymous.err;
  const ToolRun as_reader = RunTool({cli, "bake", box.string(), "--frames", "3", "--resolution", "64", "--out",
                                     (dir / "reader").string(), "--server", server.address()},
                                    kExitTimeout, {"IMPOSTOR_TOKEN=" + reader});
  EXPECT_NE(as_reader.exit_code, 0);
  EXPECT_NE(as_reader.err.find("PERMISSION_DENIED"), std::string::npos) << as_reader.err;
  EXPECT_NE(as_reader.err.find("needs role"), std::string::npos) << as_reader.err;
  // A worker with a missing token file stops at once, naming it.
  const ToolRun bad_worker =
      RunTool({(BinaryDir() / "impostor-worker").string(), "--server=" + server.address(),
               "--token-file=" + (dir / "missing.token").string()},
              kStartTimeout);
  EXPECT_EQ(bad_worker.exit_code, 2);
  EXPECT_NE(bad_worker.err.find("--token-file: cannot read"), std::string::npos) << bad_worker.err;
}

TEST(AuthBake, LocalWorkersRunOnATokenTheServerMints) {
  ServerProcess server(1, {"--auth=token"});
  const std::string submitter = CreateToken(server.data_dir(), "submitter", "artist");
  ASSERT_FALSE(submitter.empty());
  const fs::path token_file = server.data_dir() / "local-workers.token";
  struct stat st {};
  ASSERT_EQ(::stat(token_file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  const std::string minted = ReadFileBytes(token_file).substr(0, 47);
  // The secret is on no process's command line.
  for (const auto& entry : fs::directory_iterator("/proc")) {
    std::string cmdline = ReadFileBytes(entry.path() / "cmdline");
    if (cmdline.find("impostor-worker") == std::string::npos) continue;
    EXPECT_EQ(cmdline.find(minted), std::string::npos) << entry.path();
  }
  const fs::path out = NewTempDir("auth_local_out");
  const ToolRun bake = RunTool({(BinaryDir() / "impostor").string(), "bake",
                                (AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb").string(), "--frames", "3",
                                "--resolution", "64", "--out", out.string(), "--server", server.address()},
                               kExitTimeout, {"IMPOSTOR_TOKEN=" + submitter});
  EXPECT_EQ(bake.exit_code, 0) << bake.err;
  EXPECT_TRUE(fs::exists(out / "albedo_alpha.png"));
  EXPECT_TRUE(server.process().WaitForLog("event=audit token=\"local-workers\" role=worker rpc=CompleteJob"));
}

TEST(AuthBake, LocalWorkersWhoseTokenIsRevokedStopInsteadOfRestartingForever) {
  ServerProcess server(1, {"--auth=token", "--token-cache-ttl-ms=0"});
  ASSERT_TRUE(server.process().WaitForLog("event=worker_ready")) << server.process().Stderr();
  const ToolRun revoked = RunTool({(BinaryDir() / "impostor-server").string(), "token", "revoke",
                                   "--data=" + server.data_dir().string(), "--name=local-workers"},
                                  kStartTimeout);
  ASSERT_EQ(revoked.exit_code, 0) << revoked.err;
  // The worker's next lease is refused; it exits 4 and is parked, once.
  ASSERT_TRUE(server.process().WaitForLog("event=local_worker_parked")) << server.process().Stderr();
  EXPECT_EQ(server.process().CountInLog("event=local_worker_parked"), 1);
  EXPECT_EQ(server.process().CountInLog("event=worker_exited"), 0) << "not scheduled for a restart";
  EXPECT_TRUE(server.process().CountInLog("restart impostor-server to mint a new one") == 1);
  EXPECT_TRUE(server.process().Running()) << "the farm keeps serving";
}

// A lease id is no key for another worker token: only the token that took
// the lease may report on it (the result's baked_by names that token).
TEST(AuthBake, OnlyTheWorkerTokenHoldingALeaseMayReportOnIt) {
  ServerProcess server(0, {"--auth=token", "--token-cache-ttl-ms=0"});
  const std::string submitter = CreateToken(server.data_dir(), "submitter", "artist");
  const std::string holder = CreateToken(server.data_dir(), "worker", "render-node-1");
  const std::string other = CreateToken(server.data_dir(), "worker", "render-node-2");
  ASSERT_FALSE(submitter.empty() || holder.empty() || other.empty());
  server.UseToken(submitter);
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
  request.mutable_parameters()->set_frames(3);
  request.mutable_parameters()->set_resolution(64);
  v1::SubmitBakeResponse submitted;
  ASSERT_TRUE(server.bake().SubmitBake(ContextWithin().get(), request, &submitted).ok());

  auto workers = v1::WorkerService::NewStub(
      grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials()));
  v1::LeaseJobRequest lease;
  lease.set_worker_id("node-1");
  v1::LeaseJobResponse leased;
  ASSERT_TRUE(workers->LeaseJob(ContextWithAuthorization("Bearer " + holder).get(), lease, &leased).ok());
  ASSERT_TRUE(leased.has_job());
  ASSERT_EQ(leased.job().job_id(), submitted.job_id());

  // The other token, with the holder's lease id: refused, naming why.
  v1::ReportProgressRequest progress;
  progress.set_job_id(leased.job().job_id());
  progress.set_lease_id(leased.job().lease_id());
  progress.set_progress(0.5f);
  v1::ReportProgressResponse progressed;
  const grpc::Status p =
      workers->ReportProgress(ContextWithAuthorization("Bearer " + other).get(), progress, &progressed);
  EXPECT_EQ(p.error_code(), StatusCode::PERMISSION_DENIED) << p.error_message();
  EXPECT_NE(p.error_message().find("leased by another worker token"), std::string::npos) << p.error_message();
  v1::FailJobRequest fail;
  fail.set_job_id(leased.job().job_id());
  fail.set_lease_id(leased.job().lease_id());
  fail.mutable_error()->set_code(13);
  fail.mutable_error()->set_message("sabotage");
  v1::FailJobResponse failed;
  EXPECT_EQ(workers->FailJob(ContextWithAuthorization("Bearer " + other).get(), fail, &failed).error_code(),
            StatusCode::PERMISSION_DENIED);
  // The holder itself goes on.
  EXPECT_TRUE(
      workers->ReportProgress(ContextWithAuthorization("Bearer " + holder).get(), progress, &progressed).ok());
  v1::GetJobRequest get;
  get.set_job_id(submitted.job_id());
  v1::Job job;
  ASSERT_TRUE(server.bake().GetJob(ContextWithin().get(), get, &job).ok());
  EXPECT_EQ(job.state(), v1::JOB_STATE_RUNNING);
}

}  // namespace
}  // namespace impostor::testing
