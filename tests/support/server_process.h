// Test harness for real processes: run impostor-server (and workers, and the
// `impostor` tool) as child processes on a loopback port chosen by the
// kernel, and talk to them with the generated gRPC stubs.
//
// The rules every integration test gets from here:
//  - every wait has a deadline (reading a line, waiting for an exit, a
//    WatchJob stream, a log line); a missed deadline is a test failure that
//    names what was awaited, never a hang until ctest's timeout;
//  - each child runs in its own process group, and the whole group (a
//    server's local workers, a shell's pipeline) is killed with SIGKILL when
//    the ChildProcess goes away, also when a test ends with an exception or
//    std::terminate;
//  - each child's stderr (where the tools log and print their reasons) goes
//    to a log file; its tail is printed when the test that owns the process
//    has failed, and Stderr() gives the text to assert on.
//
// Threads: a ChildProcess or ServerProcess is used from one thread at a time
// (Kill/Stop/Continue/Running may also be called from another while a
// Wait is in progress). Threads that tests start should be std::jthread or
// be joined by a scope guard, declared after the processes they talk to.
#ifndef IMPOSTOR_TESTS_SUPPORT_SERVER_PROCESS_H_
#define IMPOSTOR_TESTS_SUPPORT_SERVER_PROCESS_H_

#include <signal.h>
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/bake_service.grpc.pb.h"
#include "impostor/v1/worker_service.grpc.pb.h"

namespace impostor::testing {

// Default deadlines. Generous: they exist to turn a hang into a failure
// that says what hung, on a loaded 2-core machine running lavapipe.
inline constexpr std::chrono::seconds kStartTimeout{60};   // a process's readiness line
inline constexpr std::chrono::seconds kExitTimeout{300};   // a process's exit (a CLI bake)
inline constexpr std::chrono::seconds kWatchTimeout{300};  // a job reaching a terminal state
inline constexpr std::chrono::seconds kRpcTimeout{30};     // one unary RPC

struct ProcessOptions {
  // Shown in log dumps and used in the log file's name; default: the
  // program's file name.
  std::string name;
  // Extra environment for the child, "NAME=VALUE" (replacing inherited ones).
  std::vector<std::string> env;
  // stderr to a log file (Stderr(), dumped on failure). false: inherited.
  bool capture_stderr = true;
};

// A child process in its own process group; the group is killed (SIGKILL)
// and the child reaped on destruction.
class ChildProcess {
 public:
  // Starts `argv` (argv[0] is a path, no PATH lookup); its stdout is
  // readable through ReadLineContaining and Wait.
  explicit ChildProcess(std::vector<std::string> argv, ProcessOptions options = {});
  ~ChildProcess();
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // Reads stdout until a line containing `needle` (returned), EOF or the
  // deadline ("" for both; the caller decides whether that fails a test).
  std::string ReadLineContaining(const std::string& needle,
                                 std::chrono::milliseconds timeout = kStartTimeout);
  pid_t pid() const { return pid_; }
  const std::string& name() const { return name_; }

  // SIGTERM to the process, then waits for it; after `timeout` the group is
  // killed and the test fails. Returns the raw waitpid status (-1 if the
  // process was already reaped).
  int Terminate(std::chrono::milliseconds timeout = std::chrono::seconds(30));
  // Waits for the process to exit by itself; returns its exit code (or 128 +
  // signal), and everything it wrote to stdout not yet read. Past `timeout`
  // the test fails naming the process, the group is killed and -1 returned.
  int Wait(std::string* rest_of_stdout = nullptr, std::chrono::milliseconds timeout = kExitTimeout);

  // Sends `sig` to the whole process group (SIGSTOP hangs a worker,
  // SIGCONT resumes it). No effect once the process was reaped.
  void Signal(int sig);
  // SIGKILL to the group and reap; returns the raw waitpid status.
  int KillAndReap();
  // True while the process has not exited (reaps it if it has).
  bool Running();
  // Exit code (or 128 + signal) once reaped by Wait/Running/KillAndReap; -1 before.
  int exit_code() const { return exit_code_; }

  // Everything the process wrote to stderr so far ("" when not captured).
  std::string Stderr() const;
  const std::filesystem::path& log_path() const { return log_path_; }
  // How many lines of the stderr log contain `needle`.
  int CountInLog(const std::string& needle) const;
  // Waits (inotify, no polling) until at least `count` lines of the stderr
  // log contain `needle`. False at the deadline or when the process exited
  // without writing them.
  bool WaitForLog(const std::string& needle, int count = 1,
                  std::chrono::milliseconds timeout = kStartTimeout);
  // Prints the last `lines` lines of the log, headed by the process's name.
  void DumpLogTail(int lines = 60) const;

 private:
  void Reap(int options_for_waitpid);

  std::string name_;
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  int pidfd_ = -1;
  int exit_code_ = -1;
  int raw_status_ = -1;
  std::string buffer_;
  std::filesystem::path log_path_;
};

std::filesystem::path BinaryDir();  // where impostor-server & co. live
std::filesystem::path AssetsDir();  // ../shared/assets
std::filesystem::path NewTempDir(const std::string& name);

// How a test's own channel reaches a server that serves TLS: the CA it
// trusts and, for mutual TLS, the client certificate it presents (PEM file
// paths). All empty = plaintext.
struct ChannelTls {
  std::string ca_file;
  std::string cert_file;
  std::string key_file;
  // The name the server's certificate carries, when not the dial address's
  // host (the ssl target name override). Empty = that host.
  std::string server_name;
};

// Channel credentials for `tls` (insecure when it is empty).
std::shared_ptr<grpc::ChannelCredentials> CredentialsFor(const ChannelTls& tls);

// impostor-server on 127.0.0.1:<port the kernel picked> with its own data
// directory, ready to serve when the constructor returns: it has printed its
// "listening on" line (after binding) and a channel to it is connected.
// A server that does not get there within kStartTimeout fails the test with
// its log's tail and throws (GoogleTest reports the exception and ends the
// test; destructors kill what was started).
class ServerProcess {
 public:
  explicit ServerProcess(int local_workers, std::vector<std::string> extra_args = {});
  // A server on a given data directory and listen address ("127.0.0.1:PORT"),
  // e.g. to restart one where a killed one was, with its blobs and results.
  ServerProcess(int local_workers, std::filesystem::path data_dir, const std::string& listen,
                std::vector<std::string> extra_args = {});
  // A server started with TLS flags in `extra_args` (--tls-cert, ...): the
  // harness's channel connects with `tls`.
  ServerProcess(int local_workers, std::vector<std::string> extra_args, ChannelTls tls);
  const std::string& address() const { return address_; }
  const std::filesystem::path& data_dir() const { return data_dir_; }
  std::shared_ptr<grpc::Channel> channel() const { return channel_; }
  v1::BakeService::Stub& bake() { return *bake_; }
  v1::AssetService::Stub& assets() { return *assets_; }
  v1::WorkerService::Stub& workers() { return *workers_; }
  ChildProcess& process() { return *process_; }

  // SIGKILL to the server and its local workers; the data directory stays.
  void Kill();
  // Starts the server again on the same data directory and address (after
  // Kill, or while it runs: then it is killed first). Same readiness rules
  // as the constructor.
  void Restart();

  // Identity (issue 14): from now on (and after Restart) the harness's
  // channel and stubs send "authorization: Bearer <token>".
  void UseToken(const std::string& token);

 private:
  void Start();
  void Connect();
  std::string token_;

  int local_workers_ = 0;
  std::vector<std::string> extra_args_;
  std::string listen_;
  ChannelTls tls_;
  std::filesystem::path data_dir_;
  std::unique_ptr<ChildProcess> process_;
  std::string address_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::BakeService::Stub> bake_;
  std::unique_ptr<v1::AssetService::Stub> assets_;
  std::unique_ptr<v1::WorkerService::Stub> workers_;
};

// Identity (issue 14). Runs `impostor-server token create` on `data_dir`
// (the server may be running); returns the secret, or "" after failing the
// test with the tool's message. `expires_in` e.g. "1s"; "" = never.
std::string CreateToken(const std::filesystem::path& data_dir, const std::string& role, const std::string& name,
                        const std::string& expires_in = "");
// A context whose deadline is `timeout` from now and whose "authorization"
// metadata is `authorization` (sent as is; "" = none).
std::unique_ptr<grpc::ClientContext> ContextWithAuthorization(const std::string& authorization,
                                                              std::chrono::milliseconds timeout = kRpcTimeout);

// impostor-worker against `server_address`, its stderr in its log.
// `extra_args` e.g. {"--max-jobs=1"}; `env` e.g. the pause-file hook.
std::unique_ptr<ChildProcess> StartWorker(const std::string& server_address, std::vector<std::string> extra_args = {},
                                          std::vector<std::string> env = {});

// Runs `argv` to its end (bounded by `timeout`); stdout and stderr apart.
struct ToolRun {
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};
ToolRun RunTool(std::vector<std::string> argv, std::chrono::milliseconds timeout = kExitTimeout,
                std::vector<std::string> env = {});

// Waits (inotify on `dir`, no polling) until `done()` holds; `done` is
// checked at once and whenever an entry of `dir` is created, renamed into it
// or written. False at the deadline.
bool WaitForDirectory(const std::filesystem::path& dir, const std::function<bool()>& done,
                      std::chrono::milliseconds timeout = kWatchTimeout);

// A client context whose deadline is `timeout` from now.
std::unique_ptr<grpc::ClientContext> ContextWithin(std::chrono::milliseconds timeout = kRpcTimeout);

// Uploads bytes as one blob; returns the RPC status.
grpc::Status UploadBytes(v1::AssetService::Stub& assets, const std::string& bytes, const v1::Digest& digest);
v1::Digest DigestOf(const std::string& bytes);
std::string ReadFileBytes(const std::filesystem::path& path);

// Uploads a .glb (no external files) and returns the MeshInput naming it.
v1::MeshInput UploadGlb(v1::AssetService::Stub& assets, const std::filesystem::path& glb,
                        const std::string& name_override = "");

// Follows WatchJob to a terminal state; returns the last Job seen. A stream
// that ends otherwise (error, or `timeout`) fails the test naming the job
// and where it was stuck.
v1::Job WatchToEnd(v1::BakeService::Stub& bake, const std::string& job_id, std::vector<v1::Job>* updates = nullptr,
                   std::chrono::milliseconds timeout = kWatchTimeout);
// Follows WatchJob until `done(job)` holds (returns that job) or the stream
// ends; past `timeout` the test fails naming the job and its last state.
v1::Job WatchUntil(v1::BakeService::Stub& bake, const std::string& job_id,
                   const std::function<bool(const v1::Job&)>& done, std::chrono::milliseconds timeout = kWatchTimeout);
bool IsTerminalState(v1::JobState state);
// Ended, or queued again after a failed attempt: what a test of a retryable
// failure waits for.
bool EndedOrRequeued(const v1::Job& job);
// SubmitBake of `mesh` at frames x frames and `resolution` px, every other
// parameter the default; the job id (a refused submit fails the test).
std::string SubmitSmallBake(v1::BakeService::Stub& bake, const v1::MeshInput& mesh, uint32_t frames,
                            uint32_t resolution);

// Downloads a blob with ReadBlob (bounded by kWatchTimeout).
grpc::Status ReadBlob(v1::AssetService::Stub& assets, const v1::Digest& digest, std::string* out,
                      int64_t offset = 0, int64_t limit = 0);

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_SERVER_PROCESS_H_
