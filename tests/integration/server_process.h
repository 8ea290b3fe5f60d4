// Test fixture helpers: run impostor-server (and workers) as real child
// processes on a loopback port chosen by the kernel, and talk to them with
// the generated gRPC stubs.
#ifndef IMPOSTOR_TESTS_INTEGRATION_SERVER_PROCESS_H_
#define IMPOSTOR_TESTS_INTEGRATION_SERVER_PROCESS_H_

#include <sys/types.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/bake_service.grpc.pb.h"
#include "impostor/v1/worker_service.grpc.pb.h"

namespace impostor::testing {

// A child process; killed (SIGKILL) and reaped on destruction.
class ChildProcess {
 public:
  // Starts `argv`; its stdout is readable through ReadLineContaining.
  explicit ChildProcess(std::vector<std::string> argv);
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // Reads stdout until a line containing `needle` (returned) or EOF ("").
  std::string ReadLineContaining(const std::string& needle);
  pid_t pid() const { return pid_; }
  // SIGTERM then wait; returns the exit status as waitpid reports it.
  int Terminate();
  // Waits for the process to exit by itself; returns its exit code (or 128 +
  // signal), and everything it wrote to stdout not yet read.
  int Wait(std::string* rest_of_stdout = nullptr);

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string buffer_;
};

std::filesystem::path BinaryDir();  // where impostor-server & co. live
std::filesystem::path AssetsDir();  // ../shared/assets
std::filesystem::path NewTempDir(const std::string& name);

// impostor-server on 127.0.0.1:<free port> with its own data directory.
class ServerProcess {
 public:
  explicit ServerProcess(int local_workers, std::vector<std::string> extra_args = {});
  // A server on a given data directory and listen address ("127.0.0.1:PORT"),
  // e.g. to restart one where a killed one was, with its blobs and results.
  ServerProcess(int local_workers, std::filesystem::path data_dir, const std::string& listen,
                std::vector<std::string> extra_args = {});
  const std::string& address() const { return address_; }
  const std::filesystem::path& data_dir() const { return data_dir_; }
  std::shared_ptr<grpc::Channel> channel() const { return channel_; }
  v1::BakeService::Stub& bake() { return *bake_; }
  v1::AssetService::Stub& assets() { return *assets_; }
  v1::WorkerService::Stub& workers() { return *workers_; }
  ChildProcess& process() { return *process_; }

 private:
  void Start(int local_workers, const std::string& listen, const std::vector<std::string>& extra_args);

  std::filesystem::path data_dir_;
  std::unique_ptr<ChildProcess> process_;
  std::string address_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::BakeService::Stub> bake_;
  std::unique_ptr<v1::AssetService::Stub> assets_;
  std::unique_ptr<v1::WorkerService::Stub> workers_;
};

// Uploads bytes as one blob; returns the RPC status.
grpc::Status UploadBytes(v1::AssetService::Stub& assets, const std::string& bytes, const v1::Digest& digest);
v1::Digest DigestOf(const std::string& bytes);
std::string ReadFileBytes(const std::filesystem::path& path);

// Uploads a .glb (no external files) and returns the MeshInput naming it.
v1::MeshInput UploadGlb(v1::AssetService::Stub& assets, const std::filesystem::path& glb,
                        const std::string& name_override = "");

// Follows WatchJob to a terminal state; returns the last Job seen.
v1::Job WatchToEnd(v1::BakeService::Stub& bake, const std::string& job_id, std::vector<v1::Job>* updates = nullptr);

// Downloads a blob with ReadBlob.
grpc::Status ReadBlob(v1::AssetService::Stub& assets, const v1::Digest& digest, std::string* out,
                      int64_t offset = 0, int64_t limit = 0);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_INTEGRATION_SERVER_PROCESS_H_
