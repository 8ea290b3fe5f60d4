// Downloads over links that are slow, stall, break or are given up by the
// caller: Transport::ReadBlob and ResumeBlobDownload against an in-process
// AssetService whose streams can be paced, stalled and cut on demand.
//
// Time enters these tests only where it is the subject (a stall is "no byte
// for rpc_timeout_seconds"): the fake paces its messages well inside that
// time, and every wait for an event is a condition, never a sleep.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "absl/status/status.h"
#include "client/transfer/blob_download.h"
#include "client/transport/retry.h"
#include "client/transport/rpc_error.h"
#include "client/transport/transport.h"
#include "common/util/sha256.h"
#include "impostor/client.h"
#include "impostor/v1/asset_service.grpc.pb.h"

namespace impostor::sdk {
namespace {

using Clock = std::chrono::steady_clock;

v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest d;
  d.set_hash(Sha256Hex(bytes));
  d.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return d;
}

std::string Pattern(size_t size) {
  std::string s(size, '\0');
  for (size_t i = 0; i < size; ++i) s[i] = static_cast<char>((i * 31) ^ (i >> 8));
  return s;
}

// Serves one blob in `chunk`-byte messages. Knobs and observations are
// guarded by mu; `changed` is notified on every ReadBlob call.
class StreamingServer final : public v1::AssetService::Service {
 public:
  std::mutex mu;
  std::condition_variable changed;
  std::string blob;
  size_t chunk = 1000;
  std::chrono::milliseconds pace{0};  // before every message but the first of a call
  int stall_after = -1;               // next call: after this many messages, send nothing until Release
  int cut_after = -1;                 // next call: after this many messages, end UNAVAILABLE as a cut link does
  bool cut_every_call = false;        // cut_after applies to every call, not only the next
  int refuse = 0;                     // the next N calls (ReadBlob, GetResult) are refused UNAVAILABLE
  bool refuse_all = false;
  bool released = false;
  std::vector<int64_t> offsets;  // every ReadBlob's offset, in order
  int get_result_calls = 0;

  grpc::Status ReadBlob(grpc::ServerContext*, const v1::ReadBlobRequest* request,
                        grpc::ServerWriter<v1::ReadBlobResponse>* writer) override {
    std::string bytes;
    size_t chunk_size;
    std::chrono::milliseconds gap;
    int stall, cut;
    {
      std::lock_guard lock(mu);
      offsets.push_back(request->offset());
      changed.notify_all();
      if (refuse_all || refuse > 0) {
        if (refuse > 0) --refuse;
        return {grpc::StatusCode::UNAVAILABLE, "server down (test)"};
      }
      bytes = blob;
      chunk_size = chunk;
      gap = pace;
      stall = std::exchange(stall_after, -1);
      cut = cut_every_call ? cut_after : std::exchange(cut_after, -1);
    }
    int sent = 0;
    for (size_t off = static_cast<size_t>(request->offset()); off < bytes.size(); off += chunk_size) {
      if (sent == stall) {
        std::unique_lock lock(mu);
        changed.wait(lock, [&] { return released; });
        return grpc::Status::CANCELLED;
      }
      if (sent == cut) return {grpc::StatusCode::UNAVAILABLE, "Socket closed (test)"};
      if (sent > 0 && gap.count() > 0) std::this_thread::sleep_for(gap);  // a slow link's pace
      v1::ReadBlobResponse message;
      message.set_offset(static_cast<int64_t>(off));
      message.set_data(bytes.substr(off, chunk_size));
      if (!writer->Write(message)) return grpc::Status::CANCELLED;
      ++sent;
    }
    return grpc::Status::OK;
  }

  grpc::Status GetResult(grpc::ServerContext*, const v1::GetResultRequest*, v1::Manifest*) override {
    std::lock_guard lock(mu);
    ++get_result_calls;
    changed.notify_all();
    if (refuse_all || refuse > 0) {
      if (refuse > 0) --refuse;
      return {grpc::StatusCode::UNAVAILABLE, "server down (test)"};
    }
    return {grpc::StatusCode::NOT_FOUND, "nothing baked under that key"};
  }

  // Lets every stalled stream end.
  void Release() {
    std::lock_guard lock(mu);
    released = true;
    changed.notify_all();
  }

  // Waits until `done()` holds (checked under mu at every call).
  template <typename Done>
  bool WaitUntil(Done done, std::chrono::seconds timeout = std::chrono::seconds(30)) {
    std::unique_lock lock(mu);
    return changed.wait_for(lock, timeout, [&] { return done(); });
  }
};

struct EventLog {
  std::mutex mu;
  std::vector<ConnectionEvent> events;
  std::function<void(const ConnectionEvent&)> Callback() {
    return [this](const ConnectionEvent& e) {
      std::lock_guard lock(mu);
      events.push_back(e);
    };
  }
  int Count(ConnectionEvent::Kind kind) {
    std::lock_guard lock(mu);
    return static_cast<int>(std::count_if(events.begin(), events.end(), [&](const auto& e) { return e.kind == kind; }));
  }
};

class BlobDownloadTest : public testing::Test {
 protected:
  void SetUp() override { StartServer(0); }

  void StartServer(int port) {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:" + std::to_string(port), grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(&fake_);
    server_ = builder.BuildAndStart();
    ASSERT_NE(server_, nullptr);
  }

  void TearDown() override {
    fake_.Release();
    if (server_ != nullptr) server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  }

  // A transport to the fake; `options` has everything but the server.
  std::unique_ptr<Transport> Connect(ClientOptions options, const TransportHooks& hooks = {}) {
    options.server = "127.0.0.1:" + std::to_string(port_);
    options.connect_timeout_seconds = 10;
    auto transport = Transport::Connect(options, hooks);
    EXPECT_TRUE(transport.ok()) << transport.status();
    return transport.ok() ? std::move(*transport) : nullptr;
  }

  void SetBlob(std::string bytes, size_t chunk) {
    std::lock_guard lock(fake_.mu);
    fake_.blob = std::move(bytes);
    fake_.chunk = chunk;
  }

  std::vector<int64_t> Offsets() {
    std::lock_guard lock(fake_.mu);
    return fake_.offsets;
  }

  StreamingServer fake_;
  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

// Defect A: the stream's deadline was rpc_timeout + size / 256 KiB/s, so a
// link slower than that was cut off however steadily bytes came in (and
// resumed, only to be cut off again). A stream that keeps moving is never
// cut: one ReadBlob, however long it takes.
TEST_F(BlobDownloadTest, ASlowButSteadyStreamIsNeverCutShort) {
  const std::string blob = Pattern(30 * 2048);
  SetBlob(blob, 2048);
  {
    std::lock_guard lock(fake_.mu);
    fake_.pace = std::chrono::milliseconds(100);  // ~3 s in all, a message every 0.1 s
  }
  ClientOptions options;
  options.rpc_timeout_seconds = 1.5;  // the old deadline: 1.5 s + 60 KiB / 256 KiB/s = 1.73 s
  options.max_attempts = 1;
  options.max_outage_seconds = 0;
  auto transport = Connect(options);
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<std::string> got = DownloadBlobToString(*transport, DigestOf(blob));
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, blob);
  EXPECT_EQ(Offsets(), std::vector<int64_t>{0}) << "one stream from start to end";
}

// A stream that stops bringing bytes is given up after rpc_timeout_seconds
// without a message, and the download resumes at the last byte received.
TEST_F(BlobDownloadTest, AStalledStreamIsCutAndResumedAtTheLastByteReceived) {
  const std::string blob = Pattern(8000);
  SetBlob(blob, 1000);
  {
    std::lock_guard lock(fake_.mu);
    fake_.stall_after = 3;
  }
  ClientOptions options;
  options.rpc_timeout_seconds = 1;
  options.max_attempts = 2;
  options.max_outage_seconds = 0;
  auto transport = Connect(options);
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<std::string> got = DownloadBlobToString(*transport, DigestOf(blob));
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, blob);
  EXPECT_EQ(Offsets(), (std::vector<int64_t>{0, 3000}));
}

// A stall is the link's fault as far as anyone can tell: the error says the
// link stalled (DEADLINE_EXCEEDED, naming ReadBlob and the server), and the
// connection callback hears of no lost server (the tester's log said "lost
// server ... answers again after 88.9 s" about a slow link).
TEST_F(BlobDownloadTest, AStallIsReportedAsAStalledLinkNotALostServer) {
  const std::string blob = Pattern(8000);
  SetBlob(blob, 1000);
  {
    std::lock_guard lock(fake_.mu);
    fake_.stall_after = 2;
  }
  EventLog log;
  ClientOptions options;
  options.rpc_timeout_seconds = 1;
  options.max_attempts = 1;
  options.max_outage_seconds = 60;  // only an outage, wrongly seen, would retry
  options.on_connection_change = log.Callback();
  auto transport = Connect(options);
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<std::string> got = DownloadBlobToString(*transport, DigestOf(blob));
  ASSERT_EQ(got.status().code(), absl::StatusCode::kDeadlineExceeded) << got.status();
  EXPECT_NE(got.status().message().find("stalled"), std::string::npos) << got.status();
  std::optional<RpcErrorInfo> info = GetRpcErrorInfo(got.status());
  ASSERT_TRUE(info.has_value()) << got.status();
  EXPECT_EQ(info->rpc, "ReadBlob");
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kLost), 0);
  EXPECT_EQ(Offsets(), std::vector<int64_t>{0});
}

// A link cut while bytes were arriving (the proxy's "Socket closed" every
// ~17 s at 8 KB/s) is resumed at the last byte received; the server answered
// on that very stream, so it is not reported lost.
TEST_F(BlobDownloadTest, ACutAfterBytesArrivedResumesWithoutReportingTheServerLost) {
  const std::string blob = Pattern(8000);
  SetBlob(blob, 1000);
  {
    std::lock_guard lock(fake_.mu);
    fake_.cut_after = 2;
  }
  EventLog log;
  ClientOptions options;
  options.max_attempts = 2;
  options.max_outage_seconds = 60;
  options.on_connection_change = log.Callback();
  auto transport = Connect(options);
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<std::string> got = DownloadBlobToString(*transport, DigestOf(blob));
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, blob);
  EXPECT_EQ(Offsets(), (std::vector<int64_t>{0, 2000}));
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kLost), 0);
  EXPECT_EQ(log.Count(ConnectionEvent::Kind::kRegained), 0);
}

// Progress is progress: a link cut on every stream, each time after some
// bytes, still completes, however many cuts that takes (max_attempts counts
// tries in a row without bytes).
TEST_F(BlobDownloadTest, ALinkCutOnEveryStreamStillCompletesWhileBytesArrive) {
  const std::string blob = Pattern(10 * 1000);
  SetBlob(blob, 1000);
  {
    std::lock_guard lock(fake_.mu);
    fake_.cut_after = 1;
    fake_.cut_every_call = true;
  }
  ClientOptions options;
  options.max_attempts = 2;
  options.max_outage_seconds = 0;
  auto transport = Connect(options);
  ASSERT_NE(transport, nullptr);
  absl::StatusOr<std::string> got = DownloadBlobToString(*transport, DigestOf(blob));
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_EQ(*got, blob);
  EXPECT_EQ(Offsets(), (std::vector<int64_t>{0, 1000, 2000, 3000, 4000, 5000, 6000, 7000, 8000, 9000}));
}

// Defect B: closing a cache during an outage waited out the rest of
// max_outage_seconds (29 s) and answered UNAVAILABLE: nothing but arriving
// bytes looked at the cancel flag. A CancelSource ends the backoff wait at
// once and the download answers its CANCELLED.
TEST_F(BlobDownloadTest, CancelEndsTheRetriesOfARefusingServerPromptly) {
  const std::string blob = Pattern(8000);
  SetBlob(blob, 1000);
  {
    std::lock_guard lock(fake_.mu);
    fake_.refuse_all = true;
  }
  ClientOptions options;
  options.max_attempts = 2;
  options.max_outage_seconds = 600;  // the outage budget alone would retry for 10 min
  auto transport = Connect(options);
  ASSERT_NE(transport, nullptr);
  CancelSource cancel("the cache is shutting down");
  absl::Status result;
  Clock::time_point ended;
  std::thread downloader([&] {
    result = DownloadBlob(
        *transport, DigestOf(blob), [](std::string_view) { return absl::OkStatus(); }, &cancel);
    ended = Clock::now();
  });
  // Well into the outage: refused three times, backing off between tries.
  EXPECT_TRUE(fake_.WaitUntil([&] { return fake_.offsets.size() >= 3; }));
  const Clock::time_point cancelled_at = Clock::now();
  cancel.Cancel();
  downloader.join();
  EXPECT_EQ(result.code(), absl::StatusCode::kCancelled) << result;
  EXPECT_EQ(result.message(), "the cache is shutting down");
  EXPECT_LT(ended - cancelled_at, std::chrono::seconds(5)) << "prompt, not at the end of the outage budget";
}

// The same with the server really gone: the backoff then waits on the
// channel's reconnection (Transport::WaitForServer), which Cancel ends too.
TEST_F(BlobDownloadTest, CancelEndsTheWaitForAServerThatIsDown) {
  const std::string blob = Pattern(8000);
  SetBlob(blob, 1000);
  std::mutex mu;
  std::condition_variable rpc_started;
  int read_blobs = 0;
  TransportHooks hooks;
  hooks.on_rpc = [&](const std::string& method) {
    if (method != "/impostor.v1.AssetService/ReadBlob") return;
    std::lock_guard lock(mu);
    ++read_blobs;
    rpc_started.notify_all();
  };
  ClientOptions options;
  options.max_attempts = 2;
  options.max_outage_seconds = 600;
  auto transport = Connect(options, hooks);
  ASSERT_NE(transport, nullptr);
  server_->Shutdown();
  server_.reset();
  CancelSource cancel;
  absl::Status result;
  Clock::time_point ended;
  std::thread downloader([&] {
    result = DownloadBlob(
        *transport, DigestOf(blob), [](std::string_view) { return absl::OkStatus(); }, &cancel);
    ended = Clock::now();
  });
  {
    std::unique_lock lock(mu);
    EXPECT_TRUE(rpc_started.wait_for(lock, std::chrono::seconds(30), [&] { return read_blobs >= 3; }));
  }
  const Clock::time_point cancelled_at = Clock::now();
  cancel.Cancel();
  downloader.join();
  EXPECT_EQ(result.code(), absl::StatusCode::kCancelled) << result;
  EXPECT_LT(ended - cancelled_at, std::chrono::seconds(5));
}

// Closing during a stalled link blocked 58 s: a stream in flight that brings
// nothing is cancelled at once, not when the stall watchdog would give up
// on it, and the sink sees nothing after the cancel.
TEST_F(BlobDownloadTest, CancelStopsAStreamInFlight) {
  const std::string blob = Pattern(8000);
  SetBlob(blob, 1000);
  {
    std::lock_guard lock(fake_.mu);
    fake_.stall_after = 2;
  }
  ClientOptions options;
  options.rpc_timeout_seconds = 600;  // the stall watchdog would wait 10 min
  options.max_outage_seconds = 600;
  auto transport = Connect(options);
  ASSERT_NE(transport, nullptr);
  CancelSource cancel;
  std::mutex mu;
  std::condition_variable arrived;
  size_t received = 0;
  bool after_cancel = false;
  absl::Status result;
  Clock::time_point ended;
  std::thread downloader([&] {
    result = DownloadBlob(
        *transport, DigestOf(blob),
        [&](std::string_view data) {
          std::lock_guard lock(mu);
          received += data.size();
          after_cancel = after_cancel || cancel.cancelled();
          arrived.notify_all();
          return absl::OkStatus();
        },
        &cancel);
    ended = Clock::now();
  });
  {
    std::unique_lock lock(mu);
    EXPECT_TRUE(arrived.wait_for(lock, std::chrono::seconds(30), [&] { return received == 2000; }));
  }
  const Clock::time_point cancelled_at = Clock::now();
  cancel.Cancel();
  downloader.join();
  EXPECT_EQ(result.code(), absl::StatusCode::kCancelled) << result;
  EXPECT_LT(ended - cancelled_at, std::chrono::seconds(5));
  std::lock_guard lock(mu);
  EXPECT_EQ(received, 2000u);
  EXPECT_FALSE(after_cancel);
  EXPECT_EQ(Offsets(), std::vector<int64_t>{0}) << "no stream after the cancel";
}

TEST_F(BlobDownloadTest, ACancelledSourceStartsNoStream) {
  const std::string blob = Pattern(8000);
  SetBlob(blob, 1000);
  auto transport = Connect(ClientOptions{});
  ASSERT_NE(transport, nullptr);
  CancelSource cancel("closed");
  cancel.Cancel();
  const absl::Status result = DownloadBlob(
      *transport, DigestOf(blob), [](std::string_view) { return absl::OkStatus(); }, &cancel);
  EXPECT_EQ(result, absl::CancelledError("closed"));
  EXPECT_TRUE(Offsets().empty());
}

// The cache asks for the manifest first (GetResult): that call, retried
// through an outage, is cancelled the same way.
TEST_F(BlobDownloadTest, CancelEndsAUnaryCallRetriedThroughAnOutage) {
  {
    std::lock_guard lock(fake_.mu);
    fake_.refuse_all = true;
  }
  ClientOptions options;
  options.max_attempts = 2;
  options.max_outage_seconds = 600;
  auto transport = Connect(options);
  ASSERT_NE(transport, nullptr);
  CancelSource cancel("the cache is shutting down");
  absl::Status result;
  Clock::time_point ended;
  std::thread caller([&] {
    result = transport->GetResult(std::string(64, 'a'), &cancel).status();
    ended = Clock::now();
  });
  EXPECT_TRUE(fake_.WaitUntil([&] { return fake_.get_result_calls >= 3; }));
  const Clock::time_point cancelled_at = Clock::now();
  cancel.Cancel();
  caller.join();
  EXPECT_EQ(result, absl::CancelledError("the cache is shutting down"));
  EXPECT_LT(ended - cancelled_at, std::chrono::seconds(5));
}

TEST(CancelSource, RunsEachLiveRegistrationOnceAndLateOnesAtOnce) {
  CancelSource source("stop");
  int runs = 0;
  { CancelSource::Registration gone = source.OnCancel([&] { runs += 1; }); }
  CancelSource::Registration kept = source.OnCancel([&] { runs += 10; });
  EXPECT_FALSE(source.cancelled());
  EXPECT_FALSE(source.WaitFor(std::chrono::milliseconds(1)));
  source.Cancel();
  source.Cancel();
  EXPECT_EQ(runs, 10) << "the dropped registration never runs; the kept one once";
  CancelSource::Registration late = source.OnCancel([&] { runs += 100; });
  EXPECT_EQ(runs, 110);
  EXPECT_TRUE(source.cancelled());
  EXPECT_TRUE(source.WaitFor(std::chrono::hours(1))) << "returns at once once cancelled";
  EXPECT_EQ(source.error(), absl::CancelledError("stop"));
}

// A waiting thread is woken by Cancel from another one.
TEST(CancelSource, CancelWakesAWaiter) {
  CancelSource source;
  std::atomic<bool> woke{false};
  std::thread waiter([&] { woke = source.WaitFor(std::chrono::hours(1)); });
  source.Cancel();
  waiter.join();
  EXPECT_TRUE(woke.load());
}

TEST(RetryPolicy, ACancelledCallIsNeitherRetriedNorWaitedFor) {
  ConnectionMonitor monitor("bake:1", 300, nullptr);
  monitor.NoteFailure(absl::UnavailableError("down"));  // an outage: the budget would retry
  ClientOptions options;
  options.max_attempts = 1;
  CancelSource cancel;
  int waits = 0;
  RetryPolicy retry(options, monitor, [&](std::chrono::duration<double>) { ++waits; }, &cancel);
  EXPECT_TRUE(retry.ShouldRetry(absl::UnavailableError("down")));
  EXPECT_FALSE(retry.cancelled());
  cancel.Cancel();
  EXPECT_FALSE(retry.ShouldRetry(absl::UnavailableError("down")));
  EXPECT_TRUE(retry.cancelled());
  EXPECT_EQ(waits, 1);
}

}  // namespace
}  // namespace impostor::sdk
