// The only file pair of the client that touches gRPC: one channel to the
// server, the BakeService and AssetService stubs, deadlines, retries of unary
// calls, and the translation of grpc::Status into absl::Status (see
// rpc_error.h). Everything above it speaks protobuf messages and absl::Status.
//
// Thread-safety: all methods may be called concurrently (gRPC channels and
// stubs are thread-safe; every call has its own ClientContext).
#ifndef IMPOSTOR_CLIENT_TRANSPORT_TRANSPORT_H_
#define IMPOSTOR_CLIENT_TRANSPORT_TRANSPORT_H_

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/transport/connection_monitor.h"
#include "client/transport/retry.h"
#include "common/net/failover_channel.h"
#include "impostor/client.h"
#include "impostor/v1/admin_service.pb.h"
#include "impostor/v1/asset_service.pb.h"
#include "impostor/v1/bake_service.pb.h"
#include "impostor/v1/types.pb.h"

namespace grpc {
class Status;
}  // namespace grpc

namespace impostor::sdk {

// Observers for tests and diagnostics; empty members are skipped.
struct TransportHooks {
  // Called as each RPC starts on the wire (every retry and every resumed
  // stream too) with its full method name, e.g.
  // "/impostor.v1.AssetService/ReadBlob". Runs on the calling thread.
  std::function<void(const std::string& method)> on_rpc;
};

class Transport {
 public:
  // Validates `options`, opens the channel and waits until it is ready (see
  // Client::Connect).
  static absl::StatusOr<std::unique_ptr<Transport>> Connect(const ClientOptions& options,
                                                            const TransportHooks& hooks = {});
  ~Transport();
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  const ClientOptions& options() const { return options_; }
  // ClientOptions::server: one address or a comma list of replicas.
  const std::string& server() const { return options_.server; }
  // The Authorization value every call carries ("Bearer <token>"), "" for
  // no token: the farm's HTTP front end takes the same.
  const std::string& authorization() const;
  // The farm's HTTP front end, without a trailing "/": ClientOptions::farm_http
  // or $IMPOSTOR_FARM_HTTP, else the one the farm advertised on the last
  // GetResult answer (impostor-server --http-advertise; usable with this
  // transport's TLS setting); "" when none, or when "none" turned it off.
  std::string farm_http() const;
  // How the front end has fared, kept by client/transfer/farm_http_fetch.h:
  // its failures in a row, and whether this transport gave it up.
  struct FarmHttpRecord {
    std::atomic<int> failures_in_a_row{0};
    std::atomic<bool> given_up{false};
  };
  FarmHttpRecord& farm_http_record() const;

  // Unary RPCs: deadline rpc_timeout_seconds, retried as RetryPolicy
  // decides (max_attempts, and through outages up to max_outage_seconds).
  // `cancel` (may be null), here and on GetResult: once cancelled, the call
  // in flight is cancelled and the backoff wait ends; the answer is then
  // cancel->error().
  absl::StatusOr<v1::FindMissingBlobsResponse> FindMissingBlobs(const v1::FindMissingBlobsRequest& request,
                                                                const CancelSource* cancel = nullptr);
  absl::StatusOr<v1::SubmitBakeResponse> SubmitBake(const v1::SubmitBakeRequest& request);
  absl::StatusOr<v1::Job> GetJob(const std::string& job_id);
  absl::StatusOr<v1::Job> CancelJob(const std::string& job_id);
  absl::StatusOr<v1::Manifest> GetResult(const std::string& cache_key, const CancelSource* cancel = nullptr);
  // Small blobs whole in one call (common/net/batch_read.h has the limits);
  // UNIMPLEMENTED from a server older than the call. The bytes are not
  // checked here: see ReadBlobBatch (client/transfer/blob_batch.h).
  absl::StatusOr<v1::BatchReadBlobsResponse> BatchReadBlobs(const v1::BatchReadBlobsRequest& request,
                                                            const CancelSource* cancel = nullptr);
  // Small blobs whole in one call (the same limits), each answered with its
  // own code; UNIMPLEMENTED from a server older than the call. Retried as
  // the other unary calls, but its deadline is rpc_timeout_seconds for each
  // kBatchUpdateMessageBytes of the request's data and once more, the time
  // UploadBlob's stall watchdog gives those bytes, so a slow uplink is not
  // cut for being slow. See UploadBlobFiles (client/transfer/blob_batch_upload.h).
  absl::StatusOr<v1::BatchUpdateBlobsResponse> BatchUpdateBlobs(const v1::BatchUpdateBlobsRequest& request,
                                                                const CancelSource* cancel = nullptr);
  // The bytes of a BatchUpdateBlobs request that earn its deadline another
  // rpc_timeout_seconds: UploadBlob's message size (kUploadChunkBytes).
  static constexpr int64_t kBatchUpdateMessageBytes = int64_t{64} << 10;
  absl::StatusOr<v1::LookupBakeResponse> LookupBake(const v1::SubmitBakeRequest& request);
  // AdminService (admin tokens only; `impostor admin purge`).
  absl::StatusOr<v1::PurgeWorkerResultsResponse> PurgeWorkerResults(const v1::PurgeWorkerResultsRequest& request);

  // Fills `data` (cleared before each call) with the next bytes to send and
  // returns true, or returns false once there are none left. A non-OK status
  // aborts the upload and is returned as is.
  using ChunkSource = std::function<absl::StatusOr<bool>(std::string* data)>;

  // Every RPC's outcome is reported here (streams: each message too); the
  // callers' RetryPolicy reads the outage from it.
  ConnectionMonitor& monitor();

  // Waits at most `at_most` for the current server's channel to connect,
  // returning as soon as it has: a RetryPolicy's backoff (RetryPolicy::Wait)
  // during an outage. Nothing else drives a sync channel's reconnection
  // while every call sleeps in its backoff (gRPC's backup poller runs every
  // 5 s), so a restarted server went unnoticed for 2-5 s after it listened.
  // A channel that is connected already (a live server that answered
  // UNAVAILABLE) waits the whole backoff. Returns at once when `cancel`
  // (may be null) is cancelled, before or during the wait.
  void WaitForServer(std::chrono::duration<double> at_most, const CancelSource* cancel = nullptr);
  // RetryPolicy for this transport, waiting with WaitForServer; `cancel`
  // (may be null) ends its waits and its retries (RetryPolicy).
  RetryPolicy NewRetryPolicy(const CancelSource* cancel = nullptr);

  // One UploadBlob stream, not retried (the caller resumes it: QueryUpload
  // says from where). `next_chunk` gives each message's bytes (blob_upload.h
  // says how large), the first one the blob's byte `offset`: 0 uploads from
  // the start, dropping what the server kept of an earlier try; another
  // offset resumes the server's kept partial, which must hold exactly that
  // many bytes (else FAILED_PRECONDITION naming both).
  //
  // No deadline on the whole stream: an upload that keeps moving goes on
  // however slow the link. A stall watchdog cancels it when the link takes
  // no message for rpc_timeout_seconds (a message is taken once it is in
  // this host's TCP send buffer), or when, after the last message, no answer
  // comes within rpc_timeout_seconds for each message the link may still
  // hold (up to 4 MiB of them, the most a send buffer takes) and one more:
  // the server says nothing until it has every byte, so those cross unseen.
  // Either is DEADLINE_EXCEEDED saying that the link stalled, after how many
  // seconds and how many of the blob's bytes were sent.
  //
  // `cancel` (may be null): Cancel() from any thread cancels the stream at
  // once, wherever it is; the answer is then cancel->error(), and
  // `next_chunk` is not called again.
  absl::StatusOr<v1::UploadBlobResponse> UploadBlob(const v1::Digest& digest, const ChunkSource& next_chunk,
                                                    const CancelSource* cancel = nullptr, int64_t offset = 0);
  // How much of `digest`'s upload the server holds (AssetService.QueryUpload):
  // the bytes of a kept partial to resume after, or that the blob is stored.
  // Retried as the other short calls; UNIMPLEMENTED from a server older than
  // resumable uploads.
  absl::StatusOr<v1::QueryUploadResponse> QueryUpload(const v1::Digest& digest, const CancelSource* cancel = nullptr);

  // One ReadBlob stream from `offset` to the end, not retried (the caller
  // resumes from what it got). `on_chunk` sees every message in order; a
  // non-OK status from it cancels the stream and is returned as is.
  //
  // No deadline on the whole stream: a download that keeps moving goes on
  // however slow the link. A stall watchdog cancels it when no message
  // arrives for rpc_timeout_seconds (the first one included):
  // DEADLINE_EXCEEDED, saying that the link stalled. The server is only
  // reported lost (ConnectionMonitor) when a stream fails UNAVAILABLE
  // before any message of its own: a stream cut after bytes arrived is a
  // broken link, which the caller's resume will tell apart from a server
  // gone.
  //
  // `cancel` (may be null): Cancel() from any thread cancels the stream at
  // once, wherever it is (connecting, waiting for bytes); the answer is
  // then cancel->error(), and `on_chunk` is not called again.
  absl::Status ReadBlob(const v1::Digest& digest, int64_t offset,
                        const std::function<absl::Status(const v1::ReadBlobResponse&)>& on_chunk,
                        const CancelSource* cancel = nullptr);

  // One WatchJob stream, without deadline. `on_job` sees every message; the
  // stream is closed early once it returns false.
  absl::Status WatchJob(const std::string& job_id, const std::function<bool(const v1::Job&)>& on_job);

 private:
  struct Stubs;
  Transport(ClientOptions options, std::unique_ptr<Stubs> stubs);

  using Route = FailoverChannel::Route;
  // `status` of a call made on `route` with `context` (finished) as an
  // absl::Status naming `rpc` and the address, with the server's error
  // reason (common/error_reason.h), after telling the monitor and the
  // failover whether the server answered. `try_next_now` (optional) is set
  // when the call may be tried again at once on another replica
  // (FailoverChannel::NoteFailure). `answered`: the call itself brought
  // messages before it failed, so an UNAVAILABLE is a broken stream, not a
  // server gone: the monitor is not told of an outage.
  absl::Status Note(const grpc::Status& status, std::string_view rpc, const Route& route,
                    const grpc::ClientContext& context, bool* try_next_now = nullptr, bool answered = false);
  // DEADLINE_EXCEEDED "the link stalled: <why>" for a stream on `route`
  // that the stall watchdog cancelled, told to the failover as Note would.
  // Reads nothing from the call, which may still be finishing elsewhere.
  absl::Status NoteStall(std::string_view rpc, const Route& route, std::string_view why);
  // A stream message arrived on `route`.
  void NoteAnswer(const Route& route);
  // `timeout_seconds`: each attempt's deadline; <= 0 means rpc_timeout_seconds.
  template <typename Response, typename Call>
  absl::StatusOr<Response> CallUnary(std::string_view rpc, Call call, const CancelSource* cancel = nullptr,
                                     double timeout_seconds = 0);

  ClientOptions options_;
  std::unique_ptr<Stubs> stubs_;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_TRANSPORT_TRANSPORT_H_
