#include "client/transport.h"

#include <chrono>
#include <cstdlib>
#include <cmath>
#include <functional>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include <grpcpp/create_channel.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/support/client_interceptor.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/connection_monitor.h"
#include "client/retry.h"
#include "client/rpc_error.h"
#include "client/sdk_log.h"
#include "common/connect_error.h"
#include "common/error_reason.h"
#include "common/failover_channel.h"
#include "common/keepalive.h"
#include "common/server_list.h"
#include "common/tls_channel.h"
#include "common/tls_files.h"
#include "common/tls_peer_check.h"
#include "common/token_source.h"
#include "impostor/v1/admin_service.grpc.pb.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/bake_service.grpc.pb.h"

namespace impostor::sdk {
namespace {

// ReadBlob sends at most 1 MiB per message (64 KiB from servers of this
// version) and a manifest with 64 x 64 views is well under 1 MiB; the
// margin is for future fields.
constexpr int kMaxReceiveBytes = 64 << 20;
// An upload's deadline grows by one second per this many bytes.
constexpr double kStreamBytesPerSecond = 256 * 1024;
// How often a backoff wait on a channel that is not connected looks at its
// CancelSource: a channel's state change cannot be waited for together
// with a condition variable.
constexpr auto kCancelPollInterval = std::chrono::milliseconds(50);
// Reconnect backoff of the channel: gRPC's default grows to 120 s, so a
// server back after a restart would go unnoticed for minutes. Tries every
// second at most (a refused connection costs the server nothing); each try
// may take a second to connect.
constexpr int kInitialReconnectBackoffMs = 200;
constexpr int kMaxReconnectBackoffMs = 1000;
constexpr int kMinConnectTimeoutMs = 1000;
// The largest outage budget accepted: a day.
constexpr double kMaxOutageSeconds = 86400;

std::chrono::system_clock::time_point DeadlineAfter(double seconds) {
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(seconds));
}

// The error reason the server sent with a refusal, or "".
std::string ErrorReasonFrom(const grpc::ClientContext& context) {
  const auto& trailers = context.GetServerTrailingMetadata();
  const auto found = trailers.find(kErrorReasonMetadataKey);
  return found == trailers.end() ? std::string() : std::string(found->second.data(), found->second.size());
}

absl::Status ToStatus(const grpc::Status& status, std::string_view rpc, const std::string& server,
                      std::string_view reason) {
  if (status.ok()) return absl::OkStatus();
  return MakeRpcError(static_cast<absl::StatusCode>(static_cast<int>(status.error_code())), rpc, server,
                      status.error_message(), reason);
}

absl::Status ValidateOptions(const ClientOptions& o) {
  // !(x > 0) also catches NaN.
  if (auto targets = ParseServerList(o.server, "ClientOptions.server"); !targets.ok()) return targets.status();
  if (!(o.rpc_timeout_seconds > 0) || std::isinf(o.rpc_timeout_seconds)) {
    return absl::InvalidArgumentError(
        absl::StrCat("ClientOptions.rpc_timeout_seconds: must be > 0, got ", o.rpc_timeout_seconds));
  }
  if (auto s = ValidateKeepaliveSeconds("ClientOptions.keepalive_seconds", o.keepalive_seconds); !s.ok()) return s;
  if (!(o.connect_timeout_seconds > 0) || std::isinf(o.connect_timeout_seconds)) {
    return absl::InvalidArgumentError(
        absl::StrCat("ClientOptions.connect_timeout_seconds: must be > 0, got ", o.connect_timeout_seconds));
  }
  if (o.max_attempts < 1) {
    return absl::InvalidArgumentError(absl::StrCat("ClientOptions.max_attempts: must be >= 1, got ", o.max_attempts));
  }
  if (!(o.max_outage_seconds >= 0 && o.max_outage_seconds <= kMaxOutageSeconds)) {
    return absl::InvalidArgumentError(absl::StrCat("ClientOptions.max_outage_seconds: must be in 0..",
                                                   kMaxOutageSeconds, ", got ", o.max_outage_seconds));
  }
  return absl::OkStatus();
}

const char* StateName(grpc_connectivity_state state) {
  switch (state) {
    case GRPC_CHANNEL_IDLE: return "IDLE";
    case GRPC_CHANNEL_CONNECTING: return "CONNECTING";
    case GRPC_CHANNEL_READY: return "READY";
    case GRPC_CHANNEL_TRANSIENT_FAILURE: return "TRANSIENT_FAILURE";
    case GRPC_CHANNEL_SHUTDOWN: return "SHUTDOWN";
  }
  return "?";
}

// Why a channel in TRANSIENT_FAILURE cannot connect, from the last
// connection error it keeps (a call that does not wait for READY fails at
// once with it): common/connect_error.h.
ConnectFailure DescribeConnectFailure(grpc::Channel& channel, bool uses_tls,
                                      const std::function<std::string()>& diagnose_certificate) {
  v1::BakeService::Stub probe(std::shared_ptr<grpc::ChannelInterface>(&channel, [](grpc::ChannelInterface*) {}));
  grpc::ClientContext context;
  context.set_wait_for_ready(false);
  context.set_deadline(DeadlineAfter(1.0));
  v1::GetJobRequest request;
  v1::Job job;
  const grpc::Status status = probe.GetJob(&context, request, &job);
  SdkLog().debug("connect probe: {} {}", static_cast<int>(status.error_code()), status.error_message());
  return ExplainConnectError(status.error_message(), uses_tls, diagnose_certificate);
}

// Waits until `channel` is READY: "" then, else why not, as a sentence for
// Connect's error. Gives up early when the connection fails outright (refused,
// a name that does not resolve, not a gRPC server): a CI job or a game should
// hear "nobody there" in about a second, not after the whole timeout. gRPC
// keeps the channel in TRANSIENT_FAILURE while it retries, so after the
// first failure allow one more second (a server that is just starting) and
// then ask why. A server that accepts but does not answer (stopped, or
// overloaded) gets the whole timeout.
std::string WaitForReady(grpc::Channel& channel, double timeout_seconds, bool uses_tls,
                         const std::function<std::string()>& diagnose_certificate) {
  const auto deadline = DeadlineAfter(timeout_seconds);
  bool failed_once = false;
  std::optional<ConnectFailure> failure;
  grpc_connectivity_state state = channel.GetState(/*try_to_connect=*/true);
  while (state != GRPC_CHANNEL_READY) {
    auto wait_until = deadline;
    if (state == GRPC_CHANNEL_TRANSIENT_FAILURE && !(failure && failure->silent)) {
      if (failed_once) {
        failure = DescribeConnectFailure(channel, uses_tls, diagnose_certificate);
        if (!failure->silent) break;
      }
      failed_once = true;
      if (!failure) wait_until = std::min(deadline, DeadlineAfter(1.0));
    }
    if (!channel.WaitForStateChange(state, wait_until)) {
      if (std::chrono::system_clock::now() >= deadline) break;
      continue;
    }
    state = channel.GetState(/*try_to_connect=*/true);
  }
  if (state == GRPC_CHANNEL_READY) return "";
  if (failure) return failure->sentence;
  if (state == GRPC_CHANNEL_TRANSIENT_FAILURE) {
    return DescribeConnectFailure(channel, uses_tls, diagnose_certificate).sentence;
  }
  return absl::StrCat("no impostor server answered within ", absl::SixDigits(timeout_seconds), " s (channel ",
                      StateName(state), ")");
}

// Reports every RPC to TransportHooks::on_rpc as its first message leaves.
class RpcObserver : public grpc::experimental::Interceptor {
 public:
  RpcObserver(const TransportHooks* hooks, std::string method) : hooks_(hooks), method_(std::move(method)) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      hooks_->on_rpc(method_);
    }
    methods->Proceed();
  }

 private:
  const TransportHooks* hooks_;
  std::string method_;
};

class RpcObserverFactory : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit RpcObserverFactory(const TransportHooks* hooks) : hooks_(hooks) {}
  grpc::experimental::Interceptor* CreateClientInterceptor(grpc::experimental::ClientRpcInfo* info) override {
    return new RpcObserver(hooks_, info->method());
  }

 private:
  const TransportHooks* hooks_;
};

}  // namespace

struct Transport::Stubs {
  explicit Stubs(const ClientOptions& options)
      : monitor(options.server, options.max_outage_seconds, options.on_connection_change) {}
  ConnectionMonitor monitor;
  // Outlives the channel's interceptors, which point at it.
  TransportHooks hooks;
  // A channel per address of options.server (issue 15: several replicas).
  std::unique_ptr<FailoverChannel> channels;
  // Identity (issue 14): "Bearer <token>", or empty for no token.
  std::string authorization;
  void AddToken(grpc::ClientContext& context) const {
    if (!authorization.empty()) context.AddMetadata("authorization", authorization);
  }
};

Transport::Transport(ClientOptions options, std::unique_ptr<Stubs> stubs)
    : options_(std::move(options)), stubs_(std::move(stubs)) {}

Transport::~Transport() = default;

absl::StatusOr<std::unique_ptr<Transport>> Transport::Connect(const ClientOptions& options,
                                                              const TransportHooks& hooks) {
  if (absl::Status s = ValidateOptions(options); !s.ok()) return s;
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(kMaxReceiveBytes);
  // A quiet WatchJob over a dead link fails over within keepalive + its
  // timeout (common/keepalive.h).
  ApplyClientKeepalive(options.keepalive_seconds, args);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, kInitialReconnectBackoffMs);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, kMaxReconnectBackoffMs);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, kMinConnectTimeoutMs);
  // Transport security (README "Securing a farm: TLS").
  const ClientTls tls{.files = {.ca = options.tls_ca_file, .cert = options.tls_cert_file, .key = options.tls_key_file},
                      .server_name = options.tls_server_name};
  absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> credentials =
      MakeChannelCredentials(tls,
                             {.files = {.ca = "ClientOptions.tls_ca_file",
                                        .cert = "ClientOptions.tls_cert_file",
                                        .key = "ClientOptions.tls_key_file"},
                              .server_name = "ClientOptions.tls_server_name"},
                             &args);
  if (!credentials.ok()) return credentials.status();

  auto stubs = std::make_unique<Stubs>(options);
  stubs->hooks = hooks;
  auto token = ResolveToken(options.token_file, options.token, std::getenv(kTokenEnvVar));
  if (!token.ok()) return token.status();
  if (!token->empty()) stubs->authorization = "Bearer " + *token;
  // Each address gets channels of its own (failover_channel.h): a replaced
  // channel must not inherit a dead connection from a shared pool.
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  absl::StatusOr<std::vector<std::string>> targets = ParseServerList(options.server, "ClientOptions.server");
  if (!targets.ok()) return targets.status();
  const Stubs* raw = stubs.get();
  std::shared_ptr<grpc::ChannelCredentials> channel_credentials = *credentials;
  stubs->channels = std::make_unique<FailoverChannel>(
      *targets, [raw, channel_credentials, args](const std::string& target) -> std::shared_ptr<grpc::Channel> {
        if (!raw->hooks.on_rpc) return grpc::CreateCustomChannel(target, channel_credentials, args);
        std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
        interceptors.push_back(std::make_unique<RpcObserverFactory>(&raw->hooks));
        return grpc::experimental::CreateCustomChannelWithInterceptors(target, channel_credentials, args,
                                                                       std::move(interceptors));
      });
  // The first address that answers becomes the current one; each later
  // address gets an even share of what is left of the connect timeout, so
  // a list as a whole never waits longer than one address would.
  const auto deadline = DeadlineAfter(options.connect_timeout_seconds);
  std::vector<std::string> reasons;
  for (size_t tried = 0; tried < stubs->channels->size(); ++tried) {
    const FailoverChannel::Route route = stubs->channels->Current();
    const std::string& target = stubs->channels->target(route.index);
    const double left = std::chrono::duration<double>(deadline - std::chrono::system_clock::now()).count();
    const double share = std::max(0.0, left) / static_cast<double>(stubs->channels->size() - tried);
    const auto diagnose_certificate = [&tls, &target] {
      absl::StatusOr<std::string> ca = ReadCertificateFile("--tls-ca", tls.files.ca);
      return ca.ok() ? DiagnoseServerCertificate(target, *ca, tls.server_name, 2.0) : std::string();
    };
    std::string reason = WaitForReady(*route.channel, share, UsesTls(tls), diagnose_certificate);
    if (reason.empty()) {
      stubs->channels->NoteAnswer(route);
      SdkLog().debug("connected to impostor server at {}", target);
      return std::unique_ptr<Transport>(new Transport(options, std::move(stubs)));
    }
    reasons.push_back(stubs->channels->size() == 1 ? reason : absl::StrCat(target, ": ", reason));
    stubs->channels->NoteFailure(route, grpc::StatusCode::UNAVAILABLE);
  }
  return MakeRpcError(absl::StatusCode::kUnavailable, "Connect", options.server, absl::StrJoin(reasons, "; "));
}

ConnectionMonitor& Transport::monitor() { return stubs_->monitor; }

absl::Status Transport::Note(const grpc::Status& received, std::string_view rpc, const Route& route,
                             const grpc::ClientContext& context, bool* try_next_now, bool answered) {
  const std::string& target = stubs_->channels->target(route.index);
  // Every call that cancels itself (TryCancel) returns before it gets here,
  // so a CANCELLED here came from the server: one that stops gracefully
  // cancels the calls still in flight. That is an outage like any other
  // restart, to ride out within the retry policy, not a final answer.
  const grpc::Status status =
      received.error_code() == grpc::StatusCode::CANCELLED
          ? grpc::Status(grpc::StatusCode::UNAVAILABLE,
                         absl::StrCat("the server cancelled the call, as one that is stopping does (",
                                      received.error_message(), ")"))
          : received;
  absl::Status error = ToStatus(status, rpc, target, status.ok() ? std::string() : ErrorReasonFrom(context));
  // Another replica not yet tried since the last answer is no outage: the
  // call moves on to it at once.
  const bool next_now = stubs_->channels->NoteFailure(route, status.error_code());
  if (try_next_now != nullptr) *try_next_now = next_now;
  switch (status.error_code()) {
    case grpc::StatusCode::UNAVAILABLE:
      if (!next_now && !answered) stubs_->monitor.NoteFailure(error);
      break;
    // Said by our own side (a deadline), not by the server.
    case grpc::StatusCode::DEADLINE_EXCEEDED: break;
    default: NoteAnswer(route); break;
  }
  return error;
}

void Transport::WaitForServer(std::chrono::duration<double> at_most, const CancelSource* cancel) {
  const auto until = std::chrono::system_clock::now() +
                     std::chrono::duration_cast<std::chrono::system_clock::duration>(at_most);
  const std::shared_ptr<grpc::Channel> channel = stubs_->channels->Current().channel;
  if (channel->GetState(/*try_to_connect=*/false) != GRPC_CHANNEL_READY) {
    // Not back yet: wait for the connection, in slices when a cancel may
    // end the wait early.
    while (true) {
      if (cancel != nullptr && cancel->cancelled()) return;
      const auto now = std::chrono::system_clock::now();
      if (now >= until) return;
      const auto slice_end =
          cancel == nullptr ? until
                            : std::min(until, now + std::chrono::duration_cast<std::chrono::system_clock::duration>(
                                                        kCancelPollInterval));
      if (channel->WaitForConnected(slice_end)) return;
    }
  }
  // Connected already (a live server that answered UNAVAILABLE): the whole
  // backoff.
  const auto left = until - std::chrono::system_clock::now();
  if (left <= left.zero()) return;
  if (cancel != nullptr) {
    cancel->WaitFor(left);
  } else {
    std::this_thread::sleep_until(until);
  }
}

RetryPolicy Transport::NewRetryPolicy(const CancelSource* cancel) {
  return RetryPolicy(
      options_, stubs_->monitor,
      [this, cancel](std::chrono::duration<double> at_most) { WaitForServer(at_most, cancel); }, cancel);
}

void Transport::NoteAnswer(const Route& route) {
  stubs_->monitor.NoteAnswer();
  stubs_->channels->NoteAnswer(route);
}

// Runs a unary call with a fresh context per attempt, retried as RetryPolicy
// decides; a failure that moves calls on to a replica not yet tried is
// tried there at once, outside that policy (at most once per address).
template <typename Response, typename Call>
absl::StatusOr<Response> Transport::CallUnary(std::string_view rpc, Call call, const CancelSource* cancel) {
  RetryPolicy retry = NewRetryPolicy(cancel);
  size_t moved_on = 0;
  while (true) {
    if (cancel != nullptr && cancel->cancelled()) return cancel->error();
    grpc::ClientContext context;
    stubs_->AddToken(context);
    context.set_deadline(DeadlineAfter(options_.rpc_timeout_seconds));
    if (!options_.client_id.empty()) context.AddMetadata("impostor-client-id", options_.client_id);
    const Route route = stubs_->channels->Current();
    Response response;
    grpc::Status status;
    {
      CancelSource::Registration registration;
      if (cancel != nullptr) registration = cancel->OnCancel([&context] { context.TryCancel(); });
      status = call(route, &context, &response);
    }
    // Cancelled by our side: not the server's answer (see Note).
    if (!status.ok() && cancel != nullptr && cancel->cancelled()) return cancel->error();
    bool try_next_now = false;
    absl::Status error = Note(status, rpc, route, context, &try_next_now);
    if (error.ok()) return response;
    if (try_next_now && ++moved_on < stubs_->channels->size()) {
      SdkLog().debug("{} failed on {}: {}; trying {}", std::string(rpc), stubs_->channels->target(route.index),
                     error.ToString(), stubs_->channels->target(stubs_->channels->Current().index));
      continue;
    }
    moved_on = 0;
    if (!retry.ShouldRetry(error)) return retry.cancelled() ? cancel->error() : error;
    SdkLog().debug("{} failed ({} in a row): {}; retrying", std::string(rpc), retry.failures(), error.ToString());
  }
}

absl::StatusOr<v1::FindMissingBlobsResponse> Transport::FindMissingBlobs(
    const v1::FindMissingBlobsRequest& request) {
  return CallUnary<v1::FindMissingBlobsResponse>("FindMissingBlobs", [&](const Route& route, auto* ctx, auto* resp) {
    return v1::AssetService::Stub(route.channel).FindMissingBlobs(ctx, request, resp);
  });
}

absl::StatusOr<v1::SubmitBakeResponse> Transport::SubmitBake(const v1::SubmitBakeRequest& request) {
  return CallUnary<v1::SubmitBakeResponse>("SubmitBake", [&](const Route& route, auto* ctx, auto* resp) {
    return v1::BakeService::Stub(route.channel).SubmitBake(ctx, request, resp);
  });
}

absl::StatusOr<v1::Job> Transport::GetJob(const std::string& job_id) {
  v1::GetJobRequest request;
  request.set_job_id(job_id);
  return CallUnary<v1::Job>("GetJob",
                            [&](const Route& route, auto* ctx, auto* resp) { return v1::BakeService::Stub(route.channel).GetJob(ctx, request, resp); });
}

absl::StatusOr<v1::Job> Transport::CancelJob(const std::string& job_id) {
  v1::CancelJobRequest request;
  request.set_job_id(job_id);
  return CallUnary<v1::Job>("CancelJob",
                            [&](const Route& route, auto* ctx, auto* resp) { return v1::BakeService::Stub(route.channel).CancelJob(ctx, request, resp); });
}

absl::StatusOr<v1::Manifest> Transport::GetResult(const std::string& cache_key, const CancelSource* cancel) {
  v1::GetResultRequest request;
  request.set_cache_key(cache_key);
  return CallUnary<v1::Manifest>(
      "GetResult",
      [&](const Route& route, auto* ctx, auto* resp) {
        return v1::AssetService::Stub(route.channel).GetResult(ctx, request, resp);
      },
      cancel);
}

absl::StatusOr<v1::LookupBakeResponse> Transport::LookupBake(const v1::SubmitBakeRequest& request) {
  return CallUnary<v1::LookupBakeResponse>("LookupBake", [&](const Route& route, auto* ctx, auto* resp) {
    return v1::BakeService::Stub(route.channel).LookupBake(ctx, request, resp);
  });
}

absl::StatusOr<v1::PurgeWorkerResultsResponse> Transport::PurgeWorkerResults(
    const v1::PurgeWorkerResultsRequest& request) {
  // A stub per call: administration is rare.
  return CallUnary<v1::PurgeWorkerResultsResponse>("PurgeWorkerResults", [&](const Route& route, auto* ctx,
                                                                             auto* resp) {
    return v1::AdminService::Stub(route.channel).PurgeWorkerResults(ctx, request, resp);
  });
}

absl::StatusOr<v1::UploadBlobResponse> Transport::UploadBlob(const v1::Digest& digest,
                                                             const ChunkSource& next_chunk) {
  grpc::ClientContext context;
  stubs_->AddToken(context);
  context.set_deadline(DeadlineAfter(options_.rpc_timeout_seconds +
                                     static_cast<double>(digest.size_bytes()) / kStreamBytesPerSecond));
  v1::UploadBlobResponse response;
  const Route route = stubs_->channels->Current();
  v1::AssetService::Stub stub(route.channel);
  std::unique_ptr<grpc::ClientWriter<v1::UploadBlobRequest>> writer = stub.UploadBlob(&context, &response);
  v1::UploadBlobRequest message;
  *message.mutable_digest() = digest;
  absl::Status local_error;
  bool first = true;
  while (true) {
    std::string* data = message.mutable_data();
    data->clear();
    absl::StatusOr<bool> more = next_chunk(data);
    if (!more.ok()) {
      local_error = more.status();
      break;
    }
    // An empty blob still needs one message carrying the digest.
    if (!*more && !first) break;
    if (!writer->Write(message)) break;  // the stream broke; Finish says why
    first = false;
    message.clear_digest();
    if (!*more) break;
  }
  if (!local_error.ok()) {
    context.TryCancel();
    writer->Finish();
    return local_error;
  }
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  if (absl::Status error = Note(status, "UploadBlob", route, context); !error.ok()) return error;
  return response;
}

absl::Status Transport::ReadBlob(const v1::Digest& digest, int64_t offset,
                                 const std::function<absl::Status(const v1::ReadBlobResponse&)>& on_chunk,
                                 const CancelSource* cancel) {
  if (cancel != nullptr && cancel->cancelled()) return cancel->error();
  grpc::ClientContext context;
  stubs_->AddToken(context);
  v1::ReadBlobRequest request;
  *request.mutable_digest() = digest;
  request.set_offset(offset);
  const Route route = stubs_->channels->Current();
  v1::AssetService::Stub stub(route.channel);
  // An async reader on a queue of its own: each step is waited for with the
  // stall deadline, which a sync reader cannot do. No deadline on the call:
  // gRPC has none per message.
  grpc::CompletionQueue queue;
  std::unique_ptr<grpc::ClientAsyncReader<v1::ReadBlobResponse>> reader =
      stub.PrepareAsyncReadBlob(&context, request, &queue);
  CancelSource::Registration registration;
  if (cancel != nullptr) registration = cancel->OnCancel([&context] { context.TryCancel(); });
  const auto stall_limit = std::chrono::duration_cast<std::chrono::system_clock::duration>(
      std::chrono::duration<double>(options_.rpc_timeout_seconds));
  bool stalled = false;
  // Waits for the one operation in flight. Once stall_limit passes without
  // it, cancels the call, which then completes it at once (not ok).
  const auto await = [&](void* expected) {
    void* tag = nullptr;
    bool ok = false;
    const auto deadline = std::chrono::system_clock::now() + stall_limit;
    while (true) {
      const grpc::CompletionQueue::NextStatus next =
          stalled ? (queue.Next(&tag, &ok) ? grpc::CompletionQueue::GOT_EVENT : grpc::CompletionQueue::SHUTDOWN)
                  : queue.AsyncNext(&tag, &ok, deadline);
      if (next == grpc::CompletionQueue::TIMEOUT) {
        stalled = true;
        context.TryCancel();
        continue;
      }
      if (next == grpc::CompletionQueue::SHUTDOWN) return false;  // not before Shutdown below
      if (tag == expected) return ok;
    }
  };
  int tags[3];  // distinct addresses: start, read, finish
  reader->StartCall(&tags[0]);
  bool answered = false;  // a message arrived on this call
  int64_t received = 0;
  absl::Status local_error;
  if (await(&tags[0])) {
    v1::ReadBlobResponse message;
    while (true) {
      reader->Read(&message, &tags[1]);
      if (!await(&tags[1])) break;
      answered = true;
      received += static_cast<int64_t>(message.data().size());
      NoteAnswer(route);
      local_error = on_chunk(message);
      if (!local_error.ok()) {
        context.TryCancel();
        break;
      }
    }
  }
  grpc::Status status;
  reader->Finish(&status, &tags[2]);
  {
    void* tag = nullptr;
    bool ok = false;
    while (queue.Next(&tag, &ok) && tag != &tags[2]) {
    }
  }
  queue.Shutdown();
  {
    void* tag = nullptr;
    bool ok = false;
    while (queue.Next(&tag, &ok)) {
    }
  }
  registration.Reset();
  if (!local_error.ok()) return local_error;
  if (status.ok()) return Note(status, "ReadBlob", route, context);
  // Every cancel of our own side ends here, before Note, which takes a
  // CANCELLED for the server's.
  if (cancel != nullptr && cancel->cancelled()) return cancel->error();
  if (stalled && (status.error_code() == grpc::StatusCode::CANCELLED ||
                  status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)) {
    // The watchdog's own cancel: the link (or the server) stalled.
    const grpc::Status stall(
        grpc::StatusCode::DEADLINE_EXCEEDED,
        absl::StrCat("the link stalled: no bytes arrived for ", absl::SixDigits(options_.rpc_timeout_seconds),
                     " s (rpc_timeout_seconds)",
                     answered ? absl::StrCat(", after ", received, " bytes of this stream") : std::string()));
    return Note(stall, "ReadBlob", route, context);
  }
  return Note(status, "ReadBlob", route, context, nullptr, answered);
}

absl::Status Transport::WatchJob(const std::string& job_id, const std::function<bool(const v1::Job&)>& on_job) {
  grpc::ClientContext context;
  stubs_->AddToken(context);
  v1::WatchJobRequest request;
  request.set_job_id(job_id);
  const Route route = stubs_->channels->Current();
  v1::BakeService::Stub stub(route.channel);
  std::unique_ptr<grpc::ClientReader<v1::Job>> reader = stub.WatchJob(&context, request);
  v1::Job job;
  while (reader->Read(&job)) {
    NoteAnswer(route);
    if (!on_job(job)) {
      // We have what we came for; do not wait for the server to close.
      context.TryCancel();
      reader->Finish();
      return absl::OkStatus();
    }
  }
  const grpc::Status status = reader->Finish();
  return Note(status, "WatchJob", route, context);
}

}  // namespace impostor::sdk
