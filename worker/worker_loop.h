// The worker process's main loop: lease a job from the server, fetch its
// input blobs into a private directory, bake, upload the outputs, complete
// or fail the job, repeat. A heartbeat thread renews the lease while a bake
// runs and notices cancellation.
//
// Draining (SIGTERM): no new leases; the current job may finish within the
// drain budget, else its lease is handed back (ReleaseJob) so another worker
// starts it at once.
//
// Thread-safety: Run() on one thread; Stop() and Drain() from any thread
// (e.g. a signal watcher).
#ifndef IMPOSTOR_WORKER_WORKER_LOOP_H_
#define IMPOSTOR_WORKER_WORKER_LOOP_H_

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include <grpcpp/grpcpp.h>

#include "absl/base/thread_annotations.h"
#include "absl/status/status.h"
#include "common/net/failover_channel.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/worker_service.grpc.pb.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/isolated_load.h"

namespace impostor {

struct WorkerOptions {
  // HOST:PORT of impostor-server, or the comma list of several replicas
  // of one farm (common/net/server_list.h; checked by main): leases, heartbeats
  // and transfers go to one replica and move on to the next when a call
  // fails with UNAVAILABLE or times out (common/net/failover_channel.h).
  std::string server = "localhost:50051";
  std::string worker_id;                   // unique per process
  // Per-job folders go here. A job's inputs are measured against this
  // filesystem before they are downloaded (worker/scratch_space.h).
  std::filesystem::path scratch_dir;
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
  // SIGTERM budget: the current job may finish within this many seconds;
  // past it the lease is handed back. Default 60; range 0..3600.
  int drain_seconds = 60;
  // How long the server may stay unreachable before Run gives up
  // (UNAVAILABLE, the process exits non-zero). Default 300; range 1..86400.
  int max_outage_seconds = 300;
  // HTTP/2 keepalive of calls in flight (common/net/keepalive.h; issue 15):
  // an input download or result upload over a link that died without a
  // reset fails after about keepalive + min(keepalive, 10) s and is retried
  // on the next replica, instead of waiting out its 10-minute deadline.
  // Default 20; range 1..7200.
  int keepalive_seconds = 20;
  // Test-only fault switch: raise SIGSEGV on entering the render stage of a
  // mesh whose entry file is named this. Empty = off. Set from
  // $IMPOSTOR_WORKER_TEST_CRASH_ON (see worker/test_faults.h).
  std::string test_crash_on;
  // Test-only fault switch: fail every bake of a mesh whose entry file is
  // named this ("*" = every mesh) with a retryable INTERNAL error, as a
  // broken GPU would. Empty = off. Set from $IMPOSTOR_WORKER_TEST_FAIL_ON.
  std::string test_fail_on;
  // Test hook: while this file exists, a bake pauses when it reaches its
  // render stage (heartbeats continue); when the file's first word is
  // "render-chunk", it pauses after each rendered chunk instead (a cancel
  // then lands between chunks); "complete": after uploading the result,
  // before CompleteJob (the job's stage then reads "uploaded"). Lets tests kill processes or damage the store at a
  // known point of a bake. Empty = off. Set from
  // $IMPOSTOR_WORKER_TEST_PAUSE_FILE.
  std::filesystem::path test_pause_file;
  // Transport security of the channel to `server` (common/net/tls_channel.h,
  // from --tls-ca/--tls-cert/--tls-key). Null = plaintext.
  std::shared_ptr<grpc::ChannelCredentials> channel_credentials;
  // --tls-server-name: the name the server's certificate must carry when it
  // differs from the host in `server`. Empty = that host.
  std::string tls_server_name;
  // --tls-ca's path ('' = plaintext), for explaining a failed handshake
  // (common/net/tls_peer_check.h); the credentials above hold its contents.
  std::string tls_ca_file;
  // Bearer token sent on every call (issue 14); empty = none (a server with
  // --auth none).
  std::string token;
  // Sent with every LeaseJob (worker/capabilities.h): the server leases
  // only jobs that fit them. Empty = report nothing (leased anything).
  v1::WorkerCapabilities capabilities;
};

class WorkerLoop {
 public:
  WorkerLoop(WorkerOptions options, std::unique_ptr<AtlasRenderer> renderer);

  // Serves until Stop()/Drain() or max_jobs. Returns OK on a clean stop;
  // UNAVAILABLE when the server stayed unreachable for max_outage_seconds
  // (shorter outages are retried with backoff).
  absl::Status Run();
  // Drain with the configured budget (options.drain_seconds).
  void Stop() { Drain(std::chrono::seconds(options_.drain_seconds)); }
  // Takes no new job; the current one is handed back once `budget` has
  // passed (at once for 0). A shorter budget than an earlier call wins.
  void Drain(std::chrono::seconds budget);

 private:
  // Runs one leased job to its end. Returns the scratch bytes that must be
  // available before the next lease when the job failed because this
  // worker's scratch was too full for it (scratch_shortage.h), else 0.
  int64_t ProcessJob(const v1::LeasedJob& job);
  // Downloads one input blob to `path`, verified, resuming through an
  // outage (within max_outage_seconds). A full scratch ends it at once with
  // a ScratchWriteError (scratch_shortage.h).
  absl::Status DownloadThroughOutage(const v1::Digest& digest, const std::filesystem::path& path);
  // Uploads one output file, retrying through an outage, and through a full
  // blob store on the server (STORE_FULL) within the same budget
  // (RetryThroughFullServer; `subject` goes in its log lines, e.g.
  // "job=ID"); a store still full at its end is UNAVAILABLE with the reason
  // STORE_FULL, so the job is retried, not lost.
  absl::Status UploadThroughOutage(const std::filesystem::path& path, const v1::Digest& digest,
                                   const std::string& subject);
  // A result's files (UploadResultFiles, result_files_upload.h): the
  // small ones many to a BatchUpdateBlobs call, the large ones streamed,
  // kParallelUploads calls at once (the server syncs each blob before it
  // answers, and one upload at a time waited for each sync in turn). A file
  // refused in that pass (an outage, a full store) and those not yet sent
  // go through UploadThroughOutage one at a time, in order; its status for
  // the first that fails there.
  static constexpr int kParallelUploads = 4;
  // One attempt of `rpc` on the current server, through CallServer.
  absl::Status CallAssets(const std::function<absl::Status(v1::AssetService::Stub&)>& rpc);
  absl::Status UploadAll(const std::vector<std::pair<std::filesystem::path, v1::Digest>>& files,
                         const std::string& subject);
  // Hands a lease back to the server (retrying through an outage and a full
  // database).
  void ReleaseLease(const v1::LeasedJob& job, const std::string& reason);
  using ChannelCall = std::function<grpc::Status(const std::shared_ptr<grpc::Channel>&)>;
  // Runs `call` on the current replica's channel and tells the failover how
  // it went; `try_next_now` (optional) says whether another replica not yet
  // tried since the last answer is now current.
  grpc::Status CallServer(const ChannelCall& call, bool* try_next_now = nullptr);
  // Why the current server cannot be reached, as a sentence naming the fix
  // (common/net/connect_error.h), from gRPC's message for the failed call.
  std::string ExplainUnreachable(const std::string& grpc_message) const;
  // Runs `call` (through CallServer) until it answers something other than
  // UNAVAILABLE or DEADLINE_EXCEEDED (a server that cannot answer now, e.g.
  // its database is away), or the outage budget is spent; returns its last
  // status, saying so when the budget ran out.
  grpc::Status RetryThroughOutage(std::string_view rpc, const ChannelCall& call);
  // A call that also says which error reason (common/error_reason.h) the
  // server sent with its refusal, in *reason ("" when none).
  using ReasonedCall = std::function<grpc::Status(const std::shared_ptr<grpc::Channel>&, std::string* reason)>;
  // Runs `call` through outages (RetryThroughOutage) and
  // through a full disk on the server (RESOURCE_EXHAUSTED with the reason
  // DATABASE_FULL or STORE_FULL: nothing was recorded), which it waits out
  // with backoff, lease kept, within max_outage_seconds (or the drain
  // deadline) from its start. Returns the call's last status; a server
  // still full at the end is UNAVAILABLE saying so, with *stayed_full
  // (optional; else "") set to the reason. `subject` names what the call is
  // for in the wait's log lines ("job=ID", "job=ID file=NAME").
  grpc::Status RetryThroughFullServer(std::string_view rpc, const std::string& subject, const ReasonedCall& call,
                                      std::string* stayed_full = nullptr);
  bool DrainDue() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(job_mu_);

  const WorkerOptions options_;
  std::unique_ptr<AtlasRenderer> renderer_;
  // One channel per address of options_.server (issue 15).
  std::unique_ptr<FailoverChannel> channels_;
  std::atomic<bool> stop_{false};
  // Guards the running job's progress hand-off to its heartbeat thread, and
  // the drain deadline; job_wake_ wakes that thread on either.
  std::mutex job_mu_;
  std::condition_variable job_wake_;
  std::optional<std::chrono::steady_clock::time_point> drain_deadline_ ABSL_GUARDED_BY(job_mu_);
  int64_t drain_budget_s_ ABSL_GUARDED_BY(job_mu_) = 0;  // of the drain that set drain_deadline_
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_WORKER_LOOP_H_
