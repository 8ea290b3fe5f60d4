// `impostor bake-batch` and `impostor bake A B ...` as a CI job runs them:
// the real tool against a real impostor-server with local workers on
// loopback, reading real assets from ../shared/assets. Small bakes (4x4
// frames, 128 px) keep lavapipe fast.
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <map>

#include <gtest/gtest.h>

#include "absl/strings/str_split.h"
#include <nlohmann/json.hpp>

#include "tests/support/server_process.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct CliRun {
  int exit_code = -1;
  std::string output;        // stdout (and stderr when asked for)
  std::vector<json> assets;  // --json lines of type "asset"
  json summary;              // the --json line of type "summary"
};

// Runs a shell command line (so tests can pipe stdin and capture stderr)
// and parses every JSON line it printed.
CliRun RunShell(const std::string& command) {
  ChildProcess p({"/bin/sh", "-c", command});
  CliRun run;
  run.exit_code = p.Wait(&run.output);
  size_t start = 0;
  while (start < run.output.size()) {
    size_t end = run.output.find('\n', start);
    if (end == std::string::npos) end = run.output.size();
    const std::string line = run.output.substr(start, end - start);
    start = end + 1;
    if (line.empty() || line[0] != '{') continue;
    json j = json::parse(line, nullptr, /*allow_exceptions=*/false);
    EXPECT_FALSE(j.is_discarded()) << "not JSON: " << line;
    if (j.is_discarded()) continue;
    if (j.value("type", "") == "asset") run.assets.push_back(j);
    if (j.value("type", "") == "summary") run.summary = j;
  }
  return run;
}

std::string Impostor() { return (BinaryDir() / "impostor").string(); }

std::string Quote(const std::string& s) { return "'" + s + "'"; }

fs::path Asset(const std::string& relative) { return AssetsDir() / relative; }

// Every key the README promises on an asset line.
void ExpectDocumentedKeys(const json& line) {
  for (const char* key : {"type", "asset", "name", "status", "cached", "cache_key", "job_id", "out_dir", "files",
                          "wall_seconds", "priority", "quality", "error", "error_code", "error_reason"}) {
    EXPECT_TRUE(line.contains(key)) << "missing \"" << key << "\" in " << line.dump();
  }
}

fs::path WriteSpec(const fs::path& dir, const std::vector<fs::path>& models, const std::string& name = "spec.json") {
  json spec = {{"defaults", {{"frames", 4}, {"resolution", 128}}}, {"assets", json::array()}};
  for (const fs::path& m : models) spec["assets"].push_back(m.string());
  const fs::path file = dir / name;
  std::ofstream(file) << spec.dump(2);
  return file;
}

// Props and vegetation from ../shared/assets (MANIFEST.md), binary and
// separate-file glTF, textured and not.
std::vector<fs::path> PropsAndVegetation() {
  return {
      Asset("props_pbr/Box/glTF-Binary/Box.glb"),
      Asset("props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb"),
      Asset("props_pbr/Duck/glTF-Binary/Duck.glb"),
      Asset("props_pbr/Avocado/glTF/Avocado.gltf"),
      Asset("props_pbr/Fox/glTF-Binary/Fox.glb"),
      Asset("vegetation/TreeLowPoly_RicardoSanchez/scene_alphaMASK.gltf"),
      Asset("vegetation/Quaternius_CommonTree_1/CommonTree_1.glb"),
      Asset("vegetation/AlphaBlendModeTest/glTF-Binary/AlphaBlendModeTest.glb"),
      Asset("vegetation/StylizedTree_ChrisCLP/jungletree.glb"),
  };
}

TEST(BatchCli, PropsAndVegetationBakeThenComeEntirelyFromTheCache) {
  ServerProcess server(2);
  const fs::path dir = NewTempDir("batch_all");
  std::vector<fs::path> models = PropsAndVegetation();
  models.push_back(models[0]);  // the same asset twice: one bake, two folders
  const fs::path spec = WriteSpec(dir, models);
  const std::string command = Impostor() + " bake-batch " + Quote(spec.string()) + " --out " +
                              Quote((dir / "out").string()) + " --server " + server.address() + " --json --quiet";

  const CliRun first = RunShell(command);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  ASSERT_EQ(first.assets.size(), models.size()) << first.output;
  std::set<std::string> names;
  for (const json& a : first.assets) {
    ExpectDocumentedKeys(a);
    EXPECT_EQ(a["status"], "succeeded") << a.dump();
    EXPECT_TRUE(a["error"].is_null()) << a.dump();
    EXPECT_EQ(a["cache_key"].get<std::string>().size(), 64u);
    EXPECT_TRUE(fs::exists(fs::path(a["out_dir"].get<std::string>()) / "manifest.json")) << a.dump();
    EXPECT_TRUE(fs::exists(fs::path(a["out_dir"].get<std::string>()) / "albedo_alpha.png")) << a.dump();
    EXPECT_FALSE(a["files"].empty());
    EXPECT_GE(a["wall_seconds"].get<double>(), 0.0);
    names.insert(a["name"].get<std::string>());
  }
  EXPECT_EQ(names.size(), models.size()) << "every asset has its own folder";
  EXPECT_TRUE(names.contains("Box") && names.contains("Box-2"));
  EXPECT_EQ(first.summary["total"], models.size());
  EXPECT_EQ(first.summary["succeeded"], models.size());
  EXPECT_EQ(first.summary["failed"], 0);
  EXPECT_EQ(first.summary["exit_code"], 0);
  // Nine distinct assets, each baked exactly once by the farm (the
  // duplicate Box shares its bake): nine leases, nine completions, no retry.
  const int distinct = static_cast<int>(PropsAndVegetation().size());
  EXPECT_EQ(server.process().CountInLog("event=lease job="), distinct) << server.process().Stderr();
  EXPECT_EQ(server.process().CountInLog("event=complete job="), distinct) << server.process().Stderr();
  EXPECT_EQ(server.process().CountInLog(" attempt=2 "), 0) << server.process().Stderr();
  // `baked` counts assets, not bakes (README): the duplicate Box waited for
  // the bake it shared, so all ten are baked and none was cached.
  EXPECT_EQ(first.summary["baked"], models.size()) << first.summary.dump();
  EXPECT_EQ(first.summary["cached"], 0) << first.summary.dump();

  // The next commit's CI run: nothing new to bake.
  const CliRun second = RunShell(command);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  ASSERT_EQ(second.assets.size(), models.size());
  for (const json& a : second.assets) {
    EXPECT_EQ(a["status"], "succeeded") << a.dump();
    EXPECT_EQ(a["cached"], true) << "answered from the cache: " << a.dump();
  }
  EXPECT_EQ(second.summary["cached"], models.size());
  EXPECT_EQ(second.summary["baked"], 0);
  for (size_t i = 0; i < models.size(); ++i) {
    const auto same = [&](const json& a) { return a["asset"] == first.assets[i]["asset"]; };
    auto it = std::find_if(second.assets.begin(), second.assets.end(), same);
    ASSERT_NE(it, second.assets.end());
    EXPECT_EQ((*it)["cache_key"], first.assets[i]["cache_key"]);
  }
}

// Models that fail on the client (corrupt GLB header, missing buffer) and on
// the worker (no triangles) between good ones.
std::vector<fs::path> GoodAndBroken() {
  const fs::path corpus = Asset("edge_cases/gltf-validator-tests/base/data");
  return {
      Asset("props_pbr/Box/glTF-Binary/Box.glb"),
      corpus / "glb/invalid_magic.glb",
      corpus / "buffer/not_found.gltf",
      corpus / "mesh/empty_object.gltf",
      Asset("props_pbr/Duck/glTF-Binary/Duck.glb"),
  };
}

TEST(BatchCli, KeepGoingBakesTheGoodOnesAndNamesEachFailure) {
  ServerProcess server(1);
  const fs::path dir = NewTempDir("batch_keep_going");
  const fs::path spec = WriteSpec(dir, GoodAndBroken());
  const CliRun run = RunShell(Impostor() + " bake-batch " + Quote(spec.string()) + " --out " +
                              Quote((dir / "out").string()) + " --server " + server.address() +
                              " --json --quiet --keep-going 2>&1");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  ASSERT_EQ(run.assets.size(), 5u) << run.output;
  std::map<std::string, json> by_name;
  for (const json& a : run.assets) {
    ExpectDocumentedKeys(a);
    by_name[fs::path(a["asset"].get<std::string>()).filename().string()] = a;
  }
  for (const char* good : {"Box.glb", "Duck.glb"}) {
    EXPECT_EQ(by_name[good]["status"], "succeeded") << by_name[good].dump();
    EXPECT_TRUE(fs::exists(fs::path(by_name[good]["out_dir"].get<std::string>()) / "manifest.json"));
  }
  const struct {
    const char* file;
    const char* code;
    const char* why;
  } failures[] = {
      {"invalid_magic.glb", "INVALID_ARGUMENT", "corrupt GLB header"},
      {"not_found.gltf", "NOT_FOUND", "not_found.bin not found"},
      {"empty_object.gltf", "INVALID_ARGUMENT", "no triangles"},
  };
  for (const auto& f : failures) {
    const json& a = by_name[f.file];
    EXPECT_EQ(a["status"], "failed") << a.dump();
    const std::string error = a["error"].is_string() ? a["error"].get<std::string>() : "";
    EXPECT_EQ(error.rfind(f.code, 0), 0u) << error;
    EXPECT_NE(error.find(f.why), std::string::npos) << error;
    EXPECT_NE(a["error_code"], 0);
    // And the one failure line on stderr names it too.
    EXPECT_NE(run.output.find(std::string(f.file) + ": " + f.code), std::string::npos) << run.output;
  }
  EXPECT_EQ(by_name["empty_object.gltf"]["cache_key"].get<std::string>().size(), 64u)
      << "the worker failed it, so it was submitted";
  EXPECT_EQ(run.summary["succeeded"], 2);
  EXPECT_EQ(run.summary["failed"], 3);
  EXPECT_EQ(run.summary["skipped"], 0);
  EXPECT_EQ(run.summary["exit_code"], 1);
  EXPECT_NE(run.output.find("impostor: 3 of 5 assets failed: "), std::string::npos) << run.output;
}

TEST(BatchCli, WithoutKeepGoingNothingIsSubmittedAfterTheFirstFailure) {
  ServerProcess server(1);
  const fs::path dir = NewTempDir("batch_stop");
  std::vector<fs::path> models = GoodAndBroken();
  std::rotate(models.begin(), models.begin() + 1, models.end());  // the corrupt GLB first
  const fs::path spec = WriteSpec(dir, models);
  const CliRun run = RunShell(Impostor() + " bake-batch " + Quote(spec.string()) + " --out " +
                              Quote((dir / "out").string()) + " --server " + server.address() + " --json --quiet");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  ASSERT_EQ(run.assets.size(), models.size()) << "every asset is reported, skipped ones too";
  for (const json& a : run.assets) {
    ExpectDocumentedKeys(a);
    if (fs::path(a["asset"].get<std::string>()).filename() == "invalid_magic.glb") {
      EXPECT_EQ(a["status"], "failed");
      continue;
    }
    EXPECT_EQ(a["status"], "skipped") << a.dump();
    EXPECT_EQ(a["error_code"], 1) << "CANCELLED, the code of its error: " << a.dump();
    EXPECT_TRUE(a["job_id"].is_null()) << "never submitted: " << a.dump();
    EXPECT_FALSE(fs::exists(a["out_dir"].get<std::string>())) << a.dump();
  }
  EXPECT_EQ(run.summary["skipped"], models.size() - 1);
  EXPECT_EQ(run.summary["exit_code"], 1);
}

TEST(BatchCli, BakeWithSeveralModelsIsABatch) {
  ServerProcess server(1);
  const fs::path dir = NewTempDir("batch_bake_many");
  const CliRun run = RunShell(Impostor() + " bake " + Quote(Asset("props_pbr/Box/glTF-Binary/Box.glb").string()) +
                              " " + Quote(Asset("props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb").string()) +
                              " --frames 4 --resolution 64 --priority 30 --out " + Quote((dir / "out").string()) +
                              " --server " + server.address() + " --json --quiet");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  ASSERT_EQ(run.assets.size(), 2u);
  for (const json& a : run.assets) {
    EXPECT_EQ(a["status"], "succeeded");
    EXPECT_EQ(a["priority"], 30);
  }
  EXPECT_TRUE(fs::exists(dir / "out/Box/manifest.json"));
  EXPECT_TRUE(fs::exists(dir / "out/BoxTextured/manifest.json"));
  // The server recorded the priority on the job.
  grpc::ClientContext context;
  v1::GetJobRequest request;
  request.set_job_id(run.assets[0]["job_id"].get<std::string>());
  v1::Job job;
  ASSERT_TRUE(server.bake().GetJob(&context, request, &job).ok());
  EXPECT_EQ(job.priority(), 30);
}

// The quality gate end to end: the worker measures, the server judges each
// requester, the tool reports the failure with the measured values and still
// downloads the result; the bake is cached whatever the gate said.
TEST(BatchCli, QualityGateFailsTheAssetButKeepsItsResult) {
  ServerProcess server(1);
  const fs::path dir = NewTempDir("batch_gate");
  const std::string box = Asset("props_pbr/Box/glTF-Binary/Box.glb").string();
  auto spec_with = [&](const std::string& file, const json& extra) {
    json asset = {{"path", box}, {"name", "box"}};
    asset.update(extra);
    std::ofstream(dir / file) << json{{"defaults", {{"frames", 4}, {"resolution", 128}}}, {"assets", {asset}}}.dump();
    return Quote((dir / file).string());
  };
  const std::string gated = spec_with("gated.json", {{"min_iou", 1.0}, {"min_psnr_db", 100.0}});
  const std::string ungated = spec_with("ungated.json", json::object());
  auto run = [&](const std::string& spec, const std::string& out) {
    return RunShell(Impostor() + " bake-batch " + spec + " --out " + Quote((dir / out).string()) + " --server " +
                    server.address() + " --json --quiet");
  };

  const CliRun baked = run(gated, "gated");
  EXPECT_EQ(baked.exit_code, 1) << baked.output;
  ASSERT_EQ(baked.assets.size(), 1u) << baked.output;
  const json& a = baked.assets[0];
  EXPECT_EQ(a["status"], "failed");
  EXPECT_EQ(a["error_code"], 9);
  EXPECT_EQ(a["error"].get<std::string>().rfind("FAILED_PRECONDITION: quality gate: silhouette IoU ", 0), 0u)
      << a.dump();
  ASSERT_TRUE(a["quality"].is_object()) << "the measured figures come with the failure: " << a.dump();
  EXPECT_GT(a["quality"]["views"].get<int>(), 0);
  EXPECT_TRUE(fs::exists(dir / "gated/box/manifest.json")) << "the result is kept for inspection";

  const CliRun plain = run(ungated, "plain");
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_EQ(plain.assets[0]["cached"], true) << "the gate is not part of the cache key";

  const CliRun hit = run(gated, "gated_again");
  EXPECT_EQ(hit.exit_code, 1) << hit.output;
  EXPECT_EQ(hit.assets[0]["cached"], true);
  EXPECT_EQ(hit.assets[0]["status"], "failed") << "a cache hit is gated too";
  EXPECT_EQ(hit.assets[0]["error"], a["error"]);
  // `impostor bake` with the same gate: its --json error is the same
  // "CODE: message" (no "bake failed: ", which only its stderr line has).
  const CliRun single = RunShell(Impostor() + " bake " + Quote(box) + " --frames 4 --resolution 128 --min-iou 1" +
                                 " --min-psnr 100 --out " + Quote((dir / "single").string()) + " --server " +
                                 server.address() + " --json --quiet 2>" + Quote((dir / "single.err").string()));
  EXPECT_EQ(single.exit_code, 1) << single.output;
  const json single_json = json::parse(single.output, nullptr, /*allow_exceptions=*/false);
  ASSERT_TRUE(single_json.is_object()) << single.output;
  EXPECT_EQ(single_json["error"], a["error"]) << single.output;
  std::ifstream single_err(dir / "single.err");
  const std::string single_line((std::istreambuf_iterator<char>(single_err)), std::istreambuf_iterator<char>());
  EXPECT_NE(single_line.find("impostor: bake failed: " + a["error"].get<std::string>() + "\n"), std::string::npos)
      << single_line;

  // That failure is known at submit: without --keep-going nothing after it
  // is submitted, as after any other failure.
  json two = {{"defaults", {{"frames", 4}, {"resolution", 128}}},
              {"assets",
               {{{"path", box}, {"name", "box"}, {"min_iou", 1.0}, {"min_psnr_db", 100.0}},
                {{"path", Asset("props_pbr/Duck/glTF-Binary/Duck.glb").string()}, {"name", "duck"}}}}};
  std::ofstream(dir / "gated_then_duck.json") << two.dump();
  const CliRun stopped = run(Quote((dir / "gated_then_duck.json").string()), "stopped");
  EXPECT_EQ(stopped.exit_code, 1) << stopped.output;
  ASSERT_EQ(stopped.assets.size(), 2u) << stopped.output;
  std::map<std::string, json> by_name;
  for (const json& asset : stopped.assets) by_name[asset["name"]] = asset;
  EXPECT_EQ(by_name["box"]["status"], "failed") << stopped.output;
  EXPECT_EQ(by_name["duck"]["status"], "skipped") << stopped.output;
}

// Plain output (one line per finished asset on stdout), the live progress
// line on stderr, and --quiet silencing it.
TEST(BatchCli, PlainOutputProgressLineAndQuiet) {
  ServerProcess server(1);
  const fs::path dir = NewTempDir("batch_plain");
  const fs::path spec = WriteSpec(dir, {Asset("props_pbr/Box/glTF-Binary/Box.glb"),
                                        Asset("props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb")});
  const std::vector<std::string> base = {Impostor(), "bake-batch", spec.string(), "--out", (dir / "out").string(),
                                         "--server", server.address()};
  const ToolRun loud = RunTool(base);
  ASSERT_EQ(loud.exit_code, 0) << loud.err;
  const std::vector<std::string> names = {"Box", "BoxTextured"};
  for (const std::string& name : names) {
    const std::string line = "succeeded  " + name + "  " + (dir / "out" / name).string() + "  (baked, ";
    EXPECT_NE(loud.out.find(line), std::string::npos) << name << ": " << loud.out;
  }
  EXPECT_EQ(std::count(loud.out.begin(), loud.out.end(), '\n'), 2) << "one line per asset: " << loud.out;
  EXPECT_NE(loud.err.find("[########################] 2/2  queued 0  running 0  done 2  cached 0  failed 0"),
            std::string::npos)
      << "the final progress line: " << loud.err;
  EXPECT_NE(loud.err.find("batch: 2 assets, 2 succeeded (2 baked, 0 cached), 0 failed, 0 skipped"), std::string::npos)
      << loud.err;

  std::vector<std::string> quiet_args = base;
  quiet_args.push_back("--quiet");
  const ToolRun quiet = RunTool(quiet_args);
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_EQ(quiet.err, "") << "--quiet prints nothing on stderr when all is well";
  for (const std::string& name : names) {
    EXPECT_NE(quiet.out.find("succeeded  " + name + "  "), std::string::npos) << name << ": " << quiet.out;
  }
  EXPECT_EQ(std::count(quiet.out.begin(), quiet.out.end(), '(') , 2) << quiet.out;
  EXPECT_NE(quiet.out.find("(cached, "), std::string::npos) << quiet.out;
}

TEST(BatchCli, UnreachableServerExits3AndAnUncreatableOutExits4) {
  const fs::path dir = NewTempDir("batch_exit_codes");
  const fs::path spec = WriteSpec(dir, {Asset("props_pbr/Box/glTF-Binary/Box.glb")});
  std::ofstream(dir / "a_file") << "not a directory";
  const struct {
    const char* name;
    std::string out;
    std::string server;
    int exit_code;
    std::string mentions;
  } cases[] = {
      {"server unreachable", (dir / "out").string(), "127.0.0.1:1", 3, "127.0.0.1:1"},
      {"out under a regular file", (dir / "a_file" / "out").string(), "127.0.0.1:1", 4,
       "cannot create output directory " + (dir / "a_file" / "out").string()},
  };
  for (const auto& c : cases) {
    const ToolRun run = RunTool({Impostor(), "bake-batch", spec.string(), "--out", c.out, "--server", c.server,
                                 "--json", "--quiet"});
    EXPECT_EQ(run.exit_code, c.exit_code) << c.name << ": " << run.err;
    EXPECT_NE(run.err.find("impostor: "), std::string::npos) << c.name << ": " << run.err;
    EXPECT_NE(run.err.find(c.mentions), std::string::npos) << c.name << ": " << run.err;
    // --json: every asset skipped, one line each, then the summary, as
    // when a batch stops, for CI to parse.
    std::vector<nlohmann::json> lines;
    for (absl::string_view line : absl::StrSplit(run.out, '\n', absl::SkipEmpty())) {
      lines.push_back(nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false));
    }
    ASSERT_EQ(lines.size(), 2u) << c.name << ": stdout " << run.out;
    EXPECT_EQ(lines[0]["type"], "asset") << run.out;
    EXPECT_EQ(lines[0]["status"], "skipped") << run.out;
    EXPECT_EQ(lines[0]["name"], "Box") << run.out;
    // The code of its error: UNAVAILABLE (no server), INTERNAL (local I/O).
    EXPECT_EQ(lines[0]["error_code"], c.exit_code == 3 ? 14 : 13) << run.out;
    const nlohmann::json& summary = lines[1];
    ASSERT_TRUE(summary.is_object()) << c.name << ": stdout " << run.out;
    EXPECT_EQ(summary["type"], "summary") << run.out;
    EXPECT_EQ(summary["exit_code"], c.exit_code) << run.out;
    EXPECT_EQ(summary["total"], 1) << run.out;
    EXPECT_EQ(summary["skipped"], 1) << run.out;
    EXPECT_NE(summary["error"].get<std::string>().find(c.mentions), std::string::npos) << run.out;
  }
  // A spec refused before anything is sent: exit 2, and the summary says so.
  std::ofstream(dir / "empty.json") << R"({"assets": []})";
  const ToolRun bad = RunTool({Impostor(), "bake-batch", (dir / "empty.json").string(), "--out",
                               (dir / "out").string(), "--server", "127.0.0.1:1", "--json", "--quiet"});
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
  const nlohmann::json summary = nlohmann::json::parse(bad.out, nullptr, /*allow_exceptions=*/false);
  ASSERT_TRUE(summary.is_object()) << bad.out;
  EXPECT_EQ(summary["exit_code"], 2);
  EXPECT_EQ(summary["total"], 0);
  EXPECT_NE(summary["error"].get<std::string>().find("the list is empty"), std::string::npos) << bad.out;
  // A value the server would refuse is a refused spec too: total 0, no asset lines.
  std::ofstream(dir / "bad_value.json")
      << json{{"assets", {{{"path", Asset("props_pbr/Box/glTF-Binary/Box.glb").string()}, {"resolution", 32}}}}}.dump();
  const ToolRun bad_value = RunTool({Impostor(), "bake-batch", (dir / "bad_value.json").string(), "--out",
                                     (dir / "out").string(), "--server", "127.0.0.1:1", "--json", "--quiet"});
  EXPECT_EQ(bad_value.exit_code, 2) << bad_value.err;
  const nlohmann::json refused = nlohmann::json::parse(bad_value.out, nullptr, /*allow_exceptions=*/false);
  ASSERT_TRUE(refused.is_object()) << bad_value.out;
  EXPECT_EQ(refused["total"], 0) << bad_value.out;
  EXPECT_EQ(refused["skipped"], 0) << bad_value.out;
}

// The server leases a batch's jobs highest priority first: the batch is
// submitted while no worker runs, then one worker takes them one by one.
TEST(BatchCli, JobsAreLeasedHighestPriorityFirst) {
  ServerProcess server(0);
  const fs::path dir = NewTempDir("batch_priority");
  const json spec = {{"defaults", {{"frames", 4}, {"resolution", 64}}},
                     {"assets",
                      {{{"path", Asset("props_pbr/Box/glTF-Binary/Box.glb").string()}, {"priority", -50}},
                       {{"path", Asset("props_pbr/Duck/glTF-Binary/Duck.glb").string()}, {"priority", 50}},
                       {{"path", Asset("props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb").string()}, {"priority", 0}}}}};
  std::ofstream(dir / "spec.json") << spec.dump();
  ChildProcess batch({Impostor(), "bake-batch", (dir / "spec.json").string(), "--out", (dir / "out").string(),
                      "--server", server.address(), "--json", "--quiet"});
  ASSERT_TRUE(server.process().WaitForLog("outcome=queued", 3)) << server.process().Stderr();
  auto worker = StartWorker(server.address());
  std::string out;
  ASSERT_EQ(batch.Wait(&out), 0) << out << batch.Stderr();
  std::vector<int> lease_priorities;
  std::istringstream log(server.process().Stderr());
  for (std::string line; std::getline(log, line);) {
    const size_t at = line.find("event=lease job=");
    if (at == std::string::npos) continue;
    const size_t p = line.find(" priority=", at);
    ASSERT_NE(p, std::string::npos) << line;
    lease_priorities.push_back(std::stoi(line.substr(p + std::strlen(" priority="))));
  }
  EXPECT_EQ(lease_priorities, (std::vector<int>{50, 0, -50})) << server.process().Stderr();
}

// Each result is downloaded as soon as its job finishes, not at the end of
// the batch: one of two jobs is held at its render stage by a paused worker
// while the other is baked, reported and already on disk.
TEST(BatchCli, EachResultIsDownloadedAsSoonAsItFinishes) {
  ServerProcess server(0);
  const fs::path dir = NewTempDir("batch_per_result");
  const fs::path pause = dir / "pause";
  std::ofstream(pause) << "pause";
  auto held = StartWorker(server.address(), {"--name=held"}, {"IMPOSTOR_WORKER_TEST_PAUSE_FILE=" + pause.string()});
  ASSERT_TRUE(held->WaitForLog("event=worker_ready")) << held->Stderr();
  const fs::path spec = WriteSpec(dir, {Asset("props_pbr/Box/glTF-Binary/Box.glb"),
                                        Asset("props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb")});
  ChildProcess batch({Impostor(), "bake-batch", spec.string(), "--out", (dir / "out").string(), "--server",
                      server.address(), "--quiet"});
  ASSERT_TRUE(server.process().WaitForLog("worker=\"held")) << server.process().Stderr();
  auto free_worker = StartWorker(server.address(), {"--name=free"});
  const std::string line = batch.ReadLineContaining("succeeded  ", kWatchTimeout);
  ASSERT_FALSE(line.empty()) << "no asset finished; batch stderr: " << batch.Stderr();
  const std::string name = line.find("  BoxTextured  ") != std::string::npos ? "BoxTextured" : "Box";
  const std::string other = name == "Box" ? "BoxTextured" : "Box";
  // The other job is still held, so the batch is not over; this one is on disk.
  EXPECT_TRUE(batch.Running());
  EXPECT_TRUE(fs::exists(dir / "out" / name / "manifest.json")) << line;
  EXPECT_TRUE(fs::exists(dir / "out" / name / "albedo_alpha.png")) << line;
  EXPECT_FALSE(fs::exists(dir / "out" / other / "manifest.json")) << "the held job cannot have finished";
  fs::remove(pause);
  std::string rest;
  EXPECT_EQ(batch.Wait(&rest), 0) << rest << batch.Stderr();
  EXPECT_NE(rest.find("succeeded  " + other + "  "), std::string::npos) << rest;
  EXPECT_TRUE(fs::exists(dir / "out" / other / "manifest.json"));
}

TEST(BatchCli, MalformedInputIsAUsageErrorNamingTheEntryAndField) {
  const fs::path dir = NewTempDir("batch_bad_spec");
  const std::string box = Asset("props_pbr/Box/glTF-Binary/Box.glb").string();
  const struct {
    const char* name;
    std::string spec;  // JSON text; empty = use `args` alone
    std::string args;
    std::string message;
  } cases[] = {
      {"missing file", R"({"assets": [")" + box + R"(", "missing/tree.glb"]})", "",
       "impostor: assets[1]: \"missing/tree.glb\" not found"},
      {"unknown key", R"({"assets": [{"path": ")" + box + R"(", "frame": 4}]})", "",
       "unknown key \"frame\""},
      {"wrong type", R"({"defaults": {"frames": "four"}, "assets": [")" + box + R"("]})", "",
       "impostor: defaults.frames: expected a whole number, 0 or more, or \"auto\", got \"four\" (string)"},
      {"empty list", R"({"assets": []})", "", "impostor: assets: the list is empty; nothing to bake"},
      {"priority in spec", R"({"assets": [{"path": ")" + box + R"(", "priority": 1000}]})", "",
       "priority: 1000 is out of range -100..100"},
      {"priority flag", R"({"assets": [")" + box + R"("]})", " --priority 101",
       "--priority: expected a whole number in -100..100, got \"101\""},
      {"spec missing", "", " " + (dir / "absent.json").string(), "impostor: SPEC: cannot read "},
      // Values in type but out of the server's range, judged before sending.
      {"frames out of range", R"({"defaults": {"frames": 80}, "assets": [")" + box + R"("]})", "",
       "assets[0] (\"" + box + "\"): parameters.frames: 80 is out of range 2..64"},
      {"resolution out of range", R"({"assets": [")" + box + R"(", {"path": ")" + box + R"(", "resolution": 32}]})",
       "", "assets[1] (\"" + box + "\"): parameters.resolution: 32 is out of range"},
      {"unknown layout", R"({"assets": [{"path": ")" + box + R"(", "layout": "sphere"}]})", "", "sphere"},
  };
  int n = 0;
  for (const auto& c : cases) {
    std::string spec_arg;
    if (!c.spec.empty()) {
      const fs::path file = dir / ("spec" + std::to_string(n++) + ".json");
      std::ofstream(file) << c.spec;
      spec_arg = " " + Quote(file.string());
    }
    // No server: a bad spec is refused before connecting.
    const CliRun run = RunShell(Impostor() + " bake-batch" + spec_arg + c.args + " --out " +
                                Quote((dir / "out").string()) + " --server 127.0.0.1:1 2>&1");
    EXPECT_EQ(run.exit_code, 2) << c.name << ": " << run.output;
    EXPECT_NE(run.output.find(c.message), std::string::npos) << c.name << ": " << run.output;
  }
  // YAML on standard input, with a mistake on its second asset.
  const CliRun yaml = RunShell("printf 'defaults: {frames: 4}\\nassets:\\n  - " + box +
                               "\\n  - {path: " + box + ", resolution: big}\\n' | " + Impostor() +
                               " bake-batch - --out " + Quote((dir / "out").string()) + " 2>&1");
  EXPECT_EQ(yaml.exit_code, 2) << yaml.output;
  EXPECT_NE(yaml.output.find(".resolution: expected a whole number, 0 or more, got \"big\" (string)"),
            std::string::npos)
      << yaml.output;
}

}  // namespace
}  // namespace impostor::testing
