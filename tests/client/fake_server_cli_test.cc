// The `impostor` tool itself against the fake impostor.v1 services
// (fake_server.h): a bake that uploads, watches, fetches and prints JSON,
// exit codes and one-line errors, and the lost-server / back lines.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/client/fake_server.h"

namespace impostor::sdk {
namespace {

struct CliRun {
  int exit_code;
  std::string out;  // stdout
  std::string err;  // stderr
};

// Runs the `impostor` tool against the fake server.
CliRun RunCli(const std::string& args, const fs::path& scratch) {
  fs::create_directories(scratch);
  const fs::path out = scratch / "cli.stdout", err = scratch / "cli.stderr";
  const std::string command = std::string(IMPOSTOR_CLI_PATH) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(command.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, ReadAll(out), ReadAll(err)};
}

TEST_F(FakeServerTest, CliBakeUploadsWatchesFetchesAndPrintsJson) {
  AddResult(std::string(64, 'a'));  // the key the fake's SubmitBake answers
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{MakeJob(v1::JOB_STATE_QUEUED, 0, ""), MakeJob(v1::JOB_STATE_RUNNING, 0.42f, "render"),
                            MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")}};
  }
  const fs::path out_dir = dir_ / "atlas";
  CliRun run = RunCli("bake " + (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string() + " --out " +
                          out_dir.string() + " --server 127.0.0.1:" + std::to_string(port_) + " --json",
                      dir_ / "io");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["job_id"], "job-1");
  EXPECT_EQ(j["cache_key"], std::string(64, 'a'));
  EXPECT_EQ(j["manifest"], (out_dir / "manifest.json").string());
  EXPECT_EQ(j["files"].size(), 3u);
  EXPECT_TRUE(j["error"].is_null());
  EXPECT_GT(j["uploaded_bytes"].get<int64_t>(), 0);
  EXPECT_NE(run.err.find("[running  42%] render"), std::string::npos) << run.err;
  EXPECT_EQ(ReadAll(out_dir / "albedo_alpha.png"), contents_["albedo_alpha.png"]);
}

TEST_F(FakeServerTest, CliBakeRefusedByServerExitsOneWithOneLine) {
  CliRun run = RunCli("bake " + (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string() + " --out " +
                          (dir_ / "atlas").string() + " --frames 80 --server 127.0.0.1:" + std::to_string(port_),
                      dir_ / "io");
  EXPECT_EQ(run.exit_code, 1);
  // The server's API name becomes the flag the user typed, the API name kept.
  EXPECT_EQ(run.err,
            "impostor: bake failed: INVALID_ARGUMENT: --frames (parameters.frames): 80 is out of range 2..64\n");
}

TEST_F(FakeServerTest, CliFailedBakeExitsOneWithServerReason) {
  v1::Job failed = MakeJob(v1::JOB_STATE_FAILED, 0.2f, "load");
  failed.mutable_error()->set_code(3);
  failed.mutable_error()->set_message("mesh: no triangles");
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{failed}, {failed}};
  }
  CliRun run = RunCli("bake " + (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string() + " --out " +
                          (dir_ / "atlas").string() + " --quiet --server 127.0.0.1:" + std::to_string(port_),
                      dir_ / "io");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err, "impostor: bake failed: INVALID_ARGUMENT: mesh: no triangles\n");
  EXPECT_EQ(run.out, "");
  // --json: the same stderr line; the object's error is "CODE: message",
  // without the "bake failed: " the line has.
  CliRun json_run = RunCli("bake " + (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string() + " --out " +
                               (dir_ / "atlas").string() + " --quiet --json --server 127.0.0.1:" +
                               std::to_string(port_),
                           dir_ / "io");
  EXPECT_EQ(json_run.exit_code, 1);
  EXPECT_EQ(json_run.err, "impostor: bake failed: INVALID_ARGUMENT: mesh: no triangles\n");
  const nlohmann::json j = nlohmann::json::parse(json_run.out, nullptr, /*allow_exceptions=*/false);
  ASSERT_TRUE(j.is_object()) << json_run.out;
  EXPECT_EQ(j["error"], "INVALID_ARGUMENT: mesh: no triangles") << json_run.out;
  EXPECT_EQ(j["exit_code"], 1) << json_run.out;
}

TEST_F(FakeServerTest, CliPrintsOneLineWhenItLosesTheServerAndOneWhenItIsBack) {
  AddResult(std::string(64, 'a'));  // the key the fake's SubmitBake answers
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_scripts = {{MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render")}, {MakeJob(v1::JOB_STATE_SUCCEEDED, 1, "")}};
    fake_.get_job = MakeJob(v1::JOB_STATE_RUNNING, 0.1f, "render");
    fake_.get_job_unavailable = 6;  // more than the default max_attempts (5)
  }
  const std::string server = "127.0.0.1:" + std::to_string(port_);
  const std::string model = (kAssets / "props_pbr/Box/glTF-Binary/Box.glb").string();
  CliRun run = RunCli("bake " + model + " --out " + (dir_ / "atlas").string() + " --server " + server +
                          " --max-outage-seconds 60",
                      dir_ / "io");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::vector<std::string> lost, back;
  std::istringstream lines(run.err);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("impostor: lost server ", 0) == 0) lost.push_back(line);
    if (line.rfind("impostor: server ", 0) == 0) back.push_back(line);
  }
  ASSERT_EQ(lost.size(), 1u) << run.err;
  EXPECT_EQ(lost[0].rfind("impostor: lost server " + server + " (UNAVAILABLE: ", 0), 0u) << lost[0];
  EXPECT_NE(lost[0].find("; retrying for up to 60 s"), std::string::npos) << lost[0];
  ASSERT_EQ(back.size(), 1u) << run.err;
  EXPECT_EQ(back[0].rfind("impostor: server " + server + " is back after ", 0), 0u) << back[0];
  EXPECT_EQ(ReadAll(dir_ / "atlas" / "albedo_alpha.png"), contents_["albedo_alpha.png"]);

  // --quiet silences both lines.
  {
    std::lock_guard lock(fake_.mu);
    fake_.watch_calls = 0;
    fake_.get_job_unavailable = 2;
  }
  run = RunCli("bake " + model + " --out " + (dir_ / "atlas2").string() + " --server " + server + " --quiet",
               dir_ / "io");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");
}

}  // namespace
}  // namespace impostor::sdk
