#include "tests/support/postgres_instance.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

// A free TCP port on `address` (bound with port 0, then closed).
absl::StatusOr<int> FreePort(const std::string& address) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return absl::InternalError("socket() failed");
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = 0;
  if (inet_pton(AF_INET, address.c_str(), &a.sin_addr) != 1) {
    close(fd);
    return absl::InvalidArgumentError(absl::StrCat("tcp_address: \"", address, "\" is not an IPv4 address"));
  }
  socklen_t len = sizeof(a);
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
    close(fd);
    return absl::InternalError(absl::StrCat("cannot bind a port on ", address));
  }
  const int port = ntohs(a.sin_port);
  close(fd);
  return port;
}

}  // namespace

absl::StatusOr<std::string> PostgresInstance::Run(const std::vector<std::string>& argv,
                                                  const std::vector<std::string>& prefix) {
  std::vector<std::string> full = prefix;
  if (as_postgres_user_) full.insert(full.end(), {"runuser", "-u", "postgres", "--"});
  full.insert(full.end(), argv.begin(), argv.end());
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return absl::InternalError("pipe() failed");
  const pid_t pid = fork();
  if (pid < 0) return absl::InternalError("fork() failed");
  if (pid == 0) {
    dup2(pipe_fds[1], 1);
    dup2(pipe_fds[1], 2);
    close(pipe_fds[0]);
    close(pipe_fds[1]);
    // The server must not inherit the caller's working directory rights
    // problems: run from the instance's own directory.
    if (chdir(dir_.c_str()) != 0) _exit(126);
    std::vector<char*> args;
    for (auto& a : full) args.push_back(a.data());
    args.push_back(nullptr);
    execvp(args[0], args.data());
    _exit(127);
  }
  close(pipe_fds[1]);
  std::string output;
  char buf[4096];
  ssize_t n;
  while ((n = read(pipe_fds[0], buf, sizeof(buf))) > 0) output.append(buf, static_cast<size_t>(n));
  close(pipe_fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    return absl::InternalError(absl::StrCat(absl::StrJoin(argv, " "), " failed (status ", status, "): ", output));
  }
  return output;
}

absl::StatusOr<std::unique_ptr<PostgresInstance>> PostgresInstance::Start(const Options& options) {
  std::unique_ptr<PostgresInstance> pg(new PostgresInstance());
  pg->options_ = options;
  const char* env_bin = std::getenv("IMPOSTOR_PG_BIN");
  pg->bin_dir_ = env_bin != nullptr ? fs::path(env_bin) : fs::path("/usr/lib/postgresql/15/bin");
  if (!fs::exists(pg->bin_dir_ / "initdb") || !fs::exists(pg->bin_dir_ / "pg_ctl")) {
    return absl::FailedPreconditionError(absl::StrCat("no initdb/pg_ctl in ", pg->bin_dir_.string(),
                                                      " (install postgresql-15 or set IMPOSTOR_PG_BIN)"));
  }
  std::string tmpl = (fs::temp_directory_path() / "impostor-pg-XXXXXX").string();
  if (mkdtemp(tmpl.data()) == nullptr) return absl::InternalError("mkdtemp failed");
  pg->dir_ = tmpl;
  if (geteuid() == 0) {
    const passwd* pw = getpwnam("postgres");
    if (pw == nullptr) return absl::FailedPreconditionError("running as root but there is no `postgres` user");
    if (chown(pg->dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0) return absl::InternalError("chown of the test dir failed");
    pg->as_postgres_user_ = true;
  }
  if (!options.start_prefix.empty() && options.port <= 0) {
    return absl::InvalidArgumentError("start_prefix: needs an explicit port (cannot probe one from here)");
  }
  if (!options.tcp_address.empty()) {
    if (options.port > 0) {
      pg->port_ = options.port;
    } else {
      auto port = FreePort(options.tcp_address);
      if (!port.ok()) return port.status();
      pg->port_ = *port;
    }
  }
  std::vector<std::string> initdb = {(pg->bin_dir_ / "initdb").string(), "-D", (pg->dir_ / "data").string(),
                                     "-U", "postgres", "-E", "UTF8", "--no-sync", "--auth-local=trust"};
  if (!options.password.empty()) {
    const fs::path pwfile = pg->dir_ / "pwfile";
    std::ofstream(pwfile) << options.password << "\n";
    if (pg->as_postgres_user_) {
      const passwd* pw = getpwnam("postgres");
      if (chown(pwfile.c_str(), pw->pw_uid, pw->pw_gid) != 0) return absl::InternalError("chown pwfile failed");
    }
    initdb.insert(initdb.end(), {"--auth-host=scram-sha-256", "--pwfile", pwfile.string()});
  } else {
    initdb.push_back("--auth-host=trust");
  }
  if (auto out = pg->Run(initdb); !out.ok()) return out.status();
  if (!options.tcp_address.empty()) {
    // Accept TCP clients from anywhere (the test's own network namespaces).
    std::ofstream(pg->dir_ / "data" / "pg_hba.conf", std::ios::app)
        << "host all all 0.0.0.0/0 " << (options.password.empty() ? "trust" : "scram-sha-256") << "\n";
  }
  if (auto s = pg->StartAgain(); !s.ok()) return s;
  return pg;
}

absl::Status PostgresInstance::StartAgain() {
  const std::string listen = options_.tcp_address.empty() ? "''" : options_.tcp_address;
  auto out = Run({(bin_dir_ / "pg_ctl").string(), "-D", (dir_ / "data").string(), "-l", (dir_ / "server.log").string(),
                  "-w", "-t", "60", "-o",
                  absl::StrCat("-c listen_addresses=", listen, " -k ", dir_.string(), " -p ", port_,
                               options_.fsync ? "" : " -c fsync=off", " -c max_connections=200"),
                  "start"},
                 options_.start_prefix);
  if (!out.ok()) {
    std::ifstream log(dir_ / "server.log");
    std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    return absl::InternalError(absl::StrCat(out.status().message(), "\nserver.log:\n", text));
  }
  running_ = true;
  return absl::OkStatus();
}

absl::Status PostgresInstance::Stop() {
  if (!running_) return absl::OkStatus();
  auto out = Run({(bin_dir_ / "pg_ctl").string(), "-D", (dir_ / "data").string(), "-w", "-m", "fast", "stop"});
  if (!out.ok()) return out.status();
  running_ = false;
  return absl::OkStatus();
}

absl::Status PostgresInstance::Restart() {
  if (auto s = Stop(); !s.ok()) return s;
  return StartAgain();
}

PostgresInstance::~PostgresInstance() {
  if (running_) {
    (void)Run({(bin_dir_ / "pg_ctl").string(), "-D", (dir_ / "data").string(), "-w", "-m", "immediate", "stop"});
  }
  std::error_code ec;
  if (!dir_.empty()) fs::remove_all(dir_, ec);
}

std::string PostgresInstance::Url(const std::string& database, bool tcp) const {
  if (tcp && !options_.tcp_address.empty()) {
    const std::string auth = options_.password.empty() ? "postgres" : absl::StrCat("postgres:", options_.password);
    return absl::StrCat("postgresql://", auth, "@", options_.tcp_address, ":", port_, "/", database);
  }
  return absl::StrCat("postgresql://postgres@/", database, "?host=", dir_.string(), "&port=", port_);
}

absl::StatusOr<std::string> PostgresInstance::Query(const std::string& database, const std::string& sql) {
  return Run({(bin_dir_ / "psql").string(), "-X", "-q", "-A", "-t", "-v", "ON_ERROR_STOP=1", "-h", dir_.string(),
              "-p", std::to_string(port_), "-U", "postgres", "-d", database, "-c", sql});
}

absl::Status PostgresInstance::CreateDatabase(const std::string& name) {
  for (char c : name) {
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) {
      return absl::InvalidArgumentError(absl::StrCat("database name \"", name, "\": use [a-z0-9_]"));
    }
  }
  return Query("postgres", absl::StrCat("CREATE DATABASE ", name)).status();
}

}  // namespace impostor::testing
