#include "worker/output/run_tool.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"

extern char** environ;

namespace impostor {
namespace {

std::string LastLine(const std::string& text) {
  absl::string_view t = absl::StripTrailingAsciiWhitespace(text);
  const size_t nl = t.rfind('\n');
  return std::string(nl == absl::string_view::npos ? t : t.substr(nl + 1));
}

// Waits for `pid` to end, or kills it once *cancelled: true if it was
// cancelled. A pidfd wakes the wait the moment the tool exits; the 100 ms
// timeout is only how often the flag is looked at.
bool WaitOrCancel(pid_t pid, const std::atomic<bool>* cancelled, int* status) {
  // Through syscall(): glibc 2.36's <sys/pidfd.h> declares pidfd_open
  // without C linkage for C++.
  const int pidfd = cancelled != nullptr ? static_cast<int>(::syscall(SYS_pidfd_open, pid, 0)) : -1;
  bool killed = false;
  if (pidfd >= 0) {
    pollfd p{pidfd, POLLIN, 0};
    while (!killed) {
      if (cancelled->load()) {
        kill(pid, SIGKILL);
        killed = true;
        break;
      }
      const int ready = poll(&p, 1, 100);
      if (ready > 0) break;
    }
    close(pidfd);
  } else if (cancelled != nullptr) {
    // No pidfd (a kernel before 5.3): look at the tool and the flag in turn.
    while (waitpid(pid, status, WNOHANG) == 0) {
      if (!killed && cancelled->load()) {
        kill(pid, SIGKILL);
        killed = true;
      }
      poll(nullptr, 0, 100);
    }
    return killed;
  }
  while (waitpid(pid, status, 0) < 0 && errno == EINTR) {
  }
  return killed;
}

}  // namespace

absl::StatusOr<std::string> RunTool(const std::vector<std::string>& argv, const std::filesystem::path& log,
                                    const std::atomic<bool>* cancelled) {
  if (argv.empty()) return absl::InvalidArgumentError("RunTool: no program");
  if (access(argv[0].c_str(), X_OK) != 0) {
    return absl::NotFoundError(absl::StrCat("'", argv[0], "' is not an executable file (", std::strerror(errno), ")"));
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return absl::InternalError(absl::StrCat("cannot start '", argv[0], "': ", std::strerror(rc)));
  int status = 0;
  if (WaitOrCancel(pid, cancelled, &status)) {
    return absl::CancelledError(absl::StrCat("'", argv[0], "' stopped: the job was cancelled"));
  }
  std::ifstream in(log, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return text.str();
  const std::string how = WIFEXITED(status) ? absl::StrCat("exit status ", WEXITSTATUS(status))
                                            : absl::StrCat("signal ", WTERMSIG(status));
  return absl::InternalError(absl::StrCat("'", argv[0], "' failed (", how, "): ", LastLine(text.str())));
}

}  // namespace impostor
