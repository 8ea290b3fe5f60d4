// A deadline for the SDK's WatchJob in tests. The SDK's WatchJob has none by
// design (a bake may take long; it resumes across outages), so a test that
// calls it on a stuck job would hang until ctest's timeout. This runs it on
// a thread and, past the deadline, fails the test naming the job and calls
// `unblock` (typically: kill the server, after which the SDK gives up within
// its outage budget), then joins.
#ifndef IMPOSTOR_TESTS_INTEGRATION_SDK_WATCH_H_
#define IMPOSTOR_TESTS_INTEGRATION_SDK_WATCH_H_

#include <chrono>
#include <functional>
#include <future>
#include <string>

#include <gtest/gtest.h>

#include "impostor/client.h"
#include "tests/support/server_process.h"

namespace impostor::testing {

inline absl::StatusOr<sdk::JobUpdate> WatchJobWithin(
    sdk::Client& client, const std::string& job_id, const std::function<void()>& unblock,
    std::chrono::milliseconds timeout = kWatchTimeout,
    const std::function<void(const sdk::JobUpdate&)>& on_update = [](const sdk::JobUpdate&) {}) {
  auto done = std::async(std::launch::async, [&] { return client.WatchJob(job_id, on_update); });
  if (done.wait_for(timeout) != std::future_status::ready) {
    ADD_FAILURE() << "sdk::Client::WatchJob(" << job_id << ") did not return within "
                  << std::chrono::duration<double>(timeout).count() << " s; unblocking it";
    if (unblock) unblock();
  }
  return done.get();
}

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_INTEGRATION_SDK_WATCH_H_
