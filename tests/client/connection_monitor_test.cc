// ConnectionMonitor and the backoff: one event per transition however many
// threads notice, outages begin only on UNAVAILABLE, and the delays stay
// within their documented bounds.
#include "client/transport/connection_monitor.h"

#include <atomic>
#include <mutex>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "client/transport/retry.h"

namespace impostor::sdk {
namespace {

struct Recorder {
  std::mutex mu;
  std::vector<ConnectionEvent> events;
  ConnectionMonitor::Callback Callback() {
    return [this](const ConnectionEvent& e) {
      std::lock_guard lock(mu);
      events.push_back(e);
    };
  }
};

TEST(ConnectionMonitor, OneEventPerTransitionAcrossThreads) {
  Recorder recorder;
  ConnectionMonitor monitor("bake:1", 300, recorder.Callback());
  EXPECT_FALSE(monitor.OutageSeconds().has_value());
  monitor.NoteAnswer();  // answering while up reports nothing
  for (int round = 0; round < 3; ++round) {
    std::vector<std::thread> threads;
    for (int i = 0; i < 8; ++i) threads.emplace_back([&] { monitor.NoteFailure(absl::UnavailableError("down")); });
    for (auto& t : threads) t.join();
    EXPECT_TRUE(monitor.OutageSeconds().has_value()) << round;
    threads.clear();
    for (int i = 0; i < 8; ++i) threads.emplace_back([&] { monitor.NoteAnswer(); });
    for (auto& t : threads) t.join();
    EXPECT_FALSE(monitor.OutageSeconds().has_value()) << round;
  }
  std::lock_guard lock(recorder.mu);
  ASSERT_EQ(recorder.events.size(), 6u);
  for (size_t i = 0; i < recorder.events.size(); ++i) {
    const ConnectionEvent& e = recorder.events[i];
    EXPECT_EQ(e.kind, i % 2 == 0 ? ConnectionEvent::Kind::kLost : ConnectionEvent::Kind::kRegained) << i;
    EXPECT_EQ(e.server, "bake:1");
    EXPECT_EQ(e.max_outage_seconds, 300);
    if (e.kind == ConnectionEvent::Kind::kLost) {
      EXPECT_EQ(e.error.message(), "down");
    } else {
      EXPECT_GE(e.outage_seconds, 0);
    }
  }
}

TEST(ConnectionMonitor, OnlyUnavailableBeginsAnOutage) {
  Recorder recorder;
  ConnectionMonitor monitor("bake:1", 300, recorder.Callback());
  for (const absl::Status& s : {absl::DeadlineExceededError("slow"), absl::NotFoundError("no job"),
                                absl::InternalError("oops"), absl::CancelledError("by us")}) {
    monitor.NoteFailure(s);
    EXPECT_FALSE(monitor.OutageSeconds().has_value()) << s;
  }
  std::lock_guard lock(recorder.mu);
  EXPECT_TRUE(recorder.events.empty());
}

TEST(ConnectionMonitor, WorksWithoutACallback) {
  ConnectionMonitor monitor("bake:1", 0, nullptr);
  monitor.NoteFailure(absl::UnavailableError("down"));
  EXPECT_TRUE(monitor.OutageSeconds().has_value());
  monitor.NoteAnswer();
  EXPECT_FALSE(monitor.OutageSeconds().has_value());
}

TEST(BackoffDelay, DoublesFromATenthOfASecondToOneSecondWithJitterTakenOff) {
  struct Case {
    int attempt;
    int64_t max_ms;
  };
  for (const Case& c : {Case{1, 100}, Case{2, 200}, Case{3, 400}, Case{4, 800}, Case{5, 1000}, Case{50, 1000},
                        Case{1 << 30, 1000}}) {
    for (int i = 0; i < 200; ++i) {
      const int64_t ms = BackoffDelay(c.attempt).count();
      ASSERT_LE(ms, c.max_ms) << "attempt " << c.attempt;
      ASSERT_GE(ms, c.max_ms - c.max_ms / 5) << "attempt " << c.attempt;
    }
  }
}

TEST(RetryPolicy, NonRetryableCodesEndTheCallAtOnce) {
  ConnectionMonitor monitor("bake:1", 300, nullptr);
  monitor.NoteFailure(absl::UnavailableError("down"));  // an outage is under way
  ClientOptions options;
  options.max_attempts = 5;
  RetryPolicy retry(options, monitor);
  for (const absl::Status& s : {absl::NotFoundError("x"), absl::InvalidArgumentError("x"), absl::InternalError("x"),
                                absl::DataLossError("x"), absl::ResourceExhaustedError("x")}) {
    EXPECT_FALSE(retry.ShouldRetry(s)) << s;
  }
  EXPECT_EQ(retry.failures(), 0);
}

TEST(RetryPolicy, UnavailableOutsideAnOutageCountsAgainstMaxAttempts) {
  ConnectionMonitor monitor("bake:1", 300, nullptr);  // the server answers
  ClientOptions options;
  options.max_attempts = 2;
  RetryPolicy retry(options, monitor);
  EXPECT_TRUE(retry.ShouldRetry(absl::UnavailableError("stream ended early")));
  EXPECT_FALSE(retry.ShouldRetry(absl::UnavailableError("stream ended early")));
  retry.MadeProgress();
  EXPECT_EQ(retry.failures(), 0);
  EXPECT_TRUE(retry.ShouldRetry(absl::DeadlineExceededError("slow")));
}

// With a Wait (the transport's WaitForServer), the backoff is handed to it,
// never slept here: the wait may end early when the server is back.
TEST(RetryPolicy, TheBackoffIsWaitedOutByTheGivenWait) {
  ConnectionMonitor monitor("bake:1", 300, nullptr);
  monitor.NoteFailure(absl::UnavailableError("down"));
  ClientOptions options;
  options.max_attempts = 2;
  std::vector<double> waited;
  RetryPolicy retry(options, monitor, [&](std::chrono::duration<double> d) { waited.push_back(d.count()); });
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(retry.ShouldRetry(absl::UnavailableError("down"))) << i;
  ASSERT_EQ(waited.size(), 4u);
  for (size_t i = 0; i < waited.size(); ++i) {
    const double expected = BackoffDelay(static_cast<int>(i) + 1).count() / 1000.0;
    EXPECT_LE(waited[i], 0.1 * (1 << i) + 1e-9) << i;
    EXPECT_GE(waited[i], 0.8 * 0.1 * (1 << i) - 1e-9) << i << " " << expected;
  }
  EXPECT_FALSE(retry.ShouldRetry(absl::NotFoundError("x")));
  EXPECT_EQ(waited.size(), 4u) << "an answer is not waited on";
}

}  // namespace
}  // namespace impostor::sdk
