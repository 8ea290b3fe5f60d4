// Client: the public SDK facade. Each method composes the private pieces
// (mesh_files, mesh_upload, result_fetch, transport) on the caller's thread.
#include "impostor/client.h"

#include <optional>
#include <random>
#include <utility>

#include "absl/strings/str_cat.h"
#include "client/transfer/blob_download.h"
#include "client/transfer/farm_http_result_fetch.h"
#include "client/transfer/parallel_downloads.h"
#include "client/transport/job_convert.h"
#include "client/transfer/mesh_files.h"
#include "client/transfer/mesh_upload.h"
#include "client/transfer/result_fetch.h"
#include "client/transport/retry.h"
#include "client/transport/rpc_error.h"
#include "client/base/local_io_error.h"
#include "client/base/sdk_log.h"
#include "client/transport/transport.h"
#include "common/error_reason.h"

namespace impostor::sdk {
namespace {

bool SameSnapshot(const JobUpdate& a, const JobUpdate& b) {
  return a.state == b.state && a.stage == b.stage && a.progress == b.progress && a.error_code == b.error_code &&
         a.error_message == b.error_message && a.cache_key == b.cache_key;
}

// 128 random bits as 32 hex characters: names one logical submit, so that the
// server answers its retries with the job the first attempt created.
std::string NewRequestId() {
  thread_local std::mt19937_64 rng([] {
    std::random_device device;
    return (static_cast<uint64_t>(device()) << 32) ^ device();
  }());
  static constexpr char kHex[] = "0123456789abcdef";
  std::string id(32, '0');
  for (int half = 0; half < 2; ++half) {
    uint64_t bits = rng();
    for (int i = 0; i < 16; ++i, bits >>= 4) id[half * 16 + i] = kHex[bits & 0xf];
  }
  return id;
}

// Submits are tried this many times more when the server has lost one of
// the mesh's blobs since it was uploaded (evicted under store pressure while
// a large batch uploaded the rest, or while a quota held the asset back).
constexpr int kReuploadsPerSubmit = 2;

bool InputBlobMissing(const absl::Status& status) {
  const std::optional<RpcErrorInfo> rpc = GetRpcErrorInfo(status);
  return status.code() == absl::StatusCode::kFailedPrecondition && rpc.has_value() &&
         rpc->reason == error_reason::kInputBlobMissing;
}

// SubmitBake of `request` (its mesh from uploading `files`); when the server
// answers that one of the blobs is not in the store, uploads what it lacks
// again (added to *stats) and submits once more, kReuploadsPerSubmit times
// at most. The request id stays: no attempt that was refused made a job.
absl::StatusOr<v1::SubmitBakeResponse> SubmitUploaded(Transport& transport, const MeshFiles& files,
                                                      const v1::SubmitBakeRequest& request, UploadStats* stats) {
  absl::StatusOr<v1::SubmitBakeResponse> response = transport.SubmitBake(request);
  for (int attempt = 0; attempt < kReuploadsPerSubmit && !response.ok() && InputBlobMissing(response.status());
       ++attempt) {
    SdkLog().info("{}: the server no longer has one of its files ({}); uploading again", files.entry.string(),
                  std::string(response.status().message()));
    absl::StatusOr<UploadedMesh> again = UploadMesh(transport, files);
    if (!again.ok()) return again.status();
    stats->uploaded += again->stats.uploaded;
    stats->bytes_uploaded += again->stats.bytes_uploaded;
    response = transport.SubmitBake(request);
  }
  return response;
}

}  // namespace

// Owns the transport; stateless otherwise, hence thread-safe.
class Client::Impl {
 public:
  explicit Impl(std::unique_ptr<Transport> transport) : transport_(std::move(transport)) {}
  Transport& transport() { return *transport_; }

 private:
  std::unique_ptr<Transport> transport_;
};

Client::Client(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Client::~Client() = default;

absl::StatusOr<std::unique_ptr<Client>> Client::Connect(const ClientOptions& options) {
  absl::StatusOr<std::unique_ptr<Transport>> transport = Transport::Connect(options);
  if (!transport.ok()) return transport.status();
  return std::unique_ptr<Client>(new Client(std::make_unique<Impl>(std::move(*transport))));
}

const std::string& Client::server() const { return impl_->transport().server(); }

absl::StatusOr<SubmitResult> Client::SubmitBake(const std::filesystem::path& model, const BakeSettings& settings) {
  // Everything checkable locally is checked before the first RPC.
  absl::StatusOr<v1::BakeParameters> parameters = ToBakeParameters(settings);
  if (!parameters.ok()) return parameters.status();
  absl::StatusOr<MeshFiles> files = CollectMeshFiles(model, {.follow_symlinks = settings.follow_symlinks});
  if (!files.ok()) return files.status();

  absl::StatusOr<UploadedMesh> uploaded = UploadMesh(impl_->transport(), *files);
  if (!uploaded.ok()) return uploaded.status();
  SdkLog().debug("{}: {} files, {} uploaded ({} bytes)", model.string(), uploaded->stats.files,
                 uploaded->stats.uploaded, uploaded->stats.bytes_uploaded);

  v1::SubmitBakeRequest request;
  *request.mutable_mesh() = std::move(uploaded->mesh);
  *request.mutable_parameters() = *parameters;
  ApplySchedulingSettings(settings, &request);
  request.set_request_id(NewRequestId());
  absl::StatusOr<v1::SubmitBakeResponse> response =
      SubmitUploaded(impl_->transport(), *files, request, &uploaded->stats);
  if (!response.ok()) return response.status();

  SubmitResult result;
  result.job_id = response->job_id();
  result.cache_key = response->cache_key();
  result.cached = response->cached();
  result.upload = uploaded->stats;
  if (response->job().state() == v1::JOB_STATE_FAILED) {
    result.error_code = response->job().error().code();
    result.error_message = response->job().error().message();
  }
  return result;
}

absl::StatusOr<std::vector<BatchSubmission>> Client::SubmitBakeBatch(
    const std::vector<BatchItem>& items,
    const std::function<bool(size_t index, const BatchSubmission& submission)>& on_submitted) {
  std::vector<BatchSubmission> out(items.size());
  // Local checks first, per item: one bad model does not sink the batch.
  std::vector<v1::BakeParameters> parameters(items.size());
  std::vector<MeshFiles> files(items.size());
  std::vector<const MeshFiles*> to_upload;
  std::vector<size_t> upload_index;
  for (size_t i = 0; i < items.size(); ++i) {
    absl::StatusOr<v1::BakeParameters> p = ToBakeParameters(items[i].settings);
    if (!p.ok()) {
      out[i].status = p.status();
      continue;
    }
    parameters[i] = std::move(*p);
    absl::StatusOr<MeshFiles> f =
        CollectMeshFiles(items[i].model, {.follow_symlinks = items[i].settings.follow_symlinks});
    if (!f.ok()) {
      out[i].status = f.status();
      continue;
    }
    files[i] = std::move(*f);
    to_upload.push_back(&files[i]);
    upload_index.push_back(i);
  }
  absl::StatusOr<std::vector<absl::StatusOr<UploadedMesh>>> uploaded = UploadMeshes(impl_->transport(), to_upload);
  if (!uploaded.ok()) return uploaded.status();
  std::vector<std::optional<UploadedMesh>> meshes(items.size());
  for (size_t k = 0; k < upload_index.size(); ++k) {
    if ((*uploaded)[k].ok()) {
      meshes[upload_index[k]] = std::move(*(*uploaded)[k]);
    } else {
      out[upload_index[k]].status = (*uploaded)[k].status();
    }
  }

  bool stopped = false;
  for (size_t i = 0; i < items.size(); ++i) {
    if (stopped) {
      out[i].status = absl::CancelledError("not submitted: the batch stopped");
    } else if (out[i].status.ok()) {
      v1::SubmitBakeRequest request;
      *request.mutable_mesh() = meshes[i]->mesh;
      *request.mutable_parameters() = parameters[i];
      ApplySchedulingSettings(items[i].settings, &request);
      request.set_request_id(NewRequestId());
      absl::StatusOr<v1::SubmitBakeResponse> response =
          SubmitUploaded(impl_->transport(), files[i], request, &meshes[i]->stats);
      if (response.ok()) {
        out[i].result.job_id = response->job_id();
        out[i].result.cache_key = response->cache_key();
        out[i].result.cached = response->cached();
        out[i].result.upload = meshes[i]->stats;
        if (response->job().state() == v1::JOB_STATE_FAILED) {
          out[i].result.error_code = response->job().error().code();
          out[i].result.error_message = response->job().error().message();
        }
      } else {
        out[i].status = response.status();
      }
    }
    if (on_submitted && !stopped && !on_submitted(i, out[i])) stopped = true;
  }
  return out;
}

absl::StatusOr<JobUpdate> Client::WatchJob(const std::string& job_id,
                                           const std::function<void(const JobUpdate&)>& on_update) {
  Transport& transport = impl_->transport();
  std::optional<JobUpdate> last;
  // Reports only changes: a resumed stream repeats the current state.
  auto emit = [&](const JobUpdate& update) {
    if (last.has_value() && SameSnapshot(*last, update)) return;
    last = update;
    if (on_update) on_update(update);
  };
  // Failures in a row; news from the server starts the count over.
  RetryPolicy retry = transport.NewRetryPolicy();
  while (true) {
    bool got_any = false;
    absl::Status status = transport.WatchJob(job_id, [&](const v1::Job& job) {
      got_any = true;
      emit(ToJobUpdate(job));
      return !IsTerminal(last->state);
    });
    if (last.has_value() && IsTerminal(last->state)) return *last;
    if (got_any) retry.MadeProgress();
    // The stream broke (a server restart), or ended before a terminal state
    // (a server shutting down): resume, within the retry policy.
    if (status.ok()) {
      status = MakeRpcError(absl::StatusCode::kUnavailable, "WatchJob", transport.server(),
                            absl::StrCat("stream for job ", job_id, " ended before the job finished"));
    }
    if (!retry.ShouldRetry(status)) return status;
    SdkLog().debug("WatchJob {} interrupted ({}); resuming", job_id, status.ToString());
    // GetJob rides out the rest of an outage itself (the same budget), so
    // its failure is final: the budget is spent or the job is gone.
    absl::StatusOr<v1::Job> job = transport.GetJob(job_id);
    if (!job.ok()) return job.status();
    emit(ToJobUpdate(*job));
    if (IsTerminal(last->state)) return *last;
  }
}

absl::StatusOr<JobUpdate> Client::GetJob(const std::string& job_id) {
  absl::StatusOr<v1::Job> job = impl_->transport().GetJob(job_id);
  if (!job.ok()) return job.status();
  return ToJobUpdate(*job);
}

absl::StatusOr<JobUpdate> Client::CancelJob(const std::string& job_id) {
  absl::StatusOr<v1::Job> job = impl_->transport().CancelJob(job_id);
  if (!job.ok()) return job.status();
  return ToJobUpdate(*job);
}

absl::StatusOr<FetchResult> Client::Fetch(const std::string& cache_key, const std::filesystem::path& out_dir) {
  return FetchResultFiles(impl_->transport(), cache_key, out_dir);
}

absl::StatusOr<FetchResult> FetchFromFarm(const ClientOptions& options, const std::string& cache_key,
                                          const std::filesystem::path& out_dir) {
  absl::StatusOr<std::optional<FarmHttpEndpoint>> front_end = ConfiguredFarmHttp(options);
  if (!front_end.ok()) return front_end.status();
  ClientOptions over_grpc = options;
  if (front_end->has_value()) {
    absl::StatusOr<FetchResult> fetched =
        FetchResultFilesOverHttp(**front_end, cache_key, out_dir, DefaultParallelDownloads());
    // The disk's own trouble, or a cancel, would be the same over gRPC.
    if (fetched.ok() || IsLocalFailure(fetched.status()) || absl::IsCancelled(fetched.status())) {
      return fetched;
    }
    // A result that is not there is for gRPC to say, and a front end older
    // than the listing says the same but still serves the large files: no
    // warning, and the front end stays in.
    if (absl::IsNotFound(fetched.status())) {
      SdkLog().debug("event=farm_http_fetch_not_found key={} reason=\"{}\"", cache_key,
                     std::string(fetched.status().message()));
    } else {
      SdkLog().warn("event=farm_http_fetch_fallback key={} reason=\"{}\" note=\"fetching the result over gRPC\"",
                    cache_key, std::string(fetched.status().message()));
      over_grpc.farm_http = "none";
    }
  }
  absl::StatusOr<std::unique_ptr<Client>> client = Client::Connect(over_grpc);
  if (!client.ok()) return client.status();
  return (*client)->Fetch(cache_key, out_dir);
}

absl::StatusOr<std::string> Client::GetManifestJson(const std::string& cache_key) {
  absl::StatusOr<v1::Manifest> manifest = impl_->transport().GetResult(cache_key);
  if (!manifest.ok()) return manifest.status();
  if (absl::Status s = CheckManifestFiles(*manifest); !s.ok()) {
    return absl::InternalError(absl::StrCat("server ", server(), " sent a bad result for ", cache_key, ": ",
                                            s.message()));
  }
  return DownloadBlobToString(impl_->transport(), manifest->manifest_json());
}

}  // namespace impostor::sdk
