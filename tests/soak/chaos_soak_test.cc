// Chaos soak (issue 19): bakes from several concurrent SDK clients while a
// driver kills random workers and the server itself with SIGKILL at random
// intervals. Bounded in count and time; label `soak`, run by CI on its own.
// At the end every job has SUCCEEDED or FAILED with a message naming a real
// reason, no cache key has two different results, and every blob in the
// store still hashes to its name.
#include <signal.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "common/util/sha256.h"
#include "impostor/client.h"
#include "tests/support/server_process.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using testing::AssetsDir;
using testing::ChildProcess;
using testing::ServerProcess;

constexpr int kClients = 4;
constexpr int kBakesPerClient = 75;  // 300 in all
constexpr int kWorkers = 2;
// Chaos stops after this long so the run is bounded; the clients then finish
// against a healthy farm.
constexpr auto kChaosFor = std::chrono::seconds(150);

// Small assets so a bake takes well under a second on lavapipe.
const char* const kAssets[] = {
    "props_pbr/Box/glTF-Binary/Box.glb",
    "props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb",
    "props_pbr/Duck/glTF-Binary/Duck.glb",
};

struct Request {
  std::string asset;
  sdk::BakeSettings settings;
};

// 150 distinct requests; every one is asked for by two different clients,
// so shared bakes and cache hits happen while processes die.
std::vector<Request> DistinctRequests() {
  std::vector<Request> out;
  const uint32_t frames[] = {3, 4, 5, 6, 7};
  const uint32_t resolutions[] = {64, 72, 80, 88, 96, 104, 112, 120, 128, 136};
  for (const char* asset : kAssets) {
    for (uint32_t f : frames) {
      for (uint32_t r : resolutions) {
        sdk::BakeSettings s;
        s.frames = f;
        s.resolution = r;
        s.supersampling = 1;
        out.push_back({asset, s});
      }
    }
  }
  return out;
}

struct Outcome {
  std::string cache_key;
  absl::Status status;  // of the SDK calls
  sdk::JobState state = sdk::JobState::kUnknown;
  std::string error_message;
  std::string manifest_sha256;  // of the manifest JSON read when the job succeeded
};

// Every blob file under cas/ hashes to its own name.
int CountCorruptBlobs(const fs::path& data_dir, int* checked) {
  int corrupt = 0;
  for (const auto& entry : fs::recursive_directory_iterator(data_dir / "cas")) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().filename().string();
    if (name.size() != 64) continue;  // temp files of an interrupted write
    ++*checked;
    std::string bytes = testing::ReadFileBytes(entry.path());
    if (Sha256Hex(bytes) != name) ++corrupt;
  }
  return corrupt;
}

TEST(ChaosSoak, NothingIsLostWhileWorkersAndTheServerAreKilled) {
  const fs::path data = testing::NewTempDir("chaos_data");
  // Lease >= 5x the workers' 1 s heartbeat; attempts enough that only a job
  // struck again and again fails.
  ServerProcess server(0, data, "127.0.0.1:0", {"--lease-timeout-s=5", "--max-attempts=5"});
  const std::string address = server.address();
  ASSERT_FALSE(address.empty());
  std::vector<std::unique_ptr<ChildProcess>> workers;
  for (int i = 0; i < kWorkers; ++i) workers.push_back(testing::StartWorker(address, {"--heartbeat-s=1"}));

  const std::vector<Request> requests = DistinctRequests();
  std::vector<std::vector<Outcome>> outcomes(kClients);
  std::atomic<int> clients_done{0};
  std::atomic<int> finished{0};

  auto run_client = [&](int c) {
    sdk::ClientOptions options{.server = address, .client_id = "chaos-" + std::to_string(c)};
    options.max_outage_seconds = 120;
    auto client = sdk::Client::Connect(options);
    for (int k = 0; k < kBakesPerClient; ++k) {
      // Client c asks for requests c*75 .. c*75+74 (mod 150): each request
      // is asked for by exactly two clients.
      const Request& r = requests[(static_cast<size_t>(c) * kBakesPerClient + k) % requests.size()];
      Outcome o;
      if (!client.ok()) {
        o.status = client.status();
      } else {
        auto submitted = (*client)->SubmitBake(AssetsDir() / r.asset, r.settings);
        if (!submitted.ok()) {
          o.status = submitted.status();
        } else {
          o.cache_key = submitted->cache_key;
          auto done = (*client)->WatchJob(submitted->job_id, nullptr);
          if (!done.ok()) {
            o.status = done.status();
          } else {
            o.state = done->state;
            o.error_message = done->error_message;
            if (done->state == sdk::JobState::kSucceeded) {
              auto manifest = (*client)->GetManifestJson(submitted->cache_key);
              if (manifest.ok()) o.manifest_sha256 = Sha256Hex(*manifest);
              else o.status = manifest.status();
            }
          }
        }
      }
      outcomes[c].push_back(std::move(o));
      ++finished;
    }
    ++clients_done;
  };

  // The driver: random kills, seeded so a failure can be replayed.
  // IMPOSTOR_CHAOS_SEED replays a run.
  const char* seed_env = std::getenv("IMPOSTOR_CHAOS_SEED");
  const unsigned seed = seed_env ? static_cast<unsigned>(std::strtoul(seed_env, nullptr, 10)) : std::random_device{}();
  std::printf("chaos soak: seed %u\n", seed);
  int worker_kills = 0, server_kills = 0;
  std::atomic<bool> driver_stop{false};
  std::atomic<bool> driver_failed{false};
  std::thread driver([&] {
    // A restart that fails throws (the harness has already reported why);
    // the driver then stops striking and the test fails below.
    try {
      std::mt19937 rng(seed);
      const auto chaos_until = std::chrono::steady_clock::now() + kChaosFor;
      while (!driver_stop && clients_done < kClients && std::chrono::steady_clock::now() < chaos_until) {
        // The pause between blows is the chaos itself, not synchronisation.
        std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(1500, 6000)(rng)));
        if (std::uniform_int_distribution<int>(0, 3)(rng) == 0) {
          server.Kill();
          std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(200, 3000)(rng)));
          server.Restart();
          ++server_kills;
        } else {
          const size_t w = std::uniform_int_distribution<size_t>(0, workers.size() - 1)(rng);
          workers[w]->KillAndReap();
          workers[w] = testing::StartWorker(address, {"--heartbeat-s=1"});
          ++worker_kills;
        }
      }
    } catch (...) {
      driver_failed = true;
    }
  });

  std::vector<std::thread> clients;
  for (int c = 0; c < kClients; ++c) clients.emplace_back(run_client, c);
  for (auto& t : clients) t.join();
  driver_stop = true;
  driver.join();

  EXPECT_FALSE(driver_failed) << "a restart failed (see the log above)";
  // Every job ended, and ended for a reason.
  int succeeded = 0, failed = 0, errors = 0;
  std::map<std::string, std::set<std::string>> manifests_by_key;
  for (int c = 0; c < kClients; ++c) {
    for (const Outcome& o : outcomes[c]) {
      if (!o.status.ok()) {
        ++errors;
        ADD_FAILURE() << "client " << c << " key " << o.cache_key << ": " << o.status;
      } else if (o.state == sdk::JobState::kSucceeded) {
        ++succeeded;
        manifests_by_key[o.cache_key].insert(o.manifest_sha256);
      } else {
        ++failed;
        EXPECT_EQ(o.state, sdk::JobState::kFailed) << o.cache_key;
        EXPECT_FALSE(o.error_message.empty()) << "a failed job must say why: " << o.cache_key;
      }
    }
  }
  int keys_with_two_results = 0;
  for (const auto& [key, digests] : manifests_by_key) {
    if (digests.size() != 1) ++keys_with_two_results;
    EXPECT_EQ(digests.size(), 1u) << "cache key " << key << " has " << digests.size() << " different results";
  }
  int checked = 0;
  const int corrupt = CountCorruptBlobs(data, &checked);
  EXPECT_EQ(corrupt, 0);
  EXPECT_EQ(succeeded + failed + errors, kClients * kBakesPerClient);
  EXPECT_GT(server_kills + worker_kills, 0) << "the driver never struck: the soak tested nothing";
  std::printf(
      "chaos soak: %d bakes from %d clients, %d server kills, %d worker kills: %d succeeded, %d failed with a "
      "reason, %d client errors; %zu cache keys, %d with two results; %d blobs verified, %d corrupt\n",
      kClients * kBakesPerClient, kClients, server_kills, worker_kills, succeeded, failed, errors,
      manifests_by_key.size(), keys_with_two_results, checked, corrupt);
}

}  // namespace
}  // namespace impostor
