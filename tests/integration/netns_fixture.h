// What every test on a network of namespace hosts (tests/support/netns.h)
// starts with: the skip when this process cannot build one (not root, no
// `ip netns`), the network itself, a scratch folder, hosts that fail the
// test when they cannot be added, and workers on a host that log in with
// the test's worker token (`dir_/worker.token`, written by the test).
// netns_test.cc (one server, a link cut) and netns_multihost_test.cc
// (PostgreSQL and two replicas) build on it.
#ifndef IMPOSTOR_TESTS_INTEGRATION_NETNS_FIXTURE_H_
#define IMPOSTOR_TESTS_INTEGRATION_NETNS_FIXTURE_H_

#include <filesystem>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/server_process.h"
#include "tests/support/netns.h"

namespace impostor::testing {

class NetnsTest : public ::testing::Test {
 protected:
  // Every host has its own address, so one port serves them all.
  static constexpr int kPort = 50051;

  // Skips the test (GTEST_SKIP) with the reason when namespaces cannot be
  // made; a subclass's SetUp calls this first and returns if IsSkipped().
  void SetUp() override;

  // A new host on the network; throws (failing the test) when it cannot be added.
  TestNetwork::Host Host(const std::string& name);
  static std::string Address(const TestNetwork::Host& host) { return host.address + ":" + std::to_string(kPort); }

  // impostor-worker on `host` for `servers` (a --server list), with the
  // token in dir_/worker.token.
  std::unique_ptr<ChildProcess> StartWorker(const TestNetwork::Host& host, const std::string& servers);

  std::unique_ptr<TestNetwork> net_;  // declared first: destroyed after the processes
  std::filesystem::path dir_;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_INTEGRATION_NETNS_FIXTURE_H_
