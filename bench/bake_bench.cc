// bake_bench: bakes real assets through a real impostor-server and one local
// impostor-worker (12x12 frames, 2048 px, octahedral by default) and prints
// where the time went (load, render, readback, encode, store, as the worker
// measured them), then fetches each result again from the cache with the SDK
// and prints the download throughput.
//
//   bake_bench [--frames N] [--resolution R] [--fetches K] [--keep-result DIR] [ASSET.glb ...]
//
// Ratios (issue 18's targets): bake/rr = the worker's whole bake (load to
// manifest, quality pass included) over its render + readback; wall/rr = the
// same for the end-to-end wall time the client saw. readback includes the
// device's supersample resolve. encode_s runs beside the quality pass, so
// rest_s = the bake's time outside load, render, readback and encode
// (cutout, dilation, the part of the quality pass the encoding did not
// cover, the manifest). --keep-result copies the last asset's
// fetched result (maps + manifest.json) to DIR, to look at or to render
// its views elsewhere.
//
// Figures on a shared machine are noisy: compare ratios within one run.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "bench/bench_args.h"
#include "impostor/client.h"
#include "impostor/v1/bake_service.grpc.pb.h"

namespace fs = std::filesystem;

namespace {

struct Server {
  pid_t pid = -1;
  std::string address;
  ~Server() {
    if (pid > 0) {
      ::kill(pid, SIGTERM);
      ::waitpid(pid, nullptr, 0);
    }
  }
};

bool StartServer(const fs::path& data, Server* server) {
  int fds[2];
  if (::pipe(fds) != 0) return false;
  const std::string bin = std::string(IMPOSTOR_BENCH_BINARY_DIR) + "/impostor-server";
  const std::string data_flag = "--data=" + data.string();
  server->pid = ::fork();
  if (server->pid == 0) {
    ::dup2(fds[1], STDOUT_FILENO);
    ::close(fds[0]);
    ::execl(bin.c_str(), bin.c_str(), "--listen=127.0.0.1:0", data_flag.c_str(), "--local-workers=1",
            "--log-level=warn", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(fds[1]);
  std::string out;
  char c;
  while (::read(fds[0], &c, 1) == 1 && c != '\n') out.push_back(c);
  ::close(fds[0]);
  if (out.find("listening on") == std::string::npos) return false;
  server->address = out.substr(out.rfind(' ') + 1);
  return true;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t frames = 12, resolution = 2048;
  int fetches = 3;
  fs::path keep_result;
  std::vector<fs::path> assets;
  std::string keep_flag;
  std::vector<std::string> asset_args;
  impostor::bench::BenchArgs("bake_bench", "Bakes assets through a real server and worker and prints the stage times.")
      .Uint("--frames", &frames, "frames per side (default 12)")
      .Uint("--resolution", &resolution, "atlas size in pixels (default 2048)")
      .Int("--fetches", &fetches, "downloads of each result from the cache (default 3)")
      .Text("--keep-result", &keep_flag, "copy the last asset's fetched result here")
      .Positional("ASSET.glb", &asset_args, "assets to bake (default DamagedHelmet and TransmissionTest)")
      .ParseOrExit(argc, argv);
  if (!keep_flag.empty()) keep_result = keep_flag;
  for (const std::string& a : asset_args) assets.emplace_back(a);
  if (assets.empty()) {
    const fs::path dir = IMPOSTOR_BENCH_ASSETS_DIR;
    assets = {dir / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb",
              dir / "highpoly/TransmissionTest/glTF-Binary/TransmissionTest.glb"};
  }

  const fs::path scratch = fs::temp_directory_path() / ("impostor_bench_" + std::to_string(::getpid()));
  fs::remove_all(scratch);
  fs::create_directories(scratch);
  Server server;
  if (!StartServer(scratch / "data", &server)) {
    std::fprintf(stderr, "bake_bench: impostor-server did not start\n");
    return 1;
  }
  auto client = impostor::sdk::Client::Connect({.server = server.address});
  if (!client.ok()) {
    std::fprintf(stderr, "bake_bench: %s\n", client.status().ToString().c_str());
    return 1;
  }
  auto channel = grpc::CreateChannel(server.address, grpc::InsecureChannelCredentials());
  auto bake = impostor::v1::BakeService::NewStub(channel);

  std::printf("bake_bench: %u x %u frames, %u px atlas, octahedral, one local worker\n", frames, frames, resolution);
  std::printf("%-22s %9s %7s %7s %7s %8s %8s %7s %7s %7s %7s %7s %9s %10s\n", "asset", "triangles", "wall_s",
              "load_s", "render_s", "readback", "encode_s", "rest_s", "store_s", "other_s", "bake/rr", "wall/rr",
              "fetch_MB", "fetch_MB/s");
  int failures = 0;
  for (const fs::path& asset : assets) {
    const auto start = std::chrono::steady_clock::now();
    auto submitted = (*client)->SubmitBake(asset, {.layout = "octahedral", .frames = frames, .resolution = resolution});
    if (!submitted.ok()) {
      std::fprintf(stderr, "bake_bench: %s: %s\n", asset.c_str(), submitted.status().ToString().c_str());
      ++failures;
      continue;
    }
    auto final_state = (*client)->WatchJob(submitted->job_id, [](const impostor::sdk::JobUpdate&) {});
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!final_state.ok() || final_state->state != impostor::sdk::JobState::kSucceeded) {
      std::fprintf(stderr, "bake_bench: %s: bake failed: %s\n", asset.c_str(),
                   final_state.ok() ? final_state->error_message.c_str() : final_state.status().ToString().c_str());
      ++failures;
      continue;
    }
    // The worker's own stage timings travel in the result proto.
    grpc::ClientContext ctx;
    impostor::v1::GetJobRequest get;
    get.set_job_id(submitted->job_id);
    impostor::v1::Job job;
    bake->GetJob(&ctx, get, &job);
    const auto& t = job.result().timings();
    const double accounted = t.load_seconds() + t.render_seconds() + t.readback_seconds() + t.encode_seconds() +
                             t.store_seconds();
    const double rest = std::max(
        0.0, t.total_seconds() - t.load_seconds() - t.render_seconds() - t.readback_seconds() - t.encode_seconds());
    const double render_readback = std::max(t.render_seconds() + t.readback_seconds(), 1e-9);

    // Cache hit: every fetch downloads all maps again into a fresh directory.
    std::vector<double> rates;
    double megabytes = 0;
    for (int k = 0; k < fetches; ++k) {
      const fs::path out = scratch / ("fetch_" + std::to_string(k));
      fs::remove_all(out);
      auto fetched = (*client)->Fetch(submitted->cache_key, out);
      if (!fetched.ok()) {
        std::fprintf(stderr, "bake_bench: fetch: %s\n", fetched.status().ToString().c_str());
        ++failures;
        break;
      }
      megabytes = static_cast<double>(fetched->bytes_downloaded) / 1e6;
      rates.push_back(megabytes / std::max(fetched->seconds, 1e-9));
      if (!keep_result.empty() && k == 0) {
        std::error_code ec;
        fs::remove_all(keep_result, ec);
        fs::create_directories(keep_result.parent_path().empty() ? fs::path(".") : keep_result.parent_path(), ec);
        fs::copy(out, keep_result, fs::copy_options::recursive, ec);
        if (ec) {
          std::fprintf(stderr, "bake_bench: --keep-result %s: %s\n", keep_result.c_str(), ec.message().c_str());
          ++failures;
        }
      }
    }
    std::printf("%-22s %9llu %7.2f %7.2f %7.2f %8.2f %8.2f %7.2f %7.2f %7.2f %7.2f %7.2f %9.1f %10.0f\n",
                asset.stem().string().substr(0, 22).c_str(),
                static_cast<unsigned long long>(job.result().mesh().triangles()), wall, t.load_seconds(),
                t.render_seconds(), t.readback_seconds(), t.encode_seconds(), rest, t.store_seconds(),
                std::max(0.0, wall - accounted - rest), t.total_seconds() / render_readback, wall / render_readback,
                megabytes, Median(rates));
  }
  std::printf("(render_s includes uploading the scene to the device; rest_s = the bake outside the named stages "
              "(cutout, dilation, the quality pass beyond the encoding it overlaps, manifest); other_s = wall minus the bake and store: "
              "client upload, queueing, worker download, RPCs; bake/rr and wall/rr = the bake's and the client's "
              "time over render + readback, target <= 1.3)\n");
  fs::remove_all(scratch);
  return failures == 0 ? 0 : 1;
}
