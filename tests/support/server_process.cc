#include "tests/support/server_process.h"
#include "tests/support/scratch_root.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/inotify.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>

#include <grpcpp/support/client_interceptor.h>
#include <gtest/gtest.h>

#include "common/util/sha256.h"

extern char** environ;

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Process groups still alive, killed if the test binary ends abnormally
// (std::terminate from a failed ASSERT on a thread, an uncaught exception
// outside a test body): a stray server would hold its port and data
// directory and confuse the next test.
std::mutex g_groups_mu;
std::set<pid_t>& LiveGroups() {
  static auto* groups = new std::set<pid_t>;
  return *groups;
}

void KillAllGroups() {
  std::lock_guard lock(g_groups_mu);
  for (pid_t group : LiveGroups()) ::kill(-group, SIGKILL);
}

void InstallTerminateHandler() {
  static std::once_flag once;
  std::call_once(once, [] {
    static std::terminate_handler previous = std::set_terminate([] {
      KillAllGroups();
      if (previous) previous();
      std::abort();
    });
    std::atexit(KillAllGroups);
  });
}

int Remaining(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return static_cast<int>(std::clamp<int64_t>(left, 0, 1 << 30));
}

int DecodeStatus(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

std::string Seconds(std::chrono::milliseconds d) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f s", static_cast<double>(d.count()) / 1000.0);
  return text;
}

// ScratchRoot() (scratch_root.h): every folder, log and child scratch file
// of this binary lives under it.

fs::path LogDir() {
  static const fs::path dir = [] {
    fs::path d = ScratchRoot() / "logs";
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

std::string LastLines(const std::string& text, int lines) {
  size_t pos = text.size();
  if (pos > 0 && text[pos - 1] == '\n') --pos;
  for (int n = 0; n < lines && pos > 0; ++n) {
    const size_t nl = text.rfind('\n', pos - 1);
    if (nl == std::string::npos) return text;
    pos = nl;
  }
  return text.substr(pos == 0 ? 0 : pos + 1);
}

// Sends the harness's token on every call of a ServerProcess's channel
// (the worker has the same in worker/bearer_token.cc, which the many test
// binaries built from this file do not link).
class TokenInterceptor : public grpc::experimental::Interceptor {
 public:
  explicit TokenInterceptor(const std::string* header) : header_(header) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->emplace("authorization", *header_);
    }
    methods->Proceed();
  }

 private:
  const std::string* header_;
};

class TokenInterceptorFactory : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit TokenInterceptorFactory(const std::string& token) : header_("Bearer " + token) {}
  grpc::experimental::Interceptor* CreateClientInterceptor(grpc::experimental::ClientRpcInfo*) override {
    return new TokenInterceptor(&header_);
  }

 private:
  const std::string header_;
};

bool CurrentTestFailed() {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return info != nullptr && ::testing::Test::HasFailure();
}

}  // namespace

ChildProcess::ChildProcess(std::vector<std::string> argv, ProcessOptions options) {
  InstallTerminateHandler();
  name_ = options.name.empty() ? fs::path(argv.at(0)).filename().string() : options.name;
  static std::atomic<int> sequence{0};
  if (options.capture_stderr) {
    std::string safe = name_;
    for (char& c : safe) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
    }
    log_path_ = LogDir() / (std::to_string(++sequence) + "_" + safe + ".log");
  }
  // Everything the child needs is built before fork: only async-signal-safe
  // calls between fork and exec.
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry = *e;
    const std::string key = entry.substr(0, entry.find('='));
    bool replaced = false;
    for (const std::string& extra : options.env) replaced |= extra.substr(0, extra.find('=')) == key;
    if (!replaced) env_strings.push_back(entry);
  }
  env_strings.insert(env_strings.end(), options.env.begin(), options.env.end());
  std::vector<char*> envp;
  for (auto& e : env_strings) envp.push_back(e.data());
  envp.push_back(nullptr);
  std::vector<char*> args;
  for (auto& a : argv) args.push_back(a.data());
  args.push_back(nullptr);

  int log_fd = -1;
  if (!log_path_.empty()) {
    log_fd = ::open(log_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    EXPECT_GE(log_fd, 0) << "cannot create " << log_path_ << ": " << std::strerror(errno);
  }
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    ADD_FAILURE() << "pipe: " << std::strerror(errno);
    if (log_fd >= 0) ::close(log_fd);
    return;
  }
  // stdin is /dev/null: a child in its own process group that read the
  // terminal would be stopped (SIGTTIN) when a test runs interactively.
  const int null_fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  pid_ = ::fork();
  if (pid_ == 0) {
    ::setpgid(0, 0);
    if (null_fd >= 0) ::dup2(null_fd, STDIN_FILENO);
    ::dup2(fds[1], STDOUT_FILENO);
    if (log_fd >= 0) ::dup2(log_fd, STDERR_FILENO);
    ::execve(args[0], args.data(), envp.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  if (log_fd >= 0) ::close(log_fd);
  if (null_fd >= 0) ::close(null_fd);
  stdout_fd_ = fds[0];
  if (pid_ < 0) {
    ADD_FAILURE() << "fork " << name_ << ": " << std::strerror(errno);
    return;
  }
  // Also from this side, so that a Signal() right after the constructor
  // reaches the group whichever process runs first.
  ::setpgid(pid_, pid_);
  {
    std::lock_guard lock(g_groups_mu);
    LiveGroups().insert(pid_);
  }
  pidfd_ = static_cast<int>(::syscall(SYS_pidfd_open, pid_, 0));
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0) {
    if (CurrentTestFailed()) DumpLogTail();
    KillAndReap();
  } else if (CurrentTestFailed() && !log_path_.empty()) {
    DumpLogTail();
  }
  if (stdout_fd_ >= 0) ::close(stdout_fd_);
  if (pidfd_ >= 0) ::close(pidfd_);
}

void ChildProcess::Reap(int waitpid_options) {
  if (pid_ <= 0) return;
  int status = 0;
  pid_t r;
  do {
    r = ::waitpid(pid_, &status, waitpid_options);
  } while (r < 0 && errno == EINTR);
  if (r == 0) return;  // still running (WNOHANG)
  if (r == pid_) {
    raw_status_ = status;
    exit_code_ = DecodeStatus(status);
  }
  // Whatever the group's other members were doing, they go with it.
  ::kill(-pid_, SIGKILL);
  {
    std::lock_guard lock(g_groups_mu);
    LiveGroups().erase(pid_);
  }
  pid_ = -1;
}

void ChildProcess::Signal(int sig) {
  if (pid_ > 0) ::kill(-pid_, sig);
}

int ChildProcess::KillAndReap() {
  if (pid_ <= 0) return raw_status_;
  ::kill(-pid_, SIGKILL);
  ::kill(pid_, SIGKILL);
  Reap(0);
  return raw_status_;
}

bool ChildProcess::Running() {
  Reap(WNOHANG);
  return pid_ > 0;
}

int ChildProcess::Terminate(std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return -1;
  ::kill(pid_, SIGTERM);
  const auto deadline = Clock::now() + timeout;
  while (true) {
    Reap(WNOHANG);
    if (pid_ <= 0) break;
    if (Clock::now() >= deadline) {
      // (The log's tail is printed when this object goes.)
      ADD_FAILURE() << name_ << " (pid " << pid_ << ") ignored SIGTERM for " << Seconds(timeout) << "; killed";
      KillAndReap();
      break;
    }
    pollfd p{pidfd_, POLLIN, 0};
    ::poll(&p, 1, std::min(Remaining(deadline), pidfd_ < 0 ? 100 : 1 << 30));
  }
  return raw_status_;
}

std::string ChildProcess::ReadLineContaining(const std::string& needle, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  while (true) {
    size_t nl;
    while ((nl = buffer_.find('\n')) != std::string::npos) {
      std::string line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      if (line.find(needle) != std::string::npos) return line;
    }
    if (stdout_fd_ < 0) return "";
    pollfd p{stdout_fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, Remaining(deadline));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) return "";  // deadline
    char chunk[4096];
    const ssize_t n = ::read(stdout_fd_, chunk, sizeof(chunk));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return "";
    buffer_.append(chunk, static_cast<size_t>(n));
  }
}

int ChildProcess::Wait(std::string* rest_of_stdout, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  std::string out = std::move(buffer_);
  buffer_.clear();
  bool eof = stdout_fd_ < 0;
  // Read stdout while the process runs (a full pipe would block it), until
  // it has exited and its stdout is closed. Grandchildren that keep the pipe
  // open (a server's local workers) are killed with the group at exit.
  while (true) {
    Reap(WNOHANG);
    if (pid_ <= 0 && eof) break;
    if (Clock::now() >= deadline) {
      ADD_FAILURE() << name_ << " did not exit within " << Seconds(timeout) << "; killed. stdout so far:\n"
                    << LastLines(out, 40);
      KillAndReap();
      if (rest_of_stdout) *rest_of_stdout = out;
      return -1;
    }
    pollfd p[2] = {{eof ? -1 : stdout_fd_, POLLIN, 0}, {pid_ > 0 ? pidfd_ : -1, POLLIN, 0}};
    const int ready = ::poll(p, 2, std::min(Remaining(deadline), pidfd_ < 0 ? 100 : 1 << 30));
    if (ready < 0 && errno != EINTR) break;
    if (!eof && (p[0].revents & (POLLIN | POLLHUP | POLLERR))) {
      char chunk[4096];
      const ssize_t n = ::read(stdout_fd_, chunk, sizeof(chunk));
      if (n > 0) {
        out.append(chunk, static_cast<size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        eof = true;
      }
    }
  }
  if (rest_of_stdout) *rest_of_stdout = out;
  return exit_code_;
}

std::string ChildProcess::Stderr() const { return log_path_.empty() ? "" : ReadFileBytes(log_path_); }

int ChildProcess::CountInLog(const std::string& needle) const {
  std::istringstream in(Stderr());
  int n = 0;
  for (std::string line; std::getline(in, line);) n += line.find(needle) != std::string::npos;
  return n;
}

bool ChildProcess::WaitForLog(const std::string& needle, int count, std::chrono::milliseconds timeout) {
  if (log_path_.empty()) {
    ADD_FAILURE() << name_ << ": stderr is not captured; cannot wait for \"" << needle << "\"";
    return false;
  }
  const auto deadline = Clock::now() + timeout;
  const int watch = ::inotify_init1(IN_CLOEXEC | IN_NONBLOCK);
  if (watch >= 0) ::inotify_add_watch(watch, log_path_.c_str(), IN_MODIFY);
  bool found = false;
  while (true) {
    // Watch first, then read: a line written in between still wakes us.
    if (CountInLog(needle) >= count) {
      found = true;
      break;
    }
    if (!Running() && CountInLog(needle) < count) break;
    if (Clock::now() >= deadline) break;
    pollfd p[2] = {{watch, POLLIN, 0}, {pidfd_, POLLIN, 0}};
    ::poll(p, 2, std::min(Remaining(deadline), watch < 0 ? 100 : 1 << 30));
    char events[4096];
    while (watch >= 0 && ::read(watch, events, sizeof(events)) > 0) {
    }
  }
  if (watch >= 0) ::close(watch);
  return found;
}

void ChildProcess::DumpLogTail(int lines) const {
  const std::string text = Stderr();
  std::printf("---- last %d lines of %s's stderr (%s) ----\n%s\n---- end of %s ----\n", lines, name_.c_str(),
              log_path_.c_str(), LastLines(text, lines).c_str(), name_.c_str());
  std::fflush(stdout);
}

fs::path BinaryDir() { return IMPOSTOR_TEST_BINARY_DIR; }
fs::path AssetsDir() { return IMPOSTOR_TEST_ASSETS_DIR; }

fs::path NewTempDir(const std::string& name) {
  // Inside ScratchRoot(); short, for PostgreSQL's socket paths (108 bytes).
  auto dir = ScratchRoot() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

ServerProcess::ServerProcess(int local_workers, std::vector<std::string> extra_args)
    : local_workers_(local_workers), extra_args_(std::move(extra_args)), listen_("127.0.0.1:0") {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  data_dir_ = NewTempDir(info ? std::string(info->test_suite_name()) + "_" + info->name() : "server");
  Start();
}

ServerProcess::ServerProcess(int local_workers, fs::path data_dir, const std::string& listen,
                             std::vector<std::string> extra_args)
    : local_workers_(local_workers), extra_args_(std::move(extra_args)), listen_(listen),
      data_dir_(std::move(data_dir)) {
  Start();
}

ServerProcess::ServerProcess(int local_workers, std::vector<std::string> extra_args, ChannelTls tls)
    : local_workers_(local_workers), extra_args_(std::move(extra_args)), listen_("127.0.0.1:0"), tls_(std::move(tls)) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  data_dir_ = NewTempDir(info ? std::string(info->test_suite_name()) + "_" + info->name() : "server");
  Start();
}

std::shared_ptr<grpc::ChannelCredentials> CredentialsFor(const ChannelTls& tls) {
  if (tls.ca_file.empty()) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions options;
  options.pem_root_certs = ReadFileBytes(tls.ca_file);
  if (!tls.cert_file.empty()) {
    options.pem_cert_chain = ReadFileBytes(tls.cert_file);
    options.pem_private_key = ReadFileBytes(tls.key_file);
  }
  return grpc::SslCredentials(options);
}

void ServerProcess::Start() {
  std::vector<std::string> argv = {(BinaryDir() / "impostor-server").string(),
                                   "--listen=" + listen_,
                                   "--data=" + data_dir_.string(),
                                   "--local-workers=" + std::to_string(local_workers_),
                                   "--log-level=info"};
  argv.insert(argv.end(), extra_args_.begin(), extra_args_.end());
  ProcessOptions options;
  options.name = "impostor-server";
  process_ = std::make_unique<ChildProcess>(argv, std::move(options));
  // The line is printed once the port is bound (as --port-file is written):
  // reading it is the readiness event, and it names the port the kernel chose.
  const std::string line = process_->ReadLineContaining("listening on", kStartTimeout);
  if (line.empty()) {
    // Its log's tail is printed as process_ goes, whichever way the test ends.
    if (process_->Running()) {
      ADD_FAILURE() << "impostor-server did not print its \"listening on\" line within " << Seconds(kStartTimeout);
    } else {
      ADD_FAILURE() << "impostor-server exited with " << process_->exit_code() << " before listening";
    }
    throw std::runtime_error("impostor-server did not start (see its log above)");
  }
  address_ = line.substr(line.rfind(' ') + 1);
  // Restarts keep the address the clients know.
  listen_ = address_;
  Connect();
}

void ServerProcess::Connect() {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  // A private subchannel pool: gRPC otherwise shares one connection per
  // address between channels, so a server restarted on the same address
  // could hand this fresh channel the dead server's reset connection.
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  if (!tls_.server_name.empty()) args.SetSslTargetNameOverride(tls_.server_name);
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
  if (!token_.empty()) interceptors.push_back(std::make_unique<TokenInterceptorFactory>(token_));
  channel_ = grpc::experimental::CreateCustomChannelWithInterceptors(address_, CredentialsFor(tls_), args,
                                                                     std::move(interceptors));
  if (!channel_->WaitForConnected(std::chrono::system_clock::now() + kStartTimeout)) {
    ADD_FAILURE() << "impostor-server at " << address_ << " printed its line but did not accept a connection within "
                  << Seconds(kStartTimeout);
    throw std::runtime_error("impostor-server did not accept connections");
  }
  bake_ = v1::BakeService::NewStub(channel_);
  assets_ = v1::AssetService::NewStub(channel_);
  workers_ = v1::WorkerService::NewStub(channel_);
}

void ServerProcess::Kill() {
  if (process_) process_->KillAndReap();
}

void ServerProcess::Restart() {
  Kill();
  process_.reset();
  Start();
}

void ServerProcess::UseToken(const std::string& token) {
  token_ = token;
  Connect();
}

std::string CreateToken(const fs::path& data_dir, const std::string& role, const std::string& name,
                        const std::string& expires_in) {
  std::vector<std::string> argv = {(BinaryDir() / "impostor-server").string(), "token", "create",
                                   "--data=" + data_dir.string(), "--role=" + role, "--name=" + name};
  if (!expires_in.empty()) argv.push_back("--expires-in=" + expires_in);
  const ToolRun run = RunTool(argv, kStartTimeout);
  EXPECT_EQ(run.exit_code, 0) << "token create " << role << " " << name << ": " << run.err;
  std::string secret = run.out.substr(0, run.out.find('\n'));
  return run.exit_code == 0 ? secret : "";
}

std::unique_ptr<grpc::ClientContext> ContextWithAuthorization(const std::string& authorization,
                                                              std::chrono::milliseconds timeout) {
  auto ctx = ContextWithin(timeout);
  if (!authorization.empty()) ctx->AddMetadata("authorization", authorization);
  return ctx;
}

std::unique_ptr<ChildProcess> StartWorker(const std::string& server_address, std::vector<std::string> extra_args,
                                          std::vector<std::string> env) {
  std::vector<std::string> argv = {(BinaryDir() / "impostor-worker").string(), "--server=" + server_address,
                                   "--log-level=info"};
  argv.insert(argv.end(), extra_args.begin(), extra_args.end());
  ProcessOptions options;
  options.name = "impostor-worker";
  options.env = std::move(env);
  return std::make_unique<ChildProcess>(argv, std::move(options));
}

ToolRun RunTool(std::vector<std::string> argv, std::chrono::milliseconds timeout, std::vector<std::string> env) {
  ProcessOptions options;
  options.env = std::move(env);
  ChildProcess p(std::move(argv), std::move(options));
  ToolRun run;
  run.exit_code = p.Wait(&run.out, timeout);
  run.err = p.Stderr();
  return run;
}

bool WaitForDirectory(const fs::path& dir, const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  std::error_code ec;
  fs::create_directories(dir, ec);
  const int watch = ::inotify_init1(IN_CLOEXEC | IN_NONBLOCK);
  if (watch >= 0) ::inotify_add_watch(watch, dir.c_str(), IN_CREATE | IN_MOVED_TO | IN_MODIFY | IN_CLOSE_WRITE);
  bool reached = false;
  // Watch first, then check: a change in between still wakes us.
  while (!(reached = done()) && Clock::now() < deadline) {
    pollfd p{watch, POLLIN, 0};
    ::poll(&p, 1, std::min(Remaining(deadline), watch < 0 ? 100 : 1 << 30));
    char events[4096];
    while (watch >= 0 && ::read(watch, events, sizeof(events)) > 0) {
    }
  }
  if (watch >= 0) ::close(watch);
  return reached;
}

std::unique_ptr<grpc::ClientContext> ContextWithin(std::chrono::milliseconds timeout) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + timeout);
  return ctx;
}

v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest d;
  d.set_hash(Sha256Hex(bytes));
  d.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return d;
}

std::string ReadFileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

grpc::Status UploadBytes(v1::AssetService::Stub& assets, const std::string& bytes, const v1::Digest& digest) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + kWatchTimeout);
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

v1::MeshInput UploadGlb(v1::AssetService::Stub& assets, const fs::path& glb, const std::string& name_override) {
  const std::string bytes = ReadFileBytes(glb);
  EXPECT_FALSE(bytes.empty()) << "cannot read " << glb;
  v1::MeshInput mesh;
  mesh.mutable_entry()->set_path(name_override.empty() ? glb.filename().string() : name_override);
  *mesh.mutable_entry()->mutable_digest() = DigestOf(bytes);
  const grpc::Status s = UploadBytes(assets, bytes, mesh.entry().digest());
  EXPECT_TRUE(s.ok()) << glb << ": " << s.error_message();
  return mesh;
}

bool IsTerminalState(v1::JobState state) {
  return state == v1::JOB_STATE_SUCCEEDED || state == v1::JOB_STATE_FAILED || state == v1::JOB_STATE_CANCELLED;
}

bool EndedOrRequeued(const v1::Job& job) {
  return IsTerminalState(job.state()) || (job.state() == v1::JOB_STATE_QUEUED && job.attempts() >= 1);
}

std::string SubmitSmallBake(v1::BakeService::Stub& bake, const v1::MeshInput& mesh, uint32_t frames,
                            uint32_t resolution) {
  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = mesh;
  request.mutable_parameters()->set_frames(frames);
  request.mutable_parameters()->set_resolution(resolution);
  v1::SubmitBakeResponse response;
  auto ctx = ContextWithin();
  const grpc::Status s = bake.SubmitBake(ctx.get(), request, &response);
  EXPECT_TRUE(s.ok()) << s.error_message();
  return response.job_id();
}

v1::Job WatchUntil(v1::BakeService::Stub& bake, const std::string& job_id,
                   const std::function<bool(const v1::Job&)>& done, std::chrono::milliseconds timeout) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + timeout);
  v1::WatchJobRequest request;
  request.set_job_id(job_id);
  auto reader = bake.WatchJob(&ctx, request);
  v1::Job job, last;
  bool reached = false;
  while (reader->Read(&job)) {
    last = job;
    if (done(job)) {
      reached = true;
      ctx.TryCancel();
      break;
    }
  }
  const grpc::Status s = reader->Finish();
  if (!reached) {
    ADD_FAILURE() << "WatchJob " << job_id << " ended (" << s.error_code() << ": " << s.error_message()
                  << ") before the awaited condition; last seen " << v1::JobState_Name(last.state()) << ", stage '"
                  << last.stage() << "', progress " << last.progress() << ", attempts " << last.attempts();
  }
  return last;
}

v1::Job WatchToEnd(v1::BakeService::Stub& bake, const std::string& job_id, std::vector<v1::Job>* updates,
                   std::chrono::milliseconds timeout) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + timeout);
  v1::WatchJobRequest request;
  request.set_job_id(job_id);
  auto reader = bake.WatchJob(&ctx, request);
  v1::Job job, last;
  while (reader->Read(&job)) {
    if (updates) updates->push_back(job);
    last = job;
  }
  const grpc::Status s = reader->Finish();
  EXPECT_TRUE(s.ok() && IsTerminalState(last.state()))
      << "WatchJob " << job_id << ": " << s.error_code() << " " << s.error_message() << "; stuck in "
      << v1::JobState_Name(last.state()) << ", stage '" << last.stage() << "', progress " << last.progress()
      << ", attempts " << last.attempts() << " (deadline " << Seconds(timeout) << ")";
  return last;
}

grpc::Status ReadBlob(v1::AssetService::Stub& assets, const v1::Digest& digest, std::string* out, int64_t offset,
                      int64_t limit) {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + kWatchTimeout);
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
