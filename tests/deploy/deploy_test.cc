// deploy/ checked offline (issue 15): the Kubernetes base renders with
// `kubectl kustomize` and holds the expected kinds and probes; the
// Containerfiles copy only files that exist and install the packages CPack
// builds; every flag the compose file, the Kubernetes config and the
// container entrypoint pass is one the binaries know (their --help).
// Images cannot be built here (no container runtime); this is what can be
// checked without one.
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;

const fs::path kSource = IMPOSTOR_SOURCE_DIR;

std::string Read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

int Count(const std::string& text, const std::string& needle) {
  int n = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

std::string Kubectl() {
  for (const char* p : {"/usr/bin/kubectl", "/usr/local/bin/kubectl"}) {
    if (fs::exists(p)) return p;
  }
  return "";
}

TEST(Deploy, KustomizeRendersReplicasWorkersSecretAndProbes) {
  const std::string kubectl = Kubectl();
  if (kubectl.empty()) GTEST_SKIP() << "kubectl is not installed (deploy/install-deps.sh installs it)";
  const testing::ToolRun run = testing::RunTool({kubectl, "kustomize", (kSource / "deploy/k8s").string()});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string& y = run.out;
  EXPECT_EQ(Count(y, "\nkind: Deployment\n"), 2) << y;
  EXPECT_EQ(Count(y, "\nkind: Service\n"), 2) << y;  // the replicas' Service and the headless one
  EXPECT_EQ(Count(y, "\nkind: Secret\n"), 1) << y;
  EXPECT_EQ(Count(y, "\nkind: ConfigMap\n"), 1) << y;
  EXPECT_EQ(Count(y, "\nkind: PersistentVolumeClaim\n"), 1) << y;
  EXPECT_NE(y.find("name: impostor-server\n"), std::string::npos);
  EXPECT_NE(y.find("name: impostor-worker\n"), std::string::npos);
  EXPECT_NE(y.find("replicas: 2"), std::string::npos) << "two server replicas";
  // kustomize sorts keys: the probe's httpGet follows failureThreshold.
  const size_t probe = y.find("readinessProbe:");
  ASSERT_NE(probe, std::string::npos) << y;
  EXPECT_EQ(y.find("path: /readyz", probe), y.find("path: ", probe)) << "the readiness probe asks /readyz: " << y;
  // /readyz may take BakeScheduler::kReadyProbeTimeoutMs (2 s) to say the
  // database is down; Kubernetes' default 1 s would call that a failure.
  const size_t timeout = y.find("timeoutSeconds: ", probe);
  ASSERT_NE(timeout, std::string::npos) << y;
  EXPECT_GE(std::atoi(y.c_str() + timeout + 16), 3) << y;
  EXPECT_NE(y.find("path: /healthz"), std::string::npos) << y;
  EXPECT_NE(y.find("clusterIP: None"), std::string::npos) << "headless Service for the workers";
  EXPECT_NE(y.find("mountPath: /etc/impostor/server.conf"), std::string::npos);
  EXPECT_NE(y.find("mountPath: /etc/impostor/worker.conf"), std::string::npos);
  EXPECT_NE(y.find("worker.token"), std::string::npos);
}

TEST(Deploy, ContainerfilesCopyExistingFilesAndInstallThePackagesCPackBuilds) {
  const std::string packaging = Read(kSource / "cmake/ImpostorPackage.cmake");
  const std::regex copy(R"(^COPY\s+(\S+)\s+(\S+)\s*$)");
  const std::regex deb(R"(/tmp/debs/([a-z0-9-]+)_\*\.deb)");
  for (const char* name : {"Containerfile.server", "Containerfile.worker"}) {
    const std::string text = Read(kSource / "deploy/container" / name);
    ASSERT_FALSE(text.empty()) << name;
    EXPECT_NE(text.find("FROM debian:12"), std::string::npos) << name << ": Debian 12 base";
    int copies = 0;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
      std::smatch m;
      if (!std::regex_match(line, m, copy)) continue;
      ++copies;
      EXPECT_TRUE(fs::exists(kSource / m[1].str())) << name << ": COPY source " << m[1] << " does not exist";
    }
    EXPECT_EQ(copies, 2) << name;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(text, m, deb)) << name << " installs no /tmp/debs/NAME_*.deb";
    EXPECT_NE(packaging.find("PACKAGE_NAME " + m[1].str() + ")"), std::string::npos)
        << name << " installs " << m[1] << ", which CPack does not build";
    EXPECT_NE(text.find("ENTRYPOINT [\"/usr/local/bin/impostor-entrypoint\""), std::string::npos) << name;
  }
  const fs::perms perms = fs::status(kSource / "deploy/container/entrypoint.sh").permissions();
  EXPECT_NE(perms & fs::perms::owner_exec, fs::perms::none) << "entrypoint.sh is not executable";
}

// Every --flag in `text` (flag names only, up to '=' or a space).
std::set<std::string> FlagsIn(const std::string& text) {
  std::set<std::string> flags;
  const std::regex flag(R"((^|[\s"'=])(--[a-z][a-z0-9-]+))");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), flag); it != std::sregex_iterator(); ++it) {
    flags.insert((*it)[2].str());
  }
  return flags;
}

TEST(Deploy, EveryFlagPassedIsOneTheBinariesKnow) {
  std::set<std::string> known;
  for (const std::vector<std::string>& argv :
       {std::vector<std::string>{(testing::BinaryDir() / "impostor-server").string(), "--help"},
        std::vector<std::string>{(testing::BinaryDir() / "impostor-worker").string(), "--help"},
        std::vector<std::string>{(testing::BinaryDir() / "impostor-server").string(), "token", "--help"}}) {
    const testing::ToolRun run = testing::RunTool(argv, std::chrono::seconds(60));
    std::set<std::string> flags = FlagsIn(run.out + run.err);
    known.insert(flags.begin(), flags.end());
  }
  ASSERT_TRUE(known.contains("--listen")) << "could not read impostor-server --help";
  ASSERT_TRUE(known.contains("--drain-seconds")) << "could not read impostor-worker --help";
  for (const char* file : {"deploy/compose/compose.yaml", "deploy/k8s/server.conf", "deploy/k8s/worker.conf",
                           "deploy/k8s/secret.yaml", "deploy/container/entrypoint.sh"}) {
    const std::string text = Read(kSource / file);
    ASSERT_FALSE(text.empty()) << file;
    for (const std::string& flag : FlagsIn(text)) {
      EXPECT_TRUE(known.contains(flag)) << file << " passes " << flag << ", which no binary's --help lists";
    }
  }
}

// The entrypoint itself, run as a container would run it (with this build's
// binary for /usr/bin/impostor-server and no /etc/impostor/server.conf):
// with a database URL, as compose and the Kubernetes ConfigMap configure the
// replicas, the server must get as far as the database, not stop at a flag
// the script left out.
TEST(Deploy, TheServerEntrypointPassesEveryRequiredFlagForReplicasAndForOneMachine) {
  const fs::path work = testing::NewTempDir("entrypoint");
  std::string script = Read(kSource / "deploy/container/entrypoint.sh");
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"/usr/bin/impostor-server",
                                                                     (testing::BinaryDir() / "impostor-server").string()},
                                 {"/etc/impostor/server.conf", (work / "absent.conf").string()}}) {
    for (size_t at = script.find(from); at != std::string::npos; at = script.find(from, at + to.size())) {
      script.replace(at, from.size(), to);
    }
  }
  std::ofstream(work / "entrypoint.sh") << script;
  const std::string data = "IMPOSTOR_DATA=" + (work / "data").string();
  // Replicas: port 1 on loopback refuses at once, so the server stops at the
  // database with its own message.
  const testing::ToolRun replica =
      testing::RunTool({"/usr/bin/env", data, "IMPOSTOR_DATABASE=postgresql://farm@127.0.0.1:1/farm",
                        "IMPOSTOR_BLOB_DIR=" + (work / "blobs").string(), "IMPOSTOR_LISTEN=127.0.0.1:0", "/bin/sh",
                        (work / "entrypoint.sh").string(), "server"},
                       std::chrono::seconds(60));
  EXPECT_EQ(replica.exit_code, 2) << replica.err;
  EXPECT_EQ(replica.err.find("--data: required"), std::string::npos) << replica.err;
  EXPECT_NE(replica.err.find("--database"), std::string::npos) << "stopped before the database: " << replica.err;
  // One machine: a bad flag added through IMPOSTOR_SERVER_FLAGS is the only
  // thing wrong (the server would otherwise run).
  const testing::ToolRun single =
      testing::RunTool({"/usr/bin/env", data, "IMPOSTOR_LISTEN=127.0.0.1:0", "IMPOSTOR_SERVER_FLAGS=--max-attempts=0",
                        "/bin/sh", (work / "entrypoint.sh").string(), "server"},
                       std::chrono::seconds(60));
  EXPECT_EQ(single.exit_code, 2) << single.err;
  EXPECT_NE(single.err.find("--max-attempts: must be in 1..100"), std::string::npos) << single.err;
}

}  // namespace
}  // namespace impostor
