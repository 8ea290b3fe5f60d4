#include "tests/support/netns.h"

#include <signal.h>
#include <sys/types.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

// Every namespace this harness makes is named "impostor-test-<pid>-<n>-...".
constexpr char kPrefix[] = "impostor-test-";

std::string IpPath() {
  for (const char* p : {"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"}) {
    if (fs::exists(p)) return p;
  }
  return "";
}

// Runs `ip ARGS` (arguments made by this file only: names and addresses,
// no shell characters); its output when it fails.
absl::Status Ip(const std::string& args) {
  const std::string command = absl::StrCat(IpPath(), " ", args, " 2>&1");
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return absl::InternalError(absl::StrCat("cannot run ", command));
  std::string output;
  std::array<char, 512> buffer;
  while (size_t n = std::fread(buffer.data(), 1, buffer.size(), pipe)) output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  if (status != 0) return absl::InternalError(absl::StrCat("ip ", args, " failed: ", output));
  return absl::OkStatus();
}

std::vector<std::string> NamespacesStartingWith(const std::string& prefix) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/run/netns", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(prefix, 0) == 0) names.push_back(name);
  }
  return names;
}

// Where `ip netns exec NS` finds the files it bind-mounts over /etc.
fs::path EtcDir(const std::string& netns) { return fs::path("/etc/netns") / netns; }

// A namespace and its /etc/netns folder (if SetHostNames made one).
void DeleteNamespace(const std::string& netns) {
  (void)Ip("netns delete " + netns);
  std::error_code ec;
  fs::remove_all(EtcDir(netns), ec);
}

// Deletes namespaces of test processes that are gone.
void SweepStale() {
  static const std::regex kName(std::string(kPrefix) + "([0-9]+)-.*");
  for (const std::string& name : NamespacesStartingWith(kPrefix)) {
    std::smatch m;
    if (!std::regex_match(name, m, kName)) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(m[1]));
    if (::kill(pid, 0) == 0 || errno == EPERM) continue;  // still alive
    DeleteNamespace(name);
  }
}

}  // namespace

std::string TestNetwork::Unavailable() {
  if (::geteuid() != 0) return "needs root (network namespaces, veth pairs); run as root in CI";
  if (IpPath().empty()) return "needs iproute2's `ip` command";
  const std::string probe = absl::StrCat(kPrefix, ::getpid(), "-probe");
  if (absl::Status s = Ip("netns add " + probe); !s.ok()) {
    return absl::StrCat("`ip netns add` does not work here: ", s.message());
  }
  (void)Ip("netns delete " + probe);
  return "";
}

TestNetwork::TestNetwork(std::string prefix, std::string subnet)
    : prefix_(std::move(prefix)), subnet_(std::move(subnet)), switch_ns_(prefix_ + "switch") {}

absl::StatusOr<std::unique_ptr<TestNetwork>> TestNetwork::Create() {
  SweepStale();
  static std::atomic<int> next{0};
  const int n = next++;
  const int pid = ::getpid();
  // The switch namespace's private /24; any value works (nothing outside
  // the test's namespaces routes to it), the pid only makes logs readable.
  const std::string subnet = absl::StrCat("10.", 100 + (pid % 100), ".", (pid / 100 + n) % 250, ".");
  std::unique_ptr<TestNetwork> net(new TestNetwork(absl::StrCat(kPrefix, pid, "-", n, "-"), subnet));
  if (absl::Status s = Ip("netns add " + net->switch_ns_); !s.ok()) return s;
  for (const std::string& step : {absl::StrCat("-n ", net->switch_ns_, " link add br0 type bridge"),
                                  absl::StrCat("-n ", net->switch_ns_, " link set br0 up"),
                                  absl::StrCat("-n ", net->switch_ns_, " link set lo up")}) {
    if (absl::Status s = Ip(step); !s.ok()) return s;
  }
  return net;
}

TestNetwork::~TestNetwork() {
  for (const Host& host : hosts_) DeleteNamespace(host.netns);
  DeleteNamespace(switch_ns_);
}

absl::StatusOr<TestNetwork::Host> TestNetwork::AddHost(const std::string& name) {
  static const std::regex kHostName("[A-Za-z0-9-]{1,32}");
  if (!std::regex_match(name, kHostName)) {
    return absl::InvalidArgumentError(absl::StrCat("host name \"", name, "\": want 1..32 letters, digits or '-'"));
  }
  if (hosts_.size() >= 200) return absl::ResourceExhaustedError("at most 200 hosts per test network");
  const size_t index = hosts_.size() + 1;
  Host host{.name = name,
            .netns = prefix_ + name,
            .address = absl::StrCat(subnet_, 10 + index),
            .switch_if = absl::StrCat("h", index)};
  if (absl::Status s = Ip("netns add " + host.netns); !s.ok()) return s;
  hosts_.push_back(host);  // deleted by the destructor from here on
  for (const std::string& step :
       {absl::StrCat("-n ", host.netns, " link add eth0 type veth peer name ", host.switch_if, " netns ",
                     switch_ns_),
        absl::StrCat("-n ", switch_ns_, " link set ", host.switch_if, " master br0"),
        absl::StrCat("-n ", switch_ns_, " link set ", host.switch_if, " up"),
        absl::StrCat("-n ", host.netns, " addr add ", host.address, "/24 dev eth0"),
        absl::StrCat("-n ", host.netns, " link set eth0 up"), absl::StrCat("-n ", host.netns, " link set lo up")}) {
    if (absl::Status s = Ip(step); !s.ok()) return s;
  }
  return host;
}

std::vector<std::string> TestNetwork::Exec(const Host& host, const std::vector<std::string>& argv) const {
  std::vector<std::string> out = {IpPath(), "netns", "exec", host.netns};
  out.insert(out.end(), argv.begin(), argv.end());
  return out;
}

absl::Status TestNetwork::SetLink(const Host& host, bool up) {
  return Ip(absl::StrCat("-n ", switch_ns_, " link set ", host.switch_if, up ? " up" : " down"));
}

absl::Status TestNetwork::SetHostNames(const Host& host,
                                       const std::vector<std::pair<std::string, std::string>>& entries) {
  std::error_code ec;
  fs::create_directories(EtcDir(host.netns), ec);
  if (ec) return absl::InternalError(absl::StrCat("cannot create ", EtcDir(host.netns).string(), ": ", ec.message()));
  const fs::path path = EtcDir(host.netns) / "hosts";
  std::ofstream out(path);
  out << "127.0.0.1 localhost\n::1 localhost\n";
  for (const auto& [address, name] : entries) out << address << " " << name << "\n";
  out.close();
  if (!out) return absl::InternalError(absl::StrCat("cannot write ", path.string()));
  return absl::OkStatus();
}

}  // namespace impostor::testing
