#include "client/transport/transport.h"

#include <algorithm>
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
#include "client/transport/client_options_check.h"
#include "client/transport/connection_monitor.h"
#include "client/transport/farm_http_choice.h"
#include "client/transport/farm_http_url.h"
#include "client/transport/retry.h"
#include "client/transport/rpc_error.h"
#include "client/base/sdk_log.h"
#include "common/net/connect_error.h"
#include "common/error_reason.h"
#include "common/net/failover_channel.h"
#include "common/net/keepalive.h"
#include "common/net/transfer_window.h"
#include "common/net/server_list.h"
#include "common/net/tls_channel.h"
#include "common/net/tls_files.h"
#include "common/net/tls_peer_check.h"
#include "common/net/token_source.h"
#include "impostor/v1/admin_service.grpc.pb.h"
#include "impostor/v1/asset_service.grpc.pb.h"
#include "impostor/v1/bake_service.grpc.pb.h"

namespace impostor::sdk {
namespace {

// ReadBlob sends at most 1 MiB per message (64 KiB from servers of this
// version) and a manifest with 64 x 64 views is well under 1 MiB; the
// margin is for future fields.
constexpr int kMaxReceiveBytes = 64 << 20;
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

std::chrono::system_clock::time_point DeadlineAfter(double seconds) {
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(seconds));
}

// The most bytes a link may hold after the client has handed them over:
// Linux's largest TCP send buffer by default (net.ipv4.tcp_wmem), which a
// loopback connection reaches at once and a real uplink on a deep queue
// approaches. An upload's last bytes may sit there, unseen, until they cross.
constexpr int64_t kMaxBytesTheLinkHolds = int64_t{4} << 20;

// Runs the steps of one streaming call (start, each read or write, writes
// done, finish) on a completion queue of its own, one step in flight at a
// time, and gives up on a step that waits too long, or once `cancel` (may
// be null) is cancelled: a stream's only watchdog, since gRPC has no
// deadline per message and a deadline on the whole call would cut a slow
// link that keeps moving. Giving up cancels the call and returns at once:
// the step may stay pending for a while (see UploadCall), so the call must
// still be finished and the queue drained (Close) before it is destroyed.
//
// Declared before the call's reader or writer, so the queue outlives it.
// One thread at a time.
class StallWatch {
 public:
  using Duration = std::chrono::duration<double>;

  StallWatch(grpc::ClientContext& context, const CancelSource* cancel) : context_(context), cancel_(cancel) {}
  StallWatch(const StallWatch&) = delete;
  StallWatch& operator=(const StallWatch&) = delete;

  grpc::CompletionQueue* queue() { return &queue_; }

  // Waits for the step tagged `tag` until `at_most` has passed and returns
  // its ok: false when the call broke, or when the watch gave up (then
  // stalled() or cancelled() says why, and the step may still be pending).
  // Once it gave up, waits for `tag` without limit: for Finish, which a
  // cancelled call completes at once.
  bool Await(void* tag, Duration at_most) {
    return AwaitUntil(tag, std::chrono::system_clock::now() +
                               std::chrono::duration_cast<std::chrono::system_clock::duration>(at_most));
  }
  bool AwaitUntil(void* tag, std::chrono::system_clock::time_point deadline) {
    void* got = nullptr;
    bool ok = false;
    while (true) {
      if (gave_up()) {
        if (!queue_.Next(&got, &ok)) return false;  // not before Close
        if (got == tag) return ok;
        continue;
      }
      // A CancelSource cannot wake a completion queue: look at it now and
      // then (its own callback has cancelled the call already).
      const auto now = std::chrono::system_clock::now();
      const auto until =
          cancel_ == nullptr ? deadline
                             : std::min(deadline, now + std::chrono::duration_cast<std::chrono::system_clock::duration>(
                                                            kCancelPollInterval));
      const grpc::CompletionQueue::NextStatus next = queue_.AsyncNext(&got, &ok, until);
      if (next == grpc::CompletionQueue::GOT_EVENT) {
        if (got == tag) return ok;
        continue;
      }
      if (next == grpc::CompletionQueue::SHUTDOWN) return false;  // not before Close
      if (cancel_ != nullptr && cancel_->cancelled()) {
        cancelled_ = true;
        context_.TryCancel();
        return false;
      }
      if (std::chrono::system_clock::now() >= deadline) {
        stalled_ = true;
        context_.TryCancel();
        return false;
      }
    }
  }

  // After the Finish step was started: shuts the queue down and waits for
  // every step still pending.
  void Close() {
    queue_.Shutdown();
    void* got = nullptr;
    bool ok = false;
    while (queue_.Next(&got, &ok)) {
    }
  }

  // The watch cancelled the call: a step waited too long.
  bool stalled() const { return stalled_; }
  // The watch found the CancelSource cancelled.
  bool cancelled() const { return cancelled_; }
  bool gave_up() const { return stalled_ || cancelled_; }

 private:
  grpc::ClientContext& context_;
  const CancelSource* const cancel_;
  grpc::CompletionQueue queue_;
  bool stalled_ = false;
  bool cancelled_ = false;
};

// Everything one UploadBlob call's pending steps use, so that it can be
// finished away from the caller. A write that the link has not taken when
// the call is cancelled stays pending until the socket takes its bytes or
// the connection gives up (TCP_USER_TIMEOUT, set from the keepalive: about
// 10 s on a dead link); gRPC completes no step of a cancelled call before
// that. The caller is answered at once and the call is finished by
// FinishAbandoned on a thread of its own.
struct UploadCall {
  grpc::ClientContext context;
  StallWatch watch;
  v1::UploadBlobResponse response;
  v1::UploadBlobRequest message;
  grpc::Status status;
  std::unique_ptr<grpc::ClientAsyncWriter<v1::UploadBlobRequest>> writer;
  int tags[4];  // distinct addresses: start, write, writes done, finish
  bool finish_started = false;

  explicit UploadCall(const CancelSource* cancel) : watch(context, cancel) {}
};

// Finishes a call the caller has given up on, on a detached thread that
// waits for its pending steps and frees it. The call holds its channel, so
// it may outlive the Transport.
void FinishAbandoned(std::unique_ptr<UploadCall> call) {
  if (!call->finish_started) call->writer->Finish(&call->status, &call->tags[3]);
  std::thread([call = std::move(call)] { call->watch.Close(); }).detach();
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
  // The farm's HTTP front end: given, or advertised by the farm.
  std::unique_ptr<FarmHttpChoice> farm_http;
  mutable FarmHttpRecord farm_http_record;
  void AddToken(grpc::ClientContext& context) const {
    if (!authorization.empty()) context.AddMetadata("authorization", authorization);
  }
};

Transport::Transport(ClientOptions options, std::unique_ptr<Stubs> stubs)
    : options_(std::move(options)), stubs_(std::move(stubs)) {}

Transport::~Transport() = default;

const std::string& Transport::authorization() const { return stubs_->authorization; }
std::string Transport::farm_http() const { return stubs_->farm_http->Current(); }
Transport::FarmHttpRecord& Transport::farm_http_record() const { return stubs_->farm_http_record; }

absl::StatusOr<std::unique_ptr<Transport>> Transport::Connect(const ClientOptions& options,
                                                              const TransportHooks& hooks) {
  if (absl::Status s = CheckClientOptions(options); !s.ok()) return s;
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(kMaxReceiveBytes);
  // A quiet WatchJob over a dead link fails over within keepalive + its
  // timeout (common/net/keepalive.h).
  ApplyClientKeepalive(options.keepalive_seconds, args);
  // Downloads at full speed from the first byte (transfer_window.h).
  ApplyClientTransferWindow(args);
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
  absl::StatusOr<std::string> farm_http = ResolveFarmHttp(options.farm_http, "ClientOptions.farm_http",
                                                          std::getenv(kFarmHttpEnvVar), !options.tls_ca_file.empty());
  if (!farm_http.ok()) return farm_http.status();
  stubs->farm_http = std::make_unique<FarmHttpChoice>(
      std::move(*farm_http), FarmHttpTurnedOff(options.farm_http, std::getenv(kFarmHttpEnvVar)),
      !options.tls_ca_file.empty());
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

absl::Status Transport::NoteStall(std::string_view rpc, const Route& route, std::string_view why) {
  // As Note does for DEADLINE_EXCEEDED: nothing for the monitor (no answer
  // from the server), the failover may move on.
  stubs_->channels->NoteFailure(route, grpc::StatusCode::DEADLINE_EXCEEDED);
  return MakeRpcError(absl::StatusCode::kDeadlineExceeded, rpc, stubs_->channels->target(route.index),
                      "the link stalled: " + std::string(why));
}

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
absl::StatusOr<Response> Transport::CallUnary(std::string_view rpc, Call call, const CancelSource* cancel,
                                              double timeout_seconds) {
  RetryPolicy retry = NewRetryPolicy(cancel);
  size_t moved_on = 0;
  while (true) {
    if (cancel != nullptr && cancel->cancelled()) return cancel->error();
    grpc::ClientContext context;
    stubs_->AddToken(context);
    context.set_deadline(DeadlineAfter(timeout_seconds > 0 ? timeout_seconds : options_.rpc_timeout_seconds));
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
    const v1::FindMissingBlobsRequest& request, const CancelSource* cancel) {
  return CallUnary<v1::FindMissingBlobsResponse>(
      "FindMissingBlobs",
      [&](const Route& route, auto* ctx, auto* resp) {
        return v1::AssetService::Stub(route.channel).FindMissingBlobs(ctx, request, resp);
      },
      cancel);
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
        grpc::Status status = v1::AssetService::Stub(route.channel).GetResult(ctx, request, resp);
        if (status.ok()) {
          const auto& metadata = ctx->GetServerInitialMetadata();
          const auto it = metadata.find(kFarmHttpMetadataKey);
          if (it != metadata.end()) stubs_->farm_http->Learn(absl::string_view(it->second.data(), it->second.size()));
        }
        return status;
      },
      cancel);
}

absl::StatusOr<v1::BatchReadBlobsResponse> Transport::BatchReadBlobs(const v1::BatchReadBlobsRequest& request,
                                                                    const CancelSource* cancel) {
  return CallUnary<v1::BatchReadBlobsResponse>(
      "BatchReadBlobs",
      [&](const Route& route, auto* ctx, auto* resp) {
        return v1::AssetService::Stub(route.channel).BatchReadBlobs(ctx, request, resp);
      },
      cancel);
}

absl::StatusOr<v1::BatchUpdateBlobsResponse> Transport::BatchUpdateBlobs(const v1::BatchUpdateBlobsRequest& request,
                                                                        const CancelSource* cancel) {
  int64_t bytes = 0;
  for (const v1::BatchUpdateBlobsRequest::Request& blob : request.requests()) {
    bytes += static_cast<int64_t>(blob.data().size());
  }
  const int64_t messages = (bytes + kBatchUpdateMessageBytes - 1) / kBatchUpdateMessageBytes;
  return CallUnary<v1::BatchUpdateBlobsResponse>(
      "BatchUpdateBlobs",
      [&](const Route& route, auto* ctx, auto* resp) {
        return v1::AssetService::Stub(route.channel).BatchUpdateBlobs(ctx, request, resp);
      },
      cancel, options_.rpc_timeout_seconds * static_cast<double>(1 + messages));
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

absl::StatusOr<v1::QueryUploadResponse> Transport::QueryUpload(const v1::Digest& digest,
                                                               const CancelSource* cancel) {
  v1::QueryUploadRequest request;
  *request.mutable_digest() = digest;
  return CallUnary<v1::QueryUploadResponse>(
      "QueryUpload",
      [&](const Route& route, auto* ctx, auto* resp) {
        return v1::AssetService::Stub(route.channel).QueryUpload(ctx, request, resp);
      },
      cancel);
}

absl::StatusOr<v1::UploadBlobResponse> Transport::UploadBlob(const v1::Digest& digest,
                                                             const ChunkSource& next_chunk,
                                                             const CancelSource* cancel, int64_t offset) {
  if (cancel != nullptr && cancel->cancelled()) return cancel->error();
  auto call = std::make_unique<UploadCall>(cancel);
  stubs_->AddToken(call->context);
  const Route route = stubs_->channels->Current();
  v1::AssetService::Stub stub(route.channel);
  // No deadline on the call: the watch bounds each step instead.
  const StallWatch::Duration stall_limit(options_.rpc_timeout_seconds);
  StallWatch& watch = call->watch;
  call->writer = stub.PrepareAsyncUploadBlob(&call->context, &call->response, watch.queue());
  CancelSource::Registration registration;
  if (cancel != nullptr) {
    registration = cancel->OnCancel([context = &call->context] { context->TryCancel(); });
  }
  int* const tags = call->tags;
  call->writer->StartCall(&tags[0]);
  int64_t sent = 0;             // blob bytes the link has taken
  int64_t largest_message = 1;  // bytes
  bool all_sent = false;        // every message was taken; the answer is awaited
  absl::Status local_error;
  // A message is taken once it is in this host's send buffer (write
  // through), not when HTTP/2 flow control lets it go: the server's window
  // is megabytes, which a slow link would "take" at once, leaving nothing
  // to watch.
  const grpc::WriteOptions write_through = grpc::WriteOptions().set_write_through();
  if (watch.Await(&tags[0], stall_limit)) {
    v1::UploadBlobRequest& message = call->message;
    *message.mutable_digest() = digest;
    message.set_offset(offset);
    bool first = true;
    while (true) {
      std::string* data = message.mutable_data();
      data->clear();
      absl::StatusOr<bool> more = next_chunk(data);
      if (!more.ok()) {
        local_error = more.status();
        call->context.TryCancel();
        break;
      }
      // An empty blob still needs one message carrying the digest.
      if (!*more && !first) {
        all_sent = true;
        break;
      }
      call->writer->Write(message, write_through, &tags[1]);
      if (!watch.Await(&tags[1], stall_limit)) break;  // broke, stalled or cancelled
      sent += static_cast<int64_t>(message.data().size());
      largest_message = std::max<int64_t>(largest_message, static_cast<int64_t>(message.data().size()));
      first = false;
      message.clear_digest();
      message.clear_offset();
    }
  }
  // What the link still holds crosses unseen (the server answers once it
  // has every byte): each message it may hold gets the time any message
  // gets, and the answer once more.
  const int64_t messages_held = (std::min(sent, kMaxBytesTheLinkHolds) + largest_message - 1) / largest_message;
  const StallWatch::Duration answer_limit = stall_limit * static_cast<double>(1 + messages_held);
  const auto answer_deadline = std::chrono::system_clock::now() +
                               std::chrono::duration_cast<std::chrono::system_clock::duration>(answer_limit);
  if (all_sent && !watch.gave_up()) {
    call->writer->WritesDone(&tags[2]);
    watch.AwaitUntil(&tags[2], answer_deadline);
  }
  if (!watch.gave_up()) {
    call->writer->Finish(&call->status, &tags[3]);
    call->finish_started = true;
    watch.AwaitUntil(&tags[3], answer_deadline);
  }
  registration.Reset();
  if (watch.gave_up()) {
    const bool stalled = watch.stalled();
    FinishAbandoned(std::move(call));
    if (!stalled) return cancel->error();
    return NoteStall(
        "UploadBlob", route,
        all_sent ? absl::StrCat("no answer for ", absl::SixDigits(answer_limit.count()), " s (rpc_timeout_seconds, ",
                                absl::SixDigits(options_.rpc_timeout_seconds), " s, times the ", messages_held,
                                " message(s) the link may have held, plus one) after all ", sent,
                                " bytes of the blob were sent")
                 : absl::StrCat("it took nothing for ", absl::SixDigits(options_.rpc_timeout_seconds),
                                " s (rpc_timeout_seconds), with ", sent, " of the blob's ", digest.size_bytes(),
                                " bytes sent"));
  }
  watch.Close();
  if (!local_error.ok()) return local_error;
  // Cancelled by our side just as the call ended: not the server's answer
  // (Note takes a CANCELLED for the server's).
  if (!call->status.ok() && cancel != nullptr && cancel->cancelled()) return cancel->error();
  // A message taken by the link is no sign of the server (this host's kernel
  // took it), so an UNAVAILABLE here is an outage as far as anyone can tell.
  if (absl::Status error = Note(call->status, "UploadBlob", route, call->context); !error.ok()) return error;
  return call->response;
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
  // No deadline on the call: the watch bounds each step instead.
  const StallWatch::Duration stall_limit(options_.rpc_timeout_seconds);
  StallWatch watch(context, cancel);
  std::unique_ptr<grpc::ClientAsyncReader<v1::ReadBlobResponse>> reader =
      stub.PrepareAsyncReadBlob(&context, request, watch.queue());
  CancelSource::Registration registration;
  if (cancel != nullptr) registration = cancel->OnCancel([&context] { context.TryCancel(); });
  int tags[3];  // distinct addresses: start, read, finish
  reader->StartCall(&tags[0]);
  bool answered = false;  // a message arrived on this call
  int64_t received = 0;
  absl::Status local_error;
  if (watch.Await(&tags[0], stall_limit)) {
    v1::ReadBlobResponse message;
    while (true) {
      reader->Read(&message, &tags[1]);
      if (!watch.Await(&tags[1], stall_limit)) break;
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
  watch.Await(&tags[2], stall_limit);
  // A read of a cancelled call completes at once: no need to leave it to
  // another thread, as UploadBlob does its writes.
  watch.Close();
  registration.Reset();
  if (!local_error.ok()) return local_error;
  if (status.ok()) return Note(status, "ReadBlob", route, context);
  // Every cancel of our own side ends here, before Note, which takes a
  // CANCELLED for the server's.
  if (cancel != nullptr && cancel->cancelled()) return cancel->error();
  if (watch.stalled() && (status.error_code() == grpc::StatusCode::CANCELLED ||
                          status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)) {
    // The watchdog's own cancel: the link (or the server) stalled.
    return NoteStall("ReadBlob", route,
                     absl::StrCat("no bytes arrived for ", absl::SixDigits(options_.rpc_timeout_seconds),
                                  " s (rpc_timeout_seconds)",
                                  answered ? absl::StrCat(", after ", received, " bytes of this stream")
                                           : std::string()));
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
