// How `impostor` reports what it refuses or is refused: the exit code of a
// server's refusal (1: the same command gets the same answer; 3: worth
// retrying) and the --json object on every outcome, a refused command line
// included. Real impostor-server and `impostor` processes on loopback; no
// worker is needed.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/integration/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Impostor() { return (BinaryDir() / "impostor").string(); }
fs::path Box() { return AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb"; }

// No token, a malformed one and a reader's: refusals that no retry fixes,
// exit 1 (the help's "the server refused the request"), from every command
// that talks to the server.
TEST(CliRefusals, AuthRefusalsExitOneNotThree) {
  ServerProcess server(0, {"--auth=token"});
  const fs::path dir = NewTempDir("cli_auth_refusals");
  std::ofstream(dir / "malformed.token") << "not-a-token\n";
  std::ofstream(dir / "reader.token") << CreateToken(server.data_dir(), "reader", "rd") << "\n";
  std::ofstream(dir / "spec.json") << json{{"assets", {Box().string()}}}.dump();
  const std::string key(64, 'a');
  const struct {
    const char* name;
    std::vector<std::string> token_args;
    const char* code;
  } tokens[] = {
      {"no token", {}, "UNAUTHENTICATED"},
      {"malformed token", {"--token-file", (dir / "malformed.token").string()}, "UNAUTHENTICATED"},
      {"reader token", {"--token-file", (dir / "reader.token").string()}, "PERMISSION_DENIED"},
  };
  const struct {
    const char* name;
    std::vector<std::string> args;
  } commands[] = {
      {"bake", {"bake", Box().string(), "--out", (dir / "out").string(), "--quiet"}},
      {"status", {"status", "job-0123"}},
      {"bake-batch", {"bake-batch", (dir / "spec.json").string(), "--out", (dir / "batch").string(), "--quiet"}},
      {"cache get", {"cache", "get", key, "--cache-dir", (dir / "cache").string(), "--quiet"}},
  };
  for (const auto& t : tokens) {
    for (const auto& c : commands) {
      // A reader may read results: its cache get is a plain miss (NOT_FOUND).
      const bool reader_reads = std::string(t.name) == "reader token" && std::string(c.name) == "cache get";
      std::vector<std::string> argv = {Impostor()};
      argv.insert(argv.end(), c.args.begin(), c.args.end());
      argv.insert(argv.end(), {"--server", server.address(), "--json"});
      argv.insert(argv.end(), t.token_args.begin(), t.token_args.end());
      const ToolRun run = RunTool(argv, kExitTimeout, {"IMPOSTOR_TOKEN="});
      const std::string what = std::string(c.name) + " with " + t.name;
      EXPECT_EQ(run.exit_code, 1) << what << ": " << run.err;
      EXPECT_NE(run.err.find(reader_reads ? "NOT_FOUND" : t.code), std::string::npos) << what << ": " << run.err;
      if (std::string(c.name) == "bake-batch") {
        const std::string last = run.out.substr(run.out.rfind('{'));
        const json summary = json::parse(last, nullptr, /*allow_exceptions=*/false);
        EXPECT_EQ(summary.value("exit_code", -1), 1) << what << ": " << run.out;
      }
    }
  }
}

// status and cancel --json: `error` is {code, message} both for the job's
// error and for an RPC that failed.
TEST(CliRefusals, StatusAndCancelJsonErrorIsAlwaysAnObject) {
  ServerProcess server(0);  // no worker: the job stays queued until cancelled
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = UploadGlb(server.assets(), Box());
  request.mutable_parameters()->set_frames(3);
  request.mutable_parameters()->set_resolution(64);
  v1::SubmitBakeResponse submitted;
  ASSERT_TRUE(server.bake().SubmitBake(ContextWithin().get(), request, &submitted).ok());

  auto json_of = [&](const std::vector<std::string>& args, int want_exit) {
    std::vector<std::string> argv = {Impostor()};
    argv.insert(argv.end(), args.begin(), args.end());
    argv.insert(argv.end(), {"--server", server.address(), "--json"});
    const ToolRun run = RunTool(argv);
    EXPECT_EQ(run.exit_code, want_exit) << args[0] << ": " << run.err;
    return json::parse(run.out, nullptr, /*allow_exceptions=*/false);
  };
  const json cancelled = json_of({"cancel", submitted.job_id()}, 0);
  EXPECT_EQ(cancelled["state"], "cancelled") << cancelled.dump();
  const json status = json_of({"status", submitted.job_id()}, 0);
  const json missing = json_of({"status", "job-does-not-exist"}, 1);
  const json cancel_missing = json_of({"cancel", "job-does-not-exist"}, 1);
  for (const json& j : {cancelled, status}) {
    if (j["error"].is_null()) continue;  // a cancel may carry no reason
    ASSERT_TRUE(j["error"].is_object()) << j.dump();
    EXPECT_TRUE(j["error"]["code"].is_string()) << j.dump();
    EXPECT_TRUE(j["error"]["message"].is_string()) << j.dump();
  }
  for (const json& j : {missing, cancel_missing}) {
    ASSERT_TRUE(j["error"].is_object()) << "an RPC's error has the job error's shape: " << j.dump();
    EXPECT_EQ(j["error"]["code"], "NOT_FOUND") << j.dump();
    EXPECT_NE(j["error"]["message"].get<std::string>().find("job-does-not-exist"), std::string::npos) << j.dump();
    EXPECT_EQ(j["job_id"], "job-does-not-exist") << j.dump();
    EXPECT_EQ(j["exit_code"], 1) << j.dump();
  }
}

// A command line refused before anything runs still prints its --json
// object: the summary for bake-batch, bake's object for bake.
TEST(CliRefusals, JsonComesAlsoForARefusedCommandLine) {
  const struct {
    const char* name;
    std::vector<std::string> args;
    const char* mentions;
    const char* type;  // "summary" or "" (bake's object)
  } cases[] = {
      {"bake --frames abc", {"bake", "m.gltf", "--frames", "abc", "--json"}, "--frames", ""},
      {"bake-batch --bogus", {"bake-batch", "spec.yaml", "--bogus", "--json"}, "--bogus", "summary"},
      {"bake-batch --priority 500", {"bake-batch", "spec.yaml", "--priority", "500", "--json"}, "--priority", "summary"},
      {"status --bogus", {"status", "job-1", "--bogus", "--json"}, "--bogus", ""},
  };
  for (const auto& c : cases) {
    std::vector<std::string> argv = {Impostor()};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const ToolRun run = RunTool(argv);
    EXPECT_EQ(run.exit_code, 2) << c.name << ": " << run.err;
    const json j = json::parse(run.out, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(j.is_object()) << c.name << ": stdout \"" << run.out << "\"";
    EXPECT_EQ(j["exit_code"], 2) << c.name << ": " << run.out;
    EXPECT_NE(j["error"].get<std::string>().find(c.mentions), std::string::npos) << c.name << ": " << run.out;
    if (std::string(c.type) == "summary") {
      EXPECT_EQ(j["type"], "summary") << c.name;
      EXPECT_EQ(j["total"], 0) << c.name;
    }
    if (std::string(c.name).rfind("bake ", 0) == 0) {
      EXPECT_EQ(j["model"], "m.gltf") << run.out;
      EXPECT_TRUE(j.contains("cache_key")) << run.out;
    }
  }
}

}  // namespace
}  // namespace impostor::testing
