// Hostile input through the service: every .gltf/.glb under
// ../shared/assets/edge_cases/ (the Khronos glTF validator's corpus and the
// other edge cases) is uploaded to a real impostor-server and baked by real
// impostor-worker processes on loopback. Each one must either bake or fail
// with a specific code and a one-line message; no worker may die, no job may
// hang or be retried, and the server must still serve afterwards.
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <future>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <grpcpp/generic/generic_stub.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "client/transfer/mesh_files.h"
#include "common/request/bake_request.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::ChildProcess;
using testing::ServerProcess;

// A bake of 2x2 frames at 64 px takes well under a second on lavapipe; a
// job not finished this long after its turn came is stuck.
constexpr auto kPerJobDeadline = std::chrono::seconds(120);

// Codes a bake of an untrusted file may legitimately fail with:
// INVALID_ARGUMENT for anything wrong with the file (LoadGltfScene's
// contract), RESOURCE_EXHAUSTED for a file over a GltfLoadLimits limit.
// INTERNAL, UNKNOWN and the retryable codes mean the worker or the service
// broke, not the input.
const std::set<int>& CleanFailureCodes() {
  static const std::set<int> kCodes = {grpc::StatusCode::INVALID_ARGUMENT,
                                       grpc::StatusCode::RESOURCE_EXHAUSTED};
  return kCodes;
}

std::string CodeName(int code) {
  switch (code) {
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    default: return "code " + std::to_string(code);
  }
}

bool IsModelFile(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".gltf" || ext == ".glb";
}

// Every entry file under edge_cases/, sorted so runs are comparable.
std::vector<fs::path> CorpusFiles() {
  std::vector<fs::path> files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(AssetsDir() / "edge_cases", ec), end; !ec && it != end;
       it.increment(ec)) {
    if (it->is_regular_file() && IsModelFile(it->path())) files.push_back(it->path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The external files `entry` refers to that exist inside its folder, as
// (MeshInput path, local path). Unlike sdk::CollectMeshFiles this never
// refuses the model: a missing, absolute, escaping or malformed uri is simply
// not uploaded, so that the worker, not the client, meets the problem.
std::vector<std::pair<std::string, fs::path>> ExistingExternalFiles(const fs::path& entry,
                                                                     const std::string& bytes) {
  std::string json = bytes;
  if (bytes.compare(0, 4, "glTF") == 0) {
    absl::StatusOr<std::string> chunk = sdk::GlbJsonChunk(bytes, entry.filename().string());
    if (!chunk.ok()) return {};
    json = *chunk;
  }
  const nlohmann::json doc = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return {};
  std::vector<std::pair<std::string, fs::path>> files;
  std::set<std::string> seen;
  for (const char* kind : {"buffers", "images"}) {
    auto array = doc.find(kind);
    if (array == doc.end() || !array->is_array()) continue;
    for (const nlohmann::json& item : *array) {
      if (!item.is_object()) continue;
      auto uri = item.find("uri");
      if (uri == item.end() || !uri->is_string()) continue;
      const std::string text = uri->get<std::string>();
      if (text.rfind("data:", 0) == 0) continue;
      absl::StatusOr<std::string> decoded = sdk::PercentDecode(text);
      if (!decoded.ok() || decoded->find(':') != std::string::npos) continue;
      const fs::path relative = fs::path(*decoded).lexically_normal();
      if (relative.empty() || relative.is_absolute() || *relative.begin() == "..") continue;
      const std::string path = relative.generic_string();
      std::error_code ec;
      if (!fs::is_regular_file(entry.parent_path() / relative, ec)) continue;
      if (!ValidateRelativePath("path", path).ok() || !seen.insert(path).second) continue;
      files.emplace_back(path, entry.parent_path() / relative);
    }
  }
  return files;
}

// Uploads `entry` and the external files it uses; returns the MeshInput.
v1::MeshInput UploadModel(v1::AssetService::Stub& assets, const fs::path& entry) {
  const std::string bytes = testing::ReadFileBytes(entry);
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path(entry.filename().string());
  *mesh.mutable_entry()->mutable_digest() = testing::DigestOf(bytes);
  grpc::Status s = testing::UploadBytes(assets, bytes, mesh.entry().digest());
  EXPECT_TRUE(s.ok()) << entry << ": uploading the entry: " << s.error_message();
  for (const auto& [path, local] : ExistingExternalFiles(entry, bytes)) {
    const std::string file_bytes = testing::ReadFileBytes(local);
    v1::InputFile* file = mesh.add_files();
    file->set_path(path);
    *file->mutable_digest() = testing::DigestOf(file_bytes);
    s = testing::UploadBytes(assets, file_bytes, file->digest());
    EXPECT_TRUE(s.ok()) << entry << ": uploading " << path << ": " << s.error_message();
  }
  return mesh;
}

// Follows WatchJob until the job ends or `deadline` passes; `status` is the
// stream's final status (DEADLINE_EXCEEDED for a stuck job).
v1::Job WatchWithDeadline(v1::BakeService::Stub& bake, const std::string& job_id,
                          std::chrono::seconds deadline, grpc::Status* status) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + deadline);
  v1::WatchJobRequest request;
  request.set_job_id(job_id);
  auto reader = bake.WatchJob(&ctx, request);
  v1::Job job, last;
  while (reader->Read(&job)) last = job;
  *status = reader->Finish();
  return last;
}

bool IsTerminal(v1::JobState state) {
  return state == v1::JOB_STATE_SUCCEEDED || state == v1::JOB_STATE_FAILED ||
         state == v1::JOB_STATE_CANCELLED;
}

// grpc.health.v1.Health/Check for the whole server; true if SERVING.
bool ServerIsServing(const std::shared_ptr<grpc::Channel>& channel) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1), response;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&ctx, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&](grpc::Status s) { done.set_value(s); });
  if (!done.get_future().get().ok()) return false;
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) return false;
  std::string bytes;
  for (const auto& slice : slices) bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  return bytes == std::string("\x08\x01", 2);  // status: SERVING
}

// The last `max_bytes` of a log file, for failure messages.
std::string Tail(const fs::path& log, size_t max_bytes = 4000) {
  const std::string text = testing::ReadFileBytes(log);
  return text.size() <= max_bytes ? text : text.substr(text.size() - max_bytes);
}

v1::BakeParameters SmallParameters(uint32_t resolution = 64) {
  v1::BakeParameters p;
  p.set_layout(v1::LAYOUT_OCTAHEDRAL);
  p.set_frames(3);
  p.set_resolution(resolution);
  return p;
}

struct Outcome {
  fs::path file;
  std::string name;  // relative to edge_cases/, for messages
  grpc::Status submit;
  std::string job_id;
  v1::Job job;
};

TEST(HostileCorpus, EveryEdgeCaseBakesOrFailsCleanlyAndTheServiceSurvives) {
  const std::vector<fs::path> corpus = CorpusFiles();
  // The validator corpus alone has 279 entries; fewer means the assets are
  // missing, and the test would prove nothing.
  ASSERT_GE(corpus.size(), 279u) << "edge_cases corpus not found under " << AssetsDir();

  // Workers are started here rather than with --local-workers: the server
  // restarts dead local workers, which would hide a crash.
  ServerProcess server(/*local_workers=*/0);
  const fs::path logs = testing::NewTempDir("hostile_worker_logs");
  std::vector<std::unique_ptr<ChildProcess>> workers;
  std::vector<fs::path> worker_logs;
  for (int i = 0; i < 2; ++i) {
    worker_logs.push_back(logs / ("worker" + std::to_string(i) + ".log"));
    // exec keeps the pid: the ChildProcess is the worker itself.
    workers.push_back(std::make_unique<ChildProcess>(std::vector<std::string>{
        "/bin/sh", "-c",
        "exec '" + (testing::BinaryDir() / "impostor-worker").string() + "' --server=" + server.address() +
            " --log-level=info 2>'" + worker_logs.back().string() + "'"}));
  }

  // Upload and submit everything before watching anything, so the queue
  // holds the whole corpus at once.
  std::vector<Outcome> outcomes;
  for (const fs::path& file : corpus) {
    Outcome o;
    o.file = file;
    o.name = file.lexically_relative(AssetsDir() / "edge_cases").generic_string();
    v1::SubmitBakeRequest request;
    *request.mutable_mesh() = UploadModel(server.assets(), file);
    *request.mutable_parameters() = SmallParameters();
    v1::SubmitBakeResponse response;
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    o.submit = server.bake().SubmitBake(&ctx, request, &response);
    o.job_id = response.job_id();
    outcomes.push_back(std::move(o));
  }

  int baked = 0, refused_at_submit = 0;
  std::map<std::string, int> failed_by_code;
  for (Outcome& o : outcomes) {
    if (!o.submit.ok()) {
      // SubmitBake may refuse a request outright (e.g. an empty entry file
      // has no valid digest); that must be a request error naming it.
      EXPECT_EQ(o.submit.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
          << o.name << ": SubmitBake: " << o.submit.error_message();
      EXPECT_FALSE(o.submit.error_message().empty()) << o.name << ": SubmitBake refused without a message";
      ++refused_at_submit;
      continue;
    }
    grpc::Status watch;
    o.job = WatchWithDeadline(server.bake(), o.job_id, kPerJobDeadline, &watch);
    EXPECT_TRUE(watch.ok()) << o.name << ": WatchJob " << CodeName(watch.error_code()) << ": "
                            << watch.error_message() << " (stuck in state " << v1::JobState_Name(o.job.state())
                            << ", stage '" << o.job.stage() << "')";
    if (!IsTerminal(o.job.state())) continue;
    // A second attempt means a worker lost the lease: it crashed or hung.
    EXPECT_LE(o.job.attempts(), 1u) << o.name << ": leased " << o.job.attempts() << " times";
    if (o.job.state() == v1::JOB_STATE_SUCCEEDED) {
      ++baked;
      continue;
    }
    EXPECT_EQ(o.job.state(), v1::JOB_STATE_FAILED) << o.name;
    const v1::ErrorStatus& e = o.job.error();
    EXPECT_TRUE(CleanFailureCodes().count(e.code()))
        << o.name << ": failed with " << CodeName(e.code()) << ": " << e.message();
    EXPECT_FALSE(e.message().empty()) << o.name << ": failed without a message";
    EXPECT_EQ(e.message().find('\n'), std::string::npos) << o.name << ": message is not one line: " << e.message();
    ++failed_by_code[CodeName(e.code())];
  }
  // One line per file, for whoever reviews what the service says about each.
  for (const Outcome& o : outcomes) {
    const std::string what = !o.submit.ok() ? "refused at submit: " + o.submit.error_message()
                             : o.job.state() == v1::JOB_STATE_SUCCEEDED
                                 ? std::string("baked")
                                 : CodeName(o.job.error().code()) + ": " + o.job.error().message();
    std::printf("  %s: %s\n", o.name.c_str(), what.c_str());
  }

  // Every worker is still the process it started as.
  int crashes = 0;
  for (size_t i = 0; i < workers.size(); ++i) {
    int status = 0;
    const pid_t reaped = ::waitpid(workers[i]->pid(), &status, WNOHANG);
    if (reaped != 0) {
      ++crashes;
      ADD_FAILURE() << "worker " << i << " died ("
                    << (WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status))
                                            : "exit " + std::to_string(WEXITSTATUS(status)))
                    << "); its log ends:\n"
                    << Tail(worker_logs[i]);
    }
  }

  // The service still serves: health, and a fresh bake of a good mesh (a
  // resolution no corpus job used, so it cannot come from the cache).
  EXPECT_TRUE(ServerIsServing(server.channel())) << "health check failed after the corpus";
  if (crashes == 0) {
    v1::SubmitBakeRequest request;
    *request.mutable_mesh() =
        testing::UploadGlb(server.assets(), AssetsDir() / "props_pbr/Box/glTF-Binary/Box.glb");
    *request.mutable_parameters() = SmallParameters(/*resolution=*/96);
    v1::SubmitBakeResponse response;
    grpc::ClientContext ctx;
    ASSERT_TRUE(server.bake().SubmitBake(&ctx, request, &response).ok());
    grpc::Status watch;
    const v1::Job job = WatchWithDeadline(server.bake(), response.job_id(), kPerJobDeadline, &watch);
    EXPECT_TRUE(watch.ok()) << watch.error_message();
    EXPECT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED) << "Box.glb after the corpus: " << job.error().message();
    grpc::ClientContext lookup_ctx;
    v1::LookupBakeResponse lookup;
    ASSERT_TRUE(server.bake().LookupBake(&lookup_ctx, request, &lookup).ok());
    EXPECT_TRUE(lookup.found()) << "LookupBake does not find the bake that just succeeded";
  }

  int failed = 0;
  std::string by_code;
  for (const auto& [code, n] : failed_by_code) {
    failed += n;
    by_code += (by_code.empty() ? "" : ", ") + code + " " + std::to_string(n);
  }
  std::printf("hostile corpus: %zu files, %d baked, %d failed cleanly (%s), %d refused at submit, %d crashes\n",
              corpus.size(), baked, failed, by_code.c_str(), refused_at_submit, crashes);
  EXPECT_EQ(baked + failed + refused_at_submit, static_cast<int>(corpus.size()));
}

}  // namespace
}  // namespace impostor
