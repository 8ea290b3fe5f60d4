// The worker process's main loop: lease a job from the server, fetch its
// input blobs into a private directory, bake, upload the outputs, complete
// or fail the job, repeat. A heartbeat thread renews the lease while a bake
// runs and notices cancellation.
//
// Thread-safety: Run() on one thread; Stop() from any thread (e.g. a signal
// watcher) makes Run return after the current job.
#ifndef IMPOSTOR_WORKER_WORKER_LOOP_H_
#define IMPOSTOR_WORKER_WORKER_LOOP_H_

#include <atomic>
#include <filesystem>
#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>

#include "absl/status/status.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/worker_service.grpc.pb.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/isolated_load.h"

namespace impostor {

struct WorkerOptions {
  std::string server = "localhost:50051";  // HOST:PORT of impostor-server
  std::string worker_id;                   // unique per process
  std::filesystem::path scratch_dir;       // per-job folders go here
  // Seconds between lease renewals while baking; well under the server's
  // lease timeout (default 30 s). Each renewal also tells the worker whether
  // the job was cancelled, so this bounds how long a cancelled bake runs on.
  // Default 1; range 1..60.
  int heartbeat_seconds = 1;
  // A job whose stage and fraction have not changed for this many seconds
  // is no longer renewed: its lease expires and the server requeues or
  // fails it, rather than a stuck bake holding it forever (issue 23).
  // Default 1800; range 1..86400.
  int stall_seconds = 1800;
  // Stop after this many jobs (0 = never): used by tests and one-shot runs.
  int max_jobs = 0;
  // Limits on what a mesh may contain (triangles, texture sizes, ...).
  GltfLoadLimits load_limits;
  // Each input is first loaded in a child process under these rlimits
  // (isolated_load.h), so a file that slips past load_limits fails its job,
  // not the worker.
  LoadIsolation load_isolation;
  // Test hook: while this file exists, a bake pauses when it reaches its
  // render stage (heartbeats continue). Lets tests kill processes at a known
  // point of a bake. Empty = off. Set from $IMPOSTOR_WORKER_TEST_PAUSE_FILE.
  std::filesystem::path test_pause_file;
};

class WorkerLoop {
 public:
  WorkerLoop(WorkerOptions options, std::unique_ptr<AtlasRenderer> renderer);

  // Serves until Stop() or max_jobs. Returns OK on a clean stop;
  // connection trouble is retried with backoff, never fatal.
  absl::Status Run();
  void Stop() { stop_ = true; }

 private:
  void ProcessJob(const v1::LeasedJob& job);

  const WorkerOptions options_;
  std::unique_ptr<AtlasRenderer> renderer_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::WorkerService::Stub> workers_;
  std::unique_ptr<v1::AssetService::Stub> assets_;
  std::atomic<bool> stop_{false};
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_WORKER_LOOP_H_
