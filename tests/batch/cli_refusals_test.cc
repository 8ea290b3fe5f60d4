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

#include "absl/status/status.h"
#include "absl/strings/str_split.h"
#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Impostor() { return (BinaryDir() / "impostor").string(); }
fs::path Box() { return AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb"; }

// Every JSON line of `out` (one object per line).
std::vector<json> JsonLines(const std::string& out) {
  std::vector<json> lines;
  for (absl::string_view line : absl::StrSplit(out, '\n', absl::SkipEmpty())) {
    json j = json::parse(line, nullptr, /*allow_exceptions=*/false);
    EXPECT_TRUE(j.is_object()) << "not a JSON object: " << line;
    if (j.is_object()) lines.push_back(std::move(j));
  }
  return lines;
}

// "CODE: " for a canonical code number (a batch asset's error_code).
std::string CodePrefix(int code) {
  return absl::StatusCodeToString(static_cast<absl::StatusCode>(code)) + ": ";
}

// The keys README and --help promise for status and cancel --json.
void ExpectEveryJobKey(const json& j, const std::string& what) {
  for (const char* key : {"job_id", "cache_key", "state", "progress", "stage", "cached", "error"}) {
    EXPECT_TRUE(j.contains(key)) << what << ": no \"" << key << "\" in " << j.dump();
  }
}

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
        // Each asset's error starts with the refusal's code.
        int assets = 0;
        for (const json& a : JsonLines(run.out)) {
          if (a.value("type", "") != "asset") continue;
          ++assets;
          EXPECT_EQ(a.value("error", "").rfind(std::string(t.code) + ": not submitted: ", 0), 0u)
              << what << ": " << a.dump();
        }
        EXPECT_EQ(assets, 1) << what << ": " << run.out;
      }
      if (std::string(c.name) == "bake") {
        const json j = json::parse(run.out, nullptr, /*allow_exceptions=*/false);
        EXPECT_EQ(j.value("error", "").rfind(std::string(t.code) + ": ", 0), 0u) << what << ": " << run.out;
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
  // A call that failed: the same object, every key (null: not known), and
  // exit_code. Also when the server cannot be reached (exit 3).
  const ToolRun unreachable = RunTool({Impostor(), "status", "job-0123", "--server", "127.0.0.1:1", "--json"});
  EXPECT_EQ(unreachable.exit_code, 3) << unreachable.err;
  const json unreachable_json = json::parse(unreachable.out, nullptr, /*allow_exceptions=*/false);
  ExpectEveryJobKey(unreachable_json, "status, no server");
  EXPECT_EQ(unreachable_json["job_id"], "job-0123") << unreachable.out;
  EXPECT_EQ(unreachable_json["error"]["code"], "UNAVAILABLE") << unreachable.out;
  EXPECT_EQ(unreachable_json["exit_code"], 3) << unreachable.out;
  for (const json& j : {cancelled, status, missing, cancel_missing}) ExpectEveryJobKey(j, "status or cancel");
  for (const json& j : {missing, cancel_missing}) {
    for (const char* unknown : {"cache_key", "state", "progress", "stage", "cached"}) {
      EXPECT_TRUE(j[unknown].is_null()) << unknown << " of a job the server does not have: " << j.dump();
    }
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
      {"cancel --bogus", {"cancel", "job-1", "--bogus", "--json"}, "--bogus", ""},
      {"admin purge without --worker", {"admin", "purge", "--json"}, "--worker", ""},
      {"fetch --bogus", {"fetch", std::string(64, 'a'), "--out", "d", "--bogus", "--json"}, "--bogus", ""},
      {"quality --bogus", {"quality", std::string(64, 'a'), "--bogus", "--json"}, "--bogus", ""},
  };
  for (const auto& c : cases) {
    std::vector<std::string> argv = {Impostor()};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const ToolRun run = RunTool(argv);
    EXPECT_EQ(run.exit_code, 2) << c.name << ": " << run.err;
    const json j = json::parse(run.out, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(j.is_object()) << c.name << ": stdout \"" << run.out << "\"";
    EXPECT_EQ(j["exit_code"], 2) << c.name << ": " << run.out;
    const std::string name = c.name;
    if (name.rfind("status ", 0) == 0 || name.rfind("cancel ", 0) == 0) {
      // The job object, its error {code, message} as for any failure.
      ExpectEveryJobKey(j, c.name);
      EXPECT_EQ(j["job_id"], "job-1") << run.out;
      ASSERT_TRUE(j["error"].is_object()) << c.name << ": " << run.out;
      EXPECT_EQ(j["error"]["code"], "INVALID_ARGUMENT") << run.out;
      EXPECT_NE(j["error"]["message"].get<std::string>().find(c.mentions), std::string::npos) << run.out;
      continue;
    }
    EXPECT_NE(j["error"].get<std::string>().find(c.mentions), std::string::npos) << c.name << ": " << run.out;
    // bake's error, as every bake error: "CODE: message" (the summary's
    // error is the stderr line).
    if (std::string(c.type) != "summary") {
      EXPECT_EQ(j["error"].get<std::string>().rfind("INVALID_ARGUMENT: ", 0), 0u) << c.name << ": " << run.out;
    }
    if (name.rfind("admin ", 0) == 0) {
      for (const char* key : {"worker", "cache_keys", "blobs_removed", "bytes_freed", "blobs_kept"}) {
        EXPECT_TRUE(j.contains(key) && j[key].is_null()) << key << ": " << run.out;
      }
    }
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

// Every --json `error` string of bake and of bake-batch's assets starts
// with the canonical code of the failure ("CODE: ..."), whatever failed: a
// local file, the command line, the connection, the server's refusal, a
// cancelled job, a batch that stopped. The exit code stays the one for that
// failure; bake-batch's error_code is the code the error starts with.
TEST(CliRefusals, EveryJsonErrorStartsWithItsCode) {
  ServerProcess server(0);  // no worker: jobs stay queued
  const fs::path dir = NewTempDir("cli_json_error_codes");
  std::ofstream(dir / "a_file") << "not a directory";
  const std::string out = (dir / "out").string();
  const struct {
    const char* name;
    std::vector<std::string> args;
    int exit_code;
    const char* code;
    std::string mentions;
  } bakes[] = {
      {"missing model", {"bake", "/nonexistent/m.glb", "--out", out}, 4, "NOT_FOUND",
       "model /nonexistent/m.glb not found"},
      {"uncreatable --out", {"bake", Box().string(), "--out", (dir / "a_file" / "o").string()}, 4, "INTERNAL",
       "cannot create output directory"},
      {"no server", {"bake", Box().string(), "--out", out, "--server", "127.0.0.1:1"}, 3, "UNAVAILABLE",
       "127.0.0.1:1"},
      {"usage", {"bake", Box().string(), "--out", out, "--frames", "abc"}, 2, "INVALID_ARGUMENT", "--frames"},
      {"--lod-pixel-error out of range",
       {"bake", Box().string(), "--out", out, "--product", "lod-chain", "--lod-pixel-error", "20"}, 2,
       "INVALID_ARGUMENT", "--lod-pixel-error: 20 is out of range 0.1..16"},
      {"refused by the server", {"bake", Box().string(), "--out", out, "--frames", "80", "--server", server.address()},
       1, "INVALID_ARGUMENT", "--frames (parameters.frames): 80 is out of range"},
      // The flag reaches the request: the server judges it (atlas has no
      // LOD levels).
      {"--lod-pixel-error without lod-chain",
       {"bake", Box().string(), "--out", out, "--lod-pixel-error", "2", "--server", server.address()}, 1,
       "INVALID_ARGUMENT", "--lod-pixel-error (parameters.lod_pixel_error): only for product lod-chain"},
  };
  for (const auto& c : bakes) {
    std::vector<std::string> argv = {Impostor()};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    argv.insert(argv.end(), {"--json", "--quiet"});
    const ToolRun run = RunTool(argv);
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << ": " << run.err;
    const json j = json::parse(run.out, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(j.is_object()) << c.name << ": stdout \"" << run.out << "\"";
    EXPECT_EQ(j["exit_code"], c.exit_code) << c.name << ": " << run.out;
    const std::string error = j["error"].is_string() ? j["error"].get<std::string>() : "";
    EXPECT_EQ(error.rfind(std::string(c.code) + ": ", 0), 0u) << c.name << ": " << error;
    EXPECT_NE(error.find(c.mentions), std::string::npos) << c.name << ": " << error;
    EXPECT_NE(run.err.find(c.mentions), std::string::npos) << c.name << ": " << run.err;
  }

  // A job cancelled while `bake` follows it: exit 1, CANCELLED.
  {
    ChildProcess bake({Impostor(), "bake", Box().string(), "--out", out, "--frames", "5", "--resolution", "64",
                       "--server", server.address(), "--json"});
    ASSERT_TRUE(bake.WaitForLog("submitted ")) << bake.Stderr();
    const std::string log = bake.Stderr();
    const size_t at = log.find(": job ");
    ASSERT_NE(at, std::string::npos) << log;
    v1::CancelJobRequest cancel;
    cancel.set_job_id(log.substr(at + 6, log.find(',', at) - at - 6));
    v1::Job job;
    ASSERT_TRUE(server.bake().CancelJob(ContextWithin().get(), cancel, &job).ok()) << cancel.job_id();
    std::string stdout_text;
    EXPECT_EQ(bake.Wait(&stdout_text), 1) << bake.Stderr();
    const json j = json::parse(stdout_text, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(j.is_object()) << stdout_text;
    EXPECT_EQ(j.value("error", "").rfind("CANCELLED: bake was cancelled", 0), 0u) << stdout_text;
    EXPECT_EQ(j["job_id"], cancel.job_id()) << stdout_text;
  }

  // bake-batch: every asset's error starts with the code its error_code
  // names, skipped assets too.
  const fs::path corrupt = AssetsDir() / "edge_cases/gltf-validator-tests/base/data/glb/invalid_magic.glb";
  const fs::path spec = dir / "spec.json";
  std::ofstream(spec) << json{{"defaults", {{"frames", 3}, {"resolution", 64}}},
                              {"assets", {corrupt.string(), Box().string()}}}
                             .dump();
  const struct {
    const char* name;
    std::string out;
    std::string server;
    int exit_code;
    std::vector<std::string> errors;  // each asset's error starts so
  } batches[] = {
      {"no server", out, "127.0.0.1:1", 3, {"UNAVAILABLE: not submitted: ", "UNAVAILABLE: not submitted: "}},
      {"uncreatable --out", (dir / "a_file" / "o").string(), "127.0.0.1:1", 4,
       {"INTERNAL: not submitted: cannot create output directory", "INTERNAL: not submitted: cannot create"}},
      {"stopped after a failure", (dir / "batch").string(), server.address(), 1,
       {"INVALID_ARGUMENT: ", "CANCELLED: not submitted: the batch stopped after a failure"}},
  };
  for (const auto& c : batches) {
    const ToolRun run = RunTool(
        {Impostor(), "bake-batch", spec.string(), "--out", c.out, "--server", c.server, "--json", "--quiet"});
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << ": " << run.err;
    std::vector<json> assets;
    for (const json& j : JsonLines(run.out)) {
      if (j.value("type", "") == "asset") assets.push_back(j);
    }
    ASSERT_EQ(assets.size(), 2u) << c.name << ": " << run.out;
    for (size_t i = 0; i < assets.size(); ++i) {
      const std::string error = assets[i].value("error", "");
      EXPECT_EQ(error.rfind(c.errors[i], 0), 0u) << c.name << ": " << assets[i].dump();
      EXPECT_EQ(error.rfind(CodePrefix(assets[i].value("error_code", 0)), 0), 0u) << c.name << ": " << assets[i].dump();
    }
  }
}

// admin purge --json on failure: every documented key (the results null:
// not known), error "CODE: message" and exit_code.
TEST(CliRefusals, AdminPurgeJsonHasEveryKeyOnFailure) {
  ServerProcess server(0, {"--auth=token"});
  const fs::path dir = NewTempDir("cli_admin_purge_json");
  std::ofstream(dir / "submitter.token") << CreateToken(server.data_dir(), "submitter", "ci") << "\n";
  const struct {
    const char* name;
    std::vector<std::string> args;
    int exit_code;
    const char* code;
  } cases[] = {
      {"not an admin", {"--server", server.address(), "--token-file", (dir / "submitter.token").string()}, 1,
       "PERMISSION_DENIED"},
      {"no server", {"--server", "127.0.0.1:1"}, 3, "UNAVAILABLE"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> argv = {Impostor(), "admin", "purge", "--worker", "render-1", "--json"};
    argv.insert(argv.end(), c.args.begin(), c.args.end());
    const ToolRun run = RunTool(argv, kExitTimeout, {"IMPOSTOR_TOKEN="});
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << ": " << run.err;
    const json j = json::parse(run.out, nullptr, /*allow_exceptions=*/false);
    ASSERT_TRUE(j.is_object()) << c.name << ": stdout \"" << run.out << "\"";
    EXPECT_EQ(j["worker"], "render-1") << run.out;
    for (const char* key : {"cache_keys", "blobs_removed", "bytes_freed", "blobs_kept"}) {
      EXPECT_TRUE(j.contains(key) && j[key].is_null()) << c.name << ": " << key << " in " << run.out;
    }
    EXPECT_EQ(j.value("error", "").rfind(std::string(c.code) + ": ", 0), 0u) << c.name << ": " << run.out;
    EXPECT_EQ(j["exit_code"], c.exit_code) << c.name << ": " << run.out;
  }
}

}  // namespace
}  // namespace impostor::testing
