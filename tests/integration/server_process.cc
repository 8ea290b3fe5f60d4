#include "tests/integration/server_process.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "common/sha256.h"

namespace impostor::testing {

ChildProcess::ChildProcess(std::vector<std::string> argv) {
  int fds[2];
  if (::pipe(fds) != 0) return;
  std::vector<char*> args;
  for (auto& a : argv) args.push_back(a.data());
  args.push_back(nullptr);
  pid_ = ::fork();
  if (pid_ == 0) {
    ::dup2(fds[1], STDOUT_FILENO);
    ::close(fds[0]);
    ::close(fds[1]);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  stdout_fd_ = fds[0];
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
  if (stdout_fd_ >= 0) ::close(stdout_fd_);
}

int ChildProcess::Terminate() {
  if (pid_ <= 0) return -1;
  ::kill(pid_, SIGTERM);
  int status = 0;
  ::waitpid(pid_, &status, 0);
  pid_ = -1;
  return status;
}

int ChildProcess::Wait(std::string* rest_of_stdout) {
  std::string out = buffer_;
  buffer_.clear();
  char chunk[4096];
  ssize_t n;
  while ((n = ::read(stdout_fd_, chunk, sizeof(chunk))) > 0) out.append(chunk, static_cast<size_t>(n));
  if (rest_of_stdout) *rest_of_stdout = out;
  int status = 0;
  ::waitpid(pid_, &status, 0);
  pid_ = -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string ChildProcess::ReadLineContaining(const std::string& needle) {
  while (true) {
    size_t nl;
    while ((nl = buffer_.find('\n')) != std::string::npos) {
      std::string line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      if (line.find(needle) != std::string::npos) return line;
    }
    char chunk[4096];
    const ssize_t n = ::read(stdout_fd_, chunk, sizeof(chunk));
    if (n <= 0) return "";
    buffer_.append(chunk, static_cast<size_t>(n));
  }
}

std::filesystem::path BinaryDir() { return IMPOSTOR_TEST_BINARY_DIR; }
std::filesystem::path AssetsDir() { return IMPOSTOR_TEST_ASSETS_DIR; }

std::filesystem::path NewTempDir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("impostor_it_" + std::to_string(::getpid()) + "_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

ServerProcess::ServerProcess(int local_workers, std::vector<std::string> extra_args) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  data_dir_ = NewTempDir(std::string(info->test_suite_name()) + "_" + info->name());
  Start(local_workers, "127.0.0.1:0", extra_args);
}

ServerProcess::ServerProcess(int local_workers, std::filesystem::path data_dir, const std::string& listen,
                             std::vector<std::string> extra_args)
    : data_dir_(std::move(data_dir)) {
  Start(local_workers, listen, extra_args);
}

void ServerProcess::Start(int local_workers, const std::string& listen, const std::vector<std::string>& extra_args) {
  std::vector<std::string> argv = {(BinaryDir() / "impostor-server").string(),
                                   "--listen=" + listen,
                                   "--data=" + data_dir_.string(),
                                   "--local-workers=" + std::to_string(local_workers),
                                   "--log-level=warn"};
  argv.insert(argv.end(), extra_args.begin(), extra_args.end());
  process_ = std::make_unique<ChildProcess>(argv);
  const std::string line = process_->ReadLineContaining("listening on");
  EXPECT_FALSE(line.empty()) << "impostor-server did not start";
  address_ = line.substr(line.rfind(' ') + 1);
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  channel_ = grpc::CreateCustomChannel(address_, grpc::InsecureChannelCredentials(), args);
  bake_ = v1::BakeService::NewStub(channel_);
  assets_ = v1::AssetService::NewStub(channel_);
  workers_ = v1::WorkerService::NewStub(channel_);
}

v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest d;
  d.set_hash(Sha256Hex(bytes));
  d.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return d;
}

std::string ReadFileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

grpc::Status UploadBytes(v1::AssetService::Stub& assets, const std::string& bytes, const v1::Digest& digest) {
  grpc::ClientContext ctx;
  v1::UploadBlobResponse response;
  auto writer = assets.UploadBlob(&ctx, &response);
  v1::UploadBlobRequest chunk;
  *chunk.mutable_digest() = digest;
  const size_t kChunk = 1 << 20;
  size_t pos = 0;
  do {
    chunk.set_data(bytes.substr(pos, kChunk));
    pos += kChunk;
    if (!writer->Write(chunk)) break;
    chunk.clear_digest();
  } while (pos < bytes.size());
  writer->WritesDone();
  return writer->Finish();
}

v1::MeshInput UploadGlb(v1::AssetService::Stub& assets, const std::filesystem::path& glb,
                        const std::string& name_override) {
  const std::string bytes = ReadFileBytes(glb);
  EXPECT_FALSE(bytes.empty()) << "cannot read " << glb;
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path(name_override.empty() ? glb.filename().string() : name_override);
  *mesh.mutable_entry()->mutable_digest() = DigestOf(bytes);
  const grpc::Status s = UploadBytes(assets, bytes, mesh.entry().digest());
  EXPECT_TRUE(s.ok()) << s.error_message();
  return mesh;
}

v1::Job WatchToEnd(v1::BakeService::Stub& bake, const std::string& job_id, std::vector<v1::Job>* updates) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::minutes(10));
  v1::WatchJobRequest request;
  request.set_job_id(job_id);
  auto reader = bake.WatchJob(&ctx, request);
  v1::Job job, last;
  while (reader->Read(&job)) {
    if (updates) updates->push_back(job);
    last = job;
  }
  const grpc::Status s = reader->Finish();
  EXPECT_TRUE(s.ok()) << "WatchJob: " << s.error_message();
  return last;
}

grpc::Status ReadBlob(v1::AssetService::Stub& assets, const v1::Digest& digest, std::string* out, int64_t offset,
                      int64_t limit) {
  grpc::ClientContext ctx;
  v1::ReadBlobRequest request;
  *request.mutable_digest() = digest;
  request.set_offset(offset);
  request.set_limit(limit);
  auto reader = assets.ReadBlob(&ctx, request);
  v1::ReadBlobResponse chunk;
  out->clear();
  while (reader->Read(&chunk)) out->append(chunk.data());
  return reader->Finish();
}

}  // namespace impostor::testing
