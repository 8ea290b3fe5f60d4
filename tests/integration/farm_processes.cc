#include "tests/integration/farm_processes.h"

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

namespace impostor::testing {

ScopedEnv::ScopedEnv(std::map<std::string, std::string> vars) {
  for (const auto& [name, value] : vars) {
    const char* old = std::getenv(name.c_str());
    saved_[name] = old ? std::optional<std::string>(old) : std::nullopt;
    ::setenv(name.c_str(), value.c_str(), 1);
  }
}

ScopedEnv::~ScopedEnv() {
  for (const auto& [name, value] : saved_) {
    if (value) {
      ::setenv(name.c_str(), value->c_str(), 1);
    } else {
      ::unsetenv(name.c_str());
    }
  }
}

std::unique_ptr<ChildProcess> StartWorker(const std::string& address, const std::string& name,
                                          const std::vector<std::string>& extra,
                                          const std::map<std::string, std::string>& env) {
  ScopedEnv scoped(env);
  std::vector<std::string> argv = {(BinaryDir() / "impostor-worker").string(), "--server=" + address,
                                   "--name=" + name, "--log-level=warn"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return std::make_unique<ChildProcess>(argv);
}

v1::Job GetJob(v1::BakeService::Stub& bake, const std::string& job_id) {
  grpc::ClientContext ctx;
  v1::GetJobRequest request;
  request.set_job_id(job_id);
  v1::Job job;
  const grpc::Status s = bake.GetJob(&ctx, request, &job);
  EXPECT_TRUE(s.ok()) << "GetJob " << job_id << ": " << s.error_message();
  return job;
}

v1::SubmitBakeResponse SubmitSmall(v1::BakeService::Stub& bake, const v1::MeshInput& mesh) {
  grpc::ClientContext ctx;
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = mesh;
  request.mutable_parameters()->set_frames(3);
  request.mutable_parameters()->set_resolution(64);
  v1::SubmitBakeResponse response;
  const grpc::Status s = bake.SubmitBake(&ctx, request, &response);
  EXPECT_TRUE(s.ok()) << "SubmitBake: " << s.error_message();
  return response;
}

int FreeLoopbackPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  socklen_t len = sizeof(addr);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

void Touch(const std::filesystem::path& file) { std::ofstream(file) << "pause"; }

v1::SubmitBakeResponse SubmitWithPaddedInput(ServerProcess& server, const std::filesystem::path& glb,
                                             size_t pad_bytes, uint32_t seed) {
  v1::MeshInput mesh = UploadGlb(server.assets(), glb);
  std::mt19937 rng(seed);
  std::string pad(pad_bytes, '\0');
  for (char& c : pad) c = static_cast<char>(rng());
  v1::InputFile* extra = mesh.add_files();
  extra->set_path("pad.bin");
  *extra->mutable_digest() = DigestOf(pad);
  EXPECT_TRUE(UploadBytes(server.assets(), pad, extra->digest()).ok());
  const v1::SubmitBakeResponse submitted = SubmitSmall(server.bake(), mesh);
  EXPECT_FALSE(submitted.cached());
  return submitted;
}

}  // namespace impostor::testing
