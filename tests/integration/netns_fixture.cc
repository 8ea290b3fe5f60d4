#include "tests/integration/netns_fixture.h"

#include <stdexcept>

namespace impostor::testing {

void NetnsTest::SetUp() {
  if (std::string why = TestNetwork::Unavailable(); !why.empty()) GTEST_SKIP() << "network namespaces: " << why;
  auto net = TestNetwork::Create();
  ASSERT_TRUE(net.ok()) << net.status();
  net_ = std::move(*net);
  dir_ = NewTempDir(::testing::UnitTest::GetInstance()->current_test_info()->test_suite_name());
}

TestNetwork::Host NetnsTest::Host(const std::string& name) {
  auto host = net_->AddHost(name);
  if (!host.ok()) throw std::runtime_error("cannot add host " + name + ": " + std::string(host.status().message()));
  return *host;
}

std::unique_ptr<ChildProcess> NetnsTest::StartWorker(const TestNetwork::Host& host, const std::string& servers) {
  ProcessOptions options;
  options.name = "worker-" + host.name;
  return std::make_unique<ChildProcess>(
      net_->Exec(host, {(BinaryDir() / "impostor-worker").string(), "--server=" + servers, "--name=" + host.name,
                        "--token-file=" + (dir_ / "worker.token").string(), "--log-level=info"}),
      options);
}

}  // namespace impostor::testing
