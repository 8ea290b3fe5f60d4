// Test hosts made of Linux network namespaces (issue 15): a private network
// for one test, so that servers, workers and clients talk over real
// interfaces, with their own addresses, and a test can cut one host's link.
//
// Layout: a "switch" namespace holds a bridge; each host is a namespace
// whose eth0 is a veth pair into that bridge, with an address of the
// network's /24. Nothing is added to the namespace the test runs in: the
// addresses are reachable only from the hosts, so they cannot collide with
// the machine's networks or with another test run's (each run's
// namespaces are named after its pid and a counter).
//
// Processes run on a host through Exec(), which prefixes a command with
// `ip netns exec NS`; the namespace's files are shared with the test.
//
// Names: SetHostNames() gives a host its own /etc/hosts (`ip netns exec`
// bind-mounts /etc/netns/NS/hosts over it), so a test can make a DNS name
// with a record per replica without a DNS server.
//
// Teardown: the destructor deletes every namespace it made (their veths go
// with them, and their /etc/netns folders), also when the test failed;
// Create() first deletes namespaces left behind by test processes that no
// longer exist (a crash, SIGKILL).
// Processes started on a host must be gone before the network is destroyed:
// declare the TestNetwork before them.
//
// Needs root (CAP_NET_ADMIN and CAP_SYS_ADMIN) and iproute2's `ip netns`;
// Unavailable() says why not, for GTEST_SKIP. One thread at a time.
#ifndef IMPOSTOR_TESTS_SUPPORT_NETNS_H_
#define IMPOSTOR_TESTS_SUPPORT_NETNS_H_

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

namespace impostor::testing {

class TestNetwork {
 public:
  struct Host {
    std::string name;       // the test's name for it, e.g. "server1"
    std::string netns;      // the namespace's name
    std::string address;    // its IPv4 address on the test network
    std::string switch_if;  // its veth's end in the switch namespace
  };

  // "" when this process can build test networks; else why not (not root,
  // no `ip netns`), as a sentence for GTEST_SKIP.
  static std::string Unavailable();

  // A network 10.<a>.<b>.0/24 (a, b from the pid) with no hosts yet.
  // Fails with the `ip` command's output when a step fails.
  static absl::StatusOr<std::unique_ptr<TestNetwork>> Create();
  ~TestNetwork();
  TestNetwork(const TestNetwork&) = delete;
  TestNetwork& operator=(const TestNetwork&) = delete;

  // Adds a host named `name` (letters, digits, '-'; at most 200 hosts) and
  // returns it, its link up.
  absl::StatusOr<Host> AddHost(const std::string& name);

  // `argv` to be run on `host`: {"ip", "netns", "exec", NS, argv...}, with
  // "ip" as its absolute path (ChildProcess does no PATH lookup).
  std::vector<std::string> Exec(const Host& host, const std::vector<std::string>& argv) const;

  // Takes `host`'s link down (its packets go nowhere; its peers see no
  // reset, as with a pulled cable) or up again.
  absl::Status SetLink(const Host& host, bool up);

  // The /etc/hosts of processes started on `host` from now on: localhost,
  // then each {address, name} of `entries` on a line of its own. Several
  // addresses for one name make a name with several records, which both
  // glibc (host.conf "multi on") and gRPC's c-ares resolver return in order.
  absl::Status SetHostNames(const Host& host, const std::vector<std::pair<std::string, std::string>>& entries);

 private:
  TestNetwork(std::string prefix, std::string subnet);
  std::string prefix_;  // every namespace name starts with it
  std::string subnet_;  // "10.a.b."
  std::string switch_ns_;
  std::vector<Host> hosts_;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_SUPPORT_NETNS_H_
