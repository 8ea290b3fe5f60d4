// load_bench: how many cache-hit answers a second the server gives, and
// their latency, next to an empty unary call (the gRPC health check)
// measured in the same run on the same server.
//
// A closed loop: N callers, each sends its next call as soon as its last
// one is answered, for a fixed duration per RPC. Calls go through gRPC's
// generic stub with the request serialised once, and answers are not
// parsed (the status is checked), so the load generator costs as little CPU
// as it can on a machine it shares with the server.
//
// It starts its own impostor-server (on a fresh data directory, no workers)
// and publishes one small result through WorkerService, so SubmitBake,
// LookupBake and GetResult of that result are cache hits. Not a test:
// prints figures.
//
//   load_bench [--callers N] [--seconds S] [--channels C] [--rpc NAME]...
//              [--server-arg FLAG]...
//   NAME: health, submit, submit_rid (SubmitBake with a request_id, as the
//   CLI sends it), lookup, get_result (default: all five, health first); FLAG: passed to impostor-server (e.g. --job-retention-days=1).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/support/byte_buffer.h>

#include <google/protobuf/empty.pb.h>

#include "bench/bench_args.h"
#include "tests/support/published_result.h"
#include "tests/support/server_process.h"

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

struct Target {
  std::string name;
  std::string method;   // full gRPC method path
  grpc::ByteBuffer request;  // serialised once
};

grpc::ByteBuffer Serialise(const google::protobuf::Message& m) {
  const std::string bytes = m.SerializeAsString();
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

// One caller's call in flight.
struct Call {
  grpc::ClientContext context;
  grpc::ByteBuffer response;
  grpc::Status status;
  std::unique_ptr<grpc::GenericClientAsyncResponseReader> reader;
  Clock::time_point started;
  int caller = 0;
};

struct Figures {
  int64_t answers = 0;
  int64_t errors = 0;
  std::string first_error;
  double seconds = 0;
  std::vector<double> latencies_us;
};

double Percentile(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0;
  return sorted[std::min(sorted.size() - 1, static_cast<size_t>(p * static_cast<double>(sorted.size())))];
}

// Runs `callers` closed-loop callers against `target` for `warmup` (not
// counted) and then `duration`, spread over the channels, one completion
// queue and thread per channel.
Figures RunLoad(const std::vector<std::shared_ptr<grpc::Channel>>& channels, const Target& target, int callers,
                std::chrono::milliseconds warmup, std::chrono::milliseconds duration) {
  const size_t lanes = channels.size();
  std::vector<Figures> per_lane(lanes);
  const Clock::time_point measure_from = Clock::now() + warmup;
  const Clock::time_point stop_at = measure_from + duration;
  std::vector<std::thread> threads;
  for (size_t lane = 0; lane < lanes; ++lane) {
    threads.emplace_back([&, lane] {
      grpc::GenericStub stub(channels[lane]);
      grpc::CompletionQueue cq;
      Figures& f = per_lane[lane];
      auto start_call = [&](int caller) {
        auto* call = new Call;
        call->caller = caller;
        call->started = Clock::now();
        call->context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
        call->reader = stub.PrepareUnaryCall(&call->context, target.method, target.request, &cq);
        call->reader->StartCall();
        call->reader->Finish(&call->response, &call->status, call);
      };
      int in_flight = 0;
      for (int c = static_cast<int>(lane); c < callers; c += static_cast<int>(lanes)) {
        start_call(c);
        ++in_flight;
      }
      void* tag = nullptr;
      bool ok = false;
      while (in_flight > 0 && cq.Next(&tag, &ok)) {
        std::unique_ptr<Call> call(static_cast<Call*>(tag));
        --in_flight;
        const Clock::time_point now = Clock::now();
        if (call->started >= measure_from && now <= stop_at) {
          if (ok && call->status.ok()) {
            ++f.answers;
            f.latencies_us.push_back(std::chrono::duration<double, std::micro>(now - call->started).count());
          } else {
            if (f.errors++ == 0) f.first_error = call->status.error_message();
          }
        }
        if (now < stop_at) {
          start_call(call->caller);
          ++in_flight;
        }
      }
      cq.Shutdown();
      while (cq.Next(&tag, &ok)) {
      }
    });
  }
  for (auto& t : threads) t.join();
  Figures all;
  all.seconds = std::chrono::duration<double>(duration).count();
  for (auto& f : per_lane) {
    all.answers += f.answers;
    all.errors += f.errors;
    if (all.first_error.empty()) all.first_error = f.first_error;
    all.latencies_us.insert(all.latencies_us.end(), f.latencies_us.begin(), f.latencies_us.end());
  }
  std::sort(all.latencies_us.begin(), all.latencies_us.end());
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  int callers = 200;
  double seconds = 5;
  int channel_count = 2;
  std::vector<std::string> rpcs;
  std::vector<std::string> server_args;
  impostor::bench::BenchArgs("load_bench", "Closed-loop gRPC load: N callers per RPC, throughput and latency percentiles.")
      .Int("--callers", &callers, "concurrent callers (default 200, at least 1)")
      .Real("--seconds", &seconds, "duration of each RPC's run (default 5, at least 0.1)")
      .Int("--channels", &channel_count, "gRPC channels the callers share (default 2, at least 1)")
      .Texts("--rpc", &rpcs, "health, submit, submit_rid, lookup or get_result (default all)")
      .Texts("--server-arg", &server_args, "an extra impostor-server flag")
      .ParseOrExit(argc, argv);
  callers = std::max(1, callers);
  seconds = std::max(0.1, seconds);
  channel_count = std::max(1, channel_count);
  if (rpcs.empty()) rpcs = {"health", "submit", "submit_rid", "lookup", "get_result"};

  const fs::path root = fs::temp_directory_path() / ("impostor_load_bench_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "server");
  int exit_code = 0;
  {
    impostor::testing::ServerProcess server(0, root / "server", "127.0.0.1:0", server_args);

    // One small result (a few KiB of maps), submitted by the request the
    // load then repeats.
    const std::string model = "glTF" + impostor::testing::RandomBytes(64, 1);
    impostor::v1::SubmitBakeRequest submit;
    submit.mutable_mesh()->mutable_entry()->set_path("model.glb");
    *submit.mutable_mesh()->mutable_entry()->mutable_digest() = impostor::testing::DigestOf(model);
    submit.mutable_parameters()->set_frames(3);
    submit.mutable_parameters()->set_resolution(64);
    if (!impostor::testing::UploadBytes(server.assets(), model, submit.mesh().entry().digest()).ok()) return 1;
    {
      grpc::ClientContext ctx;
      impostor::v1::SubmitBakeResponse queued;
      if (auto s = server.bake().SubmitBake(&ctx, submit, &queued); !s.ok()) {
        std::fprintf(stderr, "SubmitBake failed: %s\n", s.error_message().c_str());
        return 1;
      }
    }
    const auto published = impostor::testing::CompleteNextJob(server, {4096, 8192, 4096}, 1);

    impostor::v1::GetResultRequest get_result;
    get_result.set_cache_key(published.key);
    std::vector<Target> targets;
    for (const std::string& rpc : rpcs) {
      if (rpc == "health") {
        // HealthCheckRequest{service: ""} serialises to no bytes.
        targets.push_back({rpc, "/grpc.health.v1.Health/Check", Serialise(google::protobuf::Empty())});
      } else if (rpc == "submit") {
        targets.push_back({rpc, "/impostor.v1.BakeService/SubmitBake", Serialise(submit)});
      } else if (rpc == "submit_rid") {
        // As the CLI and SDK send it: with a request_id (looked up for a
        // retry, so this path also reads the job table).
        impostor::v1::SubmitBakeRequest with_id = submit;
        with_id.set_request_id("load-bench-0123456789abcdef");
        targets.push_back({rpc, "/impostor.v1.BakeService/SubmitBake", Serialise(with_id)});
      } else if (rpc == "lookup") {
        targets.push_back({rpc, "/impostor.v1.BakeService/LookupBake", Serialise(submit)});
      } else if (rpc == "get_result") {
        targets.push_back({rpc, "/impostor.v1.AssetService/GetResult", Serialise(get_result)});
      } else {
        std::fprintf(stderr, "--rpc: unknown \"%s\" (health, submit, submit_rid, lookup, get_result)\n", rpc.c_str());
        return 2;
      }
    }

    // Separate channels (one TCP connection each) so one connection's
    // HTTP/2 stream limit does not queue the callers.
    std::vector<std::shared_ptr<grpc::Channel>> channels;
    for (int i = 0; i < channel_count; ++i) {
      grpc::ChannelArguments args;
      args.SetInt("load_bench_channel", i);  // distinct args: a connection each
      args.SetInt(GRPC_ARG_MAX_CONCURRENT_STREAMS, 1000);
      channels.push_back(grpc::CreateCustomChannel(server.address(), grpc::InsecureChannelCredentials(), args));
    }

    std::printf("server %s, %d callers, %d channels, %.1f s per RPC (after 1 s warm-up), %u cores\n",
                server.address().c_str(), callers, channel_count, seconds, std::thread::hardware_concurrency());
    std::printf("| RPC | answers/s | p50 ms | p99 ms | p99.9 ms | p99 / health p99 | errors |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    double baseline_p99 = 0;
    for (const Target& t : targets) {
      const Figures f = RunLoad(channels, t, callers, std::chrono::seconds(1),
                                std::chrono::milliseconds(static_cast<int64_t>(seconds * 1000)));
      const double p99 = Percentile(f.latencies_us, 0.99) / 1e3;
      if (t.name == "health") baseline_p99 = p99;
      const std::string ratio = baseline_p99 > 0 ? std::to_string(p99 / baseline_p99).substr(0, 4) : "-";
      std::printf("| %s | %.0f | %.2f | %.2f | %.2f | %s | %lld%s%s |\n", t.name.c_str(),
                  static_cast<double>(f.answers) / f.seconds, Percentile(f.latencies_us, 0.5) / 1e3, p99,
                  Percentile(f.latencies_us, 0.999) / 1e3, ratio.c_str(), static_cast<long long>(f.errors),
                  f.errors ? " first: " : "", f.first_error.c_str());
      std::fflush(stdout);
      if (f.errors) exit_code = 1;
    }
    const auto db = root / "server" / "jobs.sqlite3";
    std::error_code ec;
    std::printf("jobs.sqlite3 after the run: %lld bytes (+ WAL %lld bytes)\n",
                static_cast<long long>(fs::file_size(db, ec)),
                static_cast<long long>(fs::file_size(fs::path(db.string() + "-wal"), ec)));
  }
  fs::remove_all(root);
  return exit_code;
}
