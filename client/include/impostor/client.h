// The impostor bake farm client SDK: upload a glTF model, bake it into an
// impostor atlas, follow the job and download the result.
//
// This header is the whole public API. It deliberately exposes no gRPC or
// protobuf type, so applications link against it without generated code and
// the wire protocol (impostor.v1) can evolve behind it.
//
// Typical use:
//
//   impostor::sdk::ClientOptions options;
//   options.server = "bake.example.com:50051";
//   auto client = impostor::sdk::Client::Connect(options);
//   if (!client.ok()) return client.status();
//   auto submitted = (*client)->SubmitBake("tree/scene.gltf", {});
//   if (!submitted.ok()) return submitted.status();
//   auto done = (*client)->WatchJob(submitted->job_id, [](const auto& u) {});
//   if (!done.ok()) return done.status();
//   if (done->state != impostor::sdk::JobState::kSucceeded) { ... done->error_message ... }
//   auto fetched = (*client)->Fetch(done->cache_key, "out/tree");
#ifndef IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_CLIENT_H_
#define IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_CLIENT_H_

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor::sdk {

// A change in whether the server answers, as ClientOptions::
// on_connection_change reports it.
struct ConnectionEvent {
  enum class Kind {
    // A call failed with UNAVAILABLE (server down, restarting, connection
    // refused or reset) after the server had answered; calls now retry for
    // up to max_outage_seconds, counted from this moment.
    kLost,
    // The server answered again after a kLost.
    kRegained,
  };
  Kind kind = Kind::kLost;
  // ClientOptions::server.
  std::string server;
  // kLost: the error that showed the outage (UNAVAILABLE, naming the RPC).
  absl::Status error;
  // kRegained: how long the server was gone, seconds.
  double outage_seconds = 0;
  // ClientOptions::max_outage_seconds.
  double max_outage_seconds = 0;
};

// How a Client talks to the server.
struct ClientOptions {
  // Address of the bake server as "host:port" (any gRPC target string works,
  // e.g. "dns:///bake.example.com:50051" or "unix:/run/impostor.sock").
  // The connection is plaintext unless tls_ca_file is set.
  //
  // Several replicas of one farm (issue 15): their addresses separated by
  // commas, "bake1:50051,bake2:50051" (up to 16; "[::1]:50051" for IPv6
  // literals). Connect uses the first that answers; every later call sticks
  // to that replica until a call on it fails with UNAVAILABLE (or, with
  // several addresses, DEADLINE_EXCEEDED), then moves on to the next one at
  // once, without backoff and without counting against max_attempts or the
  // outage budget until every replica has failed. A watch resumes on the
  // next replica; an upload or download restarts or resumes there. One
  // DNS name with several A/AAAA records also fails over (gRPC's pick_first
  // tries them in order). A malformed list (empty entry, no port, the same
  // address twice) is INVALID_ARGUMENT naming this field.
  // Default: "localhost:50051".
  std::string server = "localhost:50051";

  // Deadline of every unary RPC (FindMissingBlobs, SubmitBake, GetJob,
  // CancelJob, GetResult), in seconds. Uploads and downloads have no overall
  // deadline, however slow the link, only this long at most without
  // progress: no byte arriving, or no 64 KiB message taken by the link for
  // an upload ("the link stalled", DEADLINE_EXCEEDED naming the seconds and
  // bytes). A download then resumes at the last byte kept; an upload
  // resumes after the bytes the server kept of it (QueryUpload says how
  // many; a server without it gets the whole blob). After an upload's last message
  // the server's answer may take this long for each 64 KiB the link may
  // still hold (up to 4 MiB), plus once: those bytes cross unseen. WatchJob
  // has no deadline (a bake may take long) but resumes when the stream
  // breaks.
  // Default: 30. Range: > 0.
  double rpc_timeout_seconds = 30;

  // How often a call is tried in all before its error is returned, outside
  // an outage (see max_outage_seconds). A call is retried when it fails with
  // UNAVAILABLE or DEADLINE_EXCEEDED (every RPC of impostor.v1 is idempotent;
  // SubmitBake through its request id), after an exponential backoff of
  // 100 ms, 200 ms, 400 ms, ... capped at 1 s, with up to 20% jitter. A
  // download that breaks midway resumes where it stopped; its attempt count
  // starts over whenever bytes arrived, as an upload's does whenever the
  // server kept more of it.
  // Default: 5. Range: >= 1 (1 = never retry).
  int max_attempts = 5;

  // How long a server that answered once may stay away, in seconds. While
  // calls fail with UNAVAILABLE (the server is down, restarting, refusing or
  // resetting connections) every call keeps retrying with the backoff above
  // (so a restarted server is found within about a second) until the outage,
  // counted from the first failure after the last answer, has lasted this
  // long; then it returns its last error. This covers uploads (a broken
  // UploadBlob resumes after the bytes the server kept), SubmitBake (same request id, so never a second
  // job), WatchJob (resumed with GetJob and a new stream), GetJob, GetResult
  // and downloads (resumed at the byte offset already received, still
  // verified against the digest). Connect itself still fails fast when
  // nothing answers. 0 = no outage handling: max_attempts alone decides.
  // Default: 300 (a deploy or a reboot of the server). Range: 0..86400.
  double max_outage_seconds = 300;

  // Called when the server stops answering (kLost) and when it answers again
  // (kRegained): once per transition for the whole Client, however many
  // calls notice. Runs on the thread of the call that noticed, serialised
  // with other invocations; it must return quickly and must not call the
  // Client. The `impostor` CLI prints one line for each. Default: empty.
  std::function<void(const ConnectionEvent&)> on_connection_change;

  // How long Connect waits for the channel to become ready, in seconds.
  // A refused connection (nothing listening) ends the wait after about one
  // second instead. Default: 10. Range: > 0.
  double connect_timeout_seconds = 10;

  // Keepalive (issue 15): while a call is in flight, the client pings the
  // server after this many seconds of quiet and gives the connection up
  // when no answer comes within min(this, 10) s. A WatchJob that waits
  // for a queued bake over a link that died without a reset (a pulled
  // cable, a replica's host cut off) then fails over or resumes within
  // about keepalive + 10 s instead of TCP's ~15 min. An idle client (no
  // call in flight) sends nothing. Servers from this version on accept
  // pings as often as once a second; an older one answers frequent pings
  // with GOAWAY "too_many_pings", and gRPC then doubles the interval.
  // Default: 20. Range: whole seconds 1..7200 (INVALID_ARGUMENT naming
  // this field otherwise).
  int keepalive_seconds = 20;

  // Names this client to the server (the "impostor-client-id" metadata of
  // unary calls), e.g. "ci-nightly" or a user name: per-client limits and
  // fairness between clients count by it. Empty = the server uses the
  // connection's address, which every client on one host shares.
  // Default: empty. At most 128 bytes are used.
  std::string client_id;

  // Transport security (README "Securing a farm: TLS"). Connect reads and
  // checks these files (INVALID_ARGUMENT naming the field when one is
  // missing, not PEM, or a key does not match its certificate); a
  // handshake that fails (wrong CA, a name the certificate does not carry,
  // a server without TLS, mutual TLS without a certificate) is UNAVAILABLE
  // from Connect, saying so.
  //
  // CA bundle (PEM file) that the server's certificate must chain to; set =
  // TLS, trusting only this CA (not the system's roots). Default: empty =
  // plaintext.
  std::string tls_ca_file;
  // Mutual TLS: this client's certificate chain and its private key (PEM
  // files, key unencrypted), for a server run with --tls-client-ca. Both or
  // neither; they need tls_ca_file. Default: empty = no client certificate.
  std::string tls_cert_file;
  std::string tls_key_file;
  // The name the server's certificate must carry, when it differs from the
  // host in `server` (e.g. dialling an IP address or an SSH tunnel's
  // localhost for a certificate issued to bake.studio.lan). Needs
  // tls_ca_file. Default: empty = the host in `server`.
  std::string tls_server_name;
  // Identity (issue 14): the bearer token sent with every call
  // ("authorization: Bearer <token>") to a server that runs with
  // --auth token. Taken from `token_file` (a file holding the token on its
  // first line) if set, else `token`, else the IMPOSTOR_TOKEN environment
  // variable; none = no token (a loopback server with --auth none).
  // Connect answers INVALID_ARGUMENT for an unreadable or empty file.
  // Default: empty.
  std::string token_file;
  std::string token;
  // The farm's HTTP front end (the server's --http-listen, or a TLS proxy
  // in front of it), e.g. "http://bake.example.com:8080" or
  // "https://bake.example.com" (issue 45): fetching a result then
  // downloads its large files from /api/v1/results/KEY/files/NAME there
  // with libcurl, the token above as a bearer header, verified against
  // their digests as they stream; its small files still come many to one
  // BatchReadBlobs call, and the listing from GetResult. gRPC relays a
  // large file in 64 KiB messages at about a third of the speed plain HTTP
  // moves it. A file the front end cannot give intact (unreachable, 404, a
  // stall of rpc_timeout_seconds, bytes that do not verify) is downloaded
  // over gRPC instead, and nothing unverified is installed. https:// is
  // checked against tls_ca_file when set, else the system's roots. With
  // tls_ca_file set only https:// is accepted, as the token would cross
  // the network in clear. Empty = the IMPOSTOR_FARM_HTTP environment
  // variable, and when that is unset the front end the farm advertises on
  // its GetResult answers (impostor-server --http-advertise; one warning,
  // and gRPC, when this client cannot use it, e.g. http:// with
  // tls_ca_file); "none" = none, advertised or not. Anything but an
  // http:// or https:// URL of at most 2,048 printable characters is
  // INVALID_ARGUMENT from Connect naming this field. FetchFromFarm (below)
  // with a front end given here or in the variable (not advertised) takes
  // the listing and every file from it and opens no gRPC channel. Default:
  // empty.
  std::string farm_http;
};

// What to bake. Zero and empty values mean "the server's default", which the
// server fills in before computing the cache key, so an explicit default and
// an omitted one share a cached result.
struct BakeSettings {
  // Arrangement of view directions in the atlas: "octahedral" (the full
  // sphere), "hemi-octahedral" (the upper hemisphere, glTF +Y up),
  // "azimuth-elevation" (columns = azimuth, rows = elevation, full sphere,
  // odd row count), "ring-top" (ring_views horizontal views + 1 from above)
  // or "billboard" (the traditional 3x3: 8 side views + 1 top view).
  // Default: "octahedral". Any other name is INVALID_ARGUMENT.
  std::string layout = "octahedral";

  // Frames per atlas axis: the atlas holds frames x frames views.
  // Default: 0 = the server's default (12; azimuth-elevation 11). Range
  // checked by the server: 2..64 (octahedral 3..64); azimuth-elevation odd 3..63; ring-top and
  // billboard derive it and refuse an explicit value.
  uint32_t frames = 0;

  // ring-top only: horizontal views, evenly spaced in azimuth.
  // Default: unset = 24 (15 degrees apart). Range checked by the server: 3..64.
  std::optional<uint32_t> ring_views;

  // Atlas and LOD chain: samples per texel side; the atlas is rendered at
  // supersampling x its resolution and filtered down, so alpha edges are
  // smooth and keep the surface's colour. Default: unset = 2. Range checked
  // by the server: 1..4, and resolution x supersampling at most 16384.
  std::optional<uint32_t> supersampling;

  // Atlas side in pixels.
  // Default: 0 = the server's default (2048). Range checked by the server:
  // 64..16384 and at least 8 * frames.
  uint32_t resolution = 0;

  // What to bake: "atlas" (the three atlas maps) or "surfels" (a point
  // cloud for dense foliage at extreme distance: a buffer of 12 float32 per
  // point, surfels.bin, ready to upload as an instance buffer, and the same
  // points as surfels.ply). For surfels, frames and resolution describe the
  // multi-view capture the points are read from.
  // Default: "atlas" (empty is the same). Any other name is INVALID_ARGUMENT.
  std::string product = "atlas";

  // Surfels only: "prop" (2048 points, 12 frames, 512 px), "building"
  // (16384, 16, 1024), "vegetation" (32768, 24, 2048) or "hero" (65536, 32,
  // 2048); frames, resolution and point_budget given explicitly override it.
  // Default: empty = "vegetation". Checked by the server.
  std::string preset;

  // Surfels only: the most points the cloud may have; the bake gets as close
  // as the capture allows without exceeding it.
  // Default: unset = from the preset. Range checked by the server: 1..4194304.
  std::optional<uint32_t> point_budget;

  // Product "lod-chain" only (the original mesh, simplified levels, then an
  // atlas impostor; read the result with LoadLodChain, impostor/lod.h):
  // triangle ratios of the simplified levels, each in (0, 1), strictly
  // decreasing, at most 8. Default: empty = [0.5, 0.1]. Checked by the
  // server. The impostor level's layout defaults to hemi-octahedral when
  // `layout` is empty (the string default "octahedral" is sent as given).
  std::vector<float> lod_ratios;
  // Product "lod-chain" only: screen-space geometric error allowed at each
  // switch, pixels. Default: unset = 1. Range checked by the server: 0.1..16.
  std::optional<float> lod_pixel_error;

  // Product "cards" only (a few textured quads fitted to the mesh, delivered
  // as cards.glb, a standard glTF 2.0 binary, plus the card atlas maps):
  // the most cards (planes). Default: unset = 8. Range checked by the
  // server: 1..64. For cards, resolution is the card atlas's side (default
  // 1024) and frames must stay 0; layout is ignored.
  std::optional<uint32_t> max_planes;
  // Product "cards" only: how far a triangle may lie from its card's plane,
  // as a fraction of the bounding-sphere radius. Default: unset = 0.05.
  // Range checked by the server: 0.0001..1.
  std::optional<float> tolerance;

  // Scheduling priority: higher runs first. Suggested: 50 for a person
  // waiting at a desk, 0 for CI, -50 for nightly batches; among equal
  // priorities the server alternates between clients. Not part of the cache
  // key. Default: 0. Range checked by the server: -100..100.
  int32_t priority = 0;

  // Tags a worker must have (impostor-worker --tags) to bake this: e.g.
  // "gpu", or a team's tag for its reserved nodes. Not part of the cache
  // key. Checked by the server: at most 16, each 1..64 bytes of
  // [a-z0-9._-]. A bake no worker can take waits, its stage saying why.
  std::vector<std::string> required_tags;

  // Quality gate on the measured fidelity of an atlas (the manifest's
  // "quality" block): the job FAILS (error code 9, FAILED_PRECONDITION, with
  // the result still downloadable) when the mean silhouette IoU over the
  // held-out views is below min_iou, or the mean albedo PSNR below
  // min_psnr_db. Not part of the cache key: a gated request shares the bake
  // and the cached result of an ungated one.
  // Default: unset = not checked. Ranges checked by the server: min_iou
  // 0..1, min_psnr_db 0..100 (dB).
  std::optional<float> min_iou;
  std::optional<float> min_psnr_db;

  // Atlas products: let the server pick frames (which must stay 0) by
  // measured quality: it bakes the layout's ladder (octahedral layouts 8, 10,
  // 12, 16, 20, 24 frames; azimuth-elevation 7, 9, 11, 13, 17, 21; ring-top
  // ring_views 8, 12, 16, 24, 32, 48, which must then stay unset; billboard
  // its one 3x3; those that fit resolution >= 8 * grid side) and keeps the smallest whose quality meets
  // min_iou / min_psnr_db (at least one must be set; the same thresholds
  // then gate the result). The manifest's quality block lists the counts
  // tried. Part of the cache key (with the thresholds). Default: false.
  bool frames_auto = false;
  // Atlas products: held-out views of the quality pass (the manifest's
  // "quality" block). Default: unset = 16. Range checked by the server:
  // 0..256 (0 = no quality pass, and no gate can pass).
  std::optional<uint32_t> quality_views;
  // Product "atlas" only: also bake a fourth map, emissive.png (emissive
  // texture x emissiveFactor x KHR_materials_emissive_strength, sRGB, A =
  // coverage), listed in the manifest's maps as "emissive". Part of the
  // cache key. Default: false.
  bool emissive = false;
  // Atlas and LOD chain: write every map as a texture array instead of an
  // atlas: one tile-wide PNG with layer i (= view i) at rows
  // [i * tile_size, (i + 1) * tile_size); each view's tile in the manifest
  // gives its layer. For engines that prefer arrays. Default: false.
  bool texture_array = false;

  // Product "atlas" only: file format of the maps, "png" or "ktx2" (each map
  // a KTX2 file, Basis Universal UASTC, with a mip chain made per tile so no
  // level mixes frames; ktx2.md in share/doc/impostor). The server rounds resolution down so
  // tiles are multiples of 4 px at every level. Default: empty = "png".
  // Not with texture_array or frames_auto. Checked by the server.
  std::string texture_format;
  // texture_format "ktx2" only: the albedo map's codec, "uastc" or
  // "uastc-rdo" (smaller, slightly lossier). Default: empty = "uastc".
  std::string albedo_codec;
  // Upload a buffer/image reached through a symbolic link that leads out of
  // the model's folder. Not sent to the server; not part of the cache key.
  // Default: false, and such a link is PERMISSION_DENIED naming the link and
  // its target (a downloaded asset pack's "tex.png -> ~/.ssh/id_rsa" must
  // not end up in the blob store). Links inside the folder always work.
  bool follow_symlinks = false;
};

// What SubmitBake sent to the store.
struct UploadStats {
  int files = 0;               // files of the model, the entry file included
  int uploaded = 0;            // files the server lacked and that were uploaded
  int64_t bytes_total = 0;     // size of all files of the model
  int64_t bytes_uploaded = 0;  // size of the uploaded files
};

struct SubmitResult {
  std::string job_id;
  // 64 hex characters; names the result for Fetch.
  std::string cache_key;
  // The result was already baked: the job is SUCCEEDED and Fetch works now.
  bool cached = false;
  UploadStats upload;
  // Set when a cached result failed the request's quality gate: the job is
  // already FAILED with code 9 (FAILED_PRECONDITION) and this reason; Fetch
  // still downloads the result for inspection. 0 and empty otherwise.
  int error_code = 0;
  std::string error_message;
};

// One model of a SubmitBakeBatch.
struct BatchItem {
  std::filesystem::path model;  // a .gltf or .glb, as for SubmitBake
  BakeSettings settings;
};

// What SubmitBakeBatch did with one item.
struct BatchSubmission {
  // OK when submitted (`result` is set). Otherwise why not: the model's own
  // problem (NOT_FOUND, INVALID_ARGUMENT as for SubmitBake), the server's
  // refusal of this request (an RPC error from SubmitBake, e.g.
  // INVALID_ARGUMENT naming the field), or CANCELLED when the batch stopped
  // before this item (see SubmitBakeBatch).
  absl::Status status;
  SubmitResult result;
};

enum class JobState { kQueued, kRunning, kSucceeded, kFailed, kCancelled, kUnknown };

// "queued", "running", "succeeded", "failed", "cancelled" or "unknown".
std::string_view JobStateName(JobState state);

// True for kSucceeded, kFailed and kCancelled: the job will not change again.
bool IsTerminal(JobState state);

// A snapshot of a job.
struct JobUpdate {
  std::string job_id;
  std::string cache_key;
  JobState state = JobState::kUnknown;
  // Fraction done, 0..1 (1 once succeeded).
  double progress = 0;
  // While running: "download", "load", "render", "encode" or "upload".
  std::string stage;
  // When failed or cancelled: a canonical status code (absl::StatusCode and
  // grpc::StatusCode agree, e.g. 3 = INVALID_ARGUMENT) and a one-line reason.
  int error_code = 0;
  std::string error_message;
  // The result came from the cache without a new bake.
  bool cached = false;
};

// What Fetch left on disk.
struct FetchResult {
  // The output directory and its manifest.json.
  std::filesystem::path dir;
  std::filesystem::path manifest_path;
  // Every map image (albedo_alpha.png, ...) in manifest order, then
  // manifest.json. For a surfel result: surfels.bin (the point buffer, 48
  // bytes per point, ready to upload as an instance buffer unchanged; see
  // the manifest's "surfels" block for count and splat size), surfels.ply,
  // then manifest.json.
  std::vector<std::filesystem::path> files;
  // Bytes received from the server, and bytes of files already present in
  // `dir` with the right digest (kept, not downloaded again).
  int64_t bytes_downloaded = 0;
  int64_t bytes_reused = 0;
  // The manifest's `warnings`: what the baker worked around (points/lines
  // skipped, images dropped, a MASK material without alpha, ...).
  std::vector<std::string> warnings;
  // Wall time of the whole fetch.
  double seconds = 0;
};

// Details of a Status that came from an RPC (see GetRpcErrorInfo).
struct RpcErrorInfo {
  std::string rpc;             // e.g. "SubmitBake"
  std::string server;          // the ClientOptions::server address
  std::string server_message;  // the server's own message, unchanged
  // Why the server refused, as a stable word to act on instead of parsing
  // server_message (e.g. "TOKEN_PENDING_JOBS"; README.md, Quotas, lists
  // them); "" when the server gave none.
  std::string reason;
};

// Every Status a Client returns for a failed RPC carries the RPC's status
// code and a message naming the RPC and the server address; this returns its
// details. std::nullopt for local failures (a missing model file, a bad
// argument, a full disk), which lets callers tell the two apart.
std::optional<RpcErrorInfo> GetRpcErrorInfo(const absl::Status& status);

// A connection to one bake server.
//
// Thread-safety: every method may be called from any thread, concurrently;
// the client holds no per-call state. Ownership: the caller owns the Client;
// it owns its channel, which closes when the Client is destroyed.
class Client {
 public:
  // Opens a channel to options.server and waits up to
  // options.connect_timeout_seconds for it to become ready (about a second
  // when the connection is refused). UNAVAILABLE naming the address when it
  // does not; INVALID_ARGUMENT for out-of-range options.
  static absl::StatusOr<std::unique_ptr<Client>> Connect(const ClientOptions& options);

  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Uploads what the server lacks of `model` (a .gltf or .glb file and every
  // file its buffers and images refer to by relative URI) and submits a bake.
  // The submit carries a fresh random request id, the same on every retry,
  // so a retried SubmitBake never creates a second job.
  // Errors: INVALID_ARGUMENT (unknown layout, not a .gltf/.glb, malformed
  // glTF, a URI that is absolute or leaves the model's directory), NOT_FOUND
  // (the model or a file it refers to is missing), or an RPC's error.
  absl::StatusOr<SubmitResult> SubmitBake(const std::filesystem::path& model,
                                          const BakeSettings& settings);

  // Submits many bakes at once: hashes every item's files, asks the server
  // which blobs it lacks with one FindMissingBlobs for the whole batch (one
  // per 10,000 distinct blobs), uploads each missing blob once, then sends
  // one SubmitBake per item, in order (each with its own request id, as
  // SubmitBake). Identical models share one bake on
  // the server; cached ones are answered at once (result.cached).
  // An item whose files cannot be read or whose settings are invalid is not
  // submitted and the others go on. `on_submitted` (may be empty) is called
  // on the calling thread with each item's index and outcome, in item order,
  // as soon as it is known; when it returns false, no further item is
  // submitted and each gets CANCELLED "not submitted: the batch stopped".
  // Returns one BatchSubmission per item (an item whose upload the server
  // refused, e.g. RESOURCE_EXHAUSTED on a full disk, gets that error and the
  // rest go on), or an RPC's error for the whole batch when FindMissingBlobs
  // fails or an upload fails for the caller or the connection.
  absl::StatusOr<std::vector<BatchSubmission>> SubmitBakeBatch(
      const std::vector<BatchItem>& items,
      const std::function<bool(size_t index, const BatchSubmission& submission)>& on_submitted);

  // Follows a job until it reaches a terminal state and returns that state; a
  // failed or cancelled bake is an OK StatusOr whose state says so.
  // `on_update` (may be empty) is called on the calling thread for each
  // change, the terminal one included. When the stream breaks (UNAVAILABLE,
  // e.g. a server restart) it resumes: GetJob, then a new stream, for as long
  // as ClientOptions::max_outage_seconds allows (a stream that ends without
  // news while the server answers: up to max_attempts times in a row).
  absl::StatusOr<JobUpdate> WatchJob(const std::string& job_id,
                                     const std::function<void(const JobUpdate&)>& on_update);

  // The job's current state.
  absl::StatusOr<JobUpdate> GetJob(const std::string& job_id);

  // Cancels a queued or running job; returns its state afterwards (a job that
  // already finished is returned unchanged).
  absl::StatusOr<JobUpdate> CancelJob(const std::string& job_id);

  // Downloads the result baked under `cache_key` into `out_dir` (created if
  // needed): every map image and manifest.json (written last, so a
  // manifest.json on disk means its maps are complete). Each file is written
  // to a temporary file in out_dir, verified against its SHA-256 and size,
  // then renamed into place; files already there with the right digest are
  // kept. Errors: NOT_FOUND (nothing baked under that key), DATA_LOSS (a
  // download did not match its digest), INTERNAL (cannot write out_dir),
  // RESOURCE_EXHAUSTED (out_dir's disk or quota is full: names the file and
  // the free space; the temporary file is removed), or an RPC's error.
  absl::StatusOr<FetchResult> Fetch(const std::string& cache_key,
                                    const std::filesystem::path& out_dir);

  // The text of the result's manifest.json, verified against its digest.
  absl::StatusOr<std::string> GetManifestJson(const std::string& cache_key);

  // The address this client talks to (ClientOptions::server).
  const std::string& server() const;

 private:
  class Impl;
  explicit Client(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Client::Connect and Fetch in one call, for a process that only fetches
// (`impostor fetch`): when `options` name the farm's HTTP front end
// (ClientOptions::farm_http or $IMPOSTOR_FARM_HTTP, not "none"), the
// result's listing and every file come from it, each verified as it
// streams, and no gRPC channel is opened; the process then pays what an
// HTTP client pays. When the front end cannot give the result (not there,
// a refused token, a bad byte, a front end that predates the listing), one
// warning line says why and the whole result is fetched over gRPC instead,
// with the front end left out. A local failure (the disk, out_dir) is
// returned as is. Errors: Connect's and Fetch's.
absl::StatusOr<FetchResult> FetchFromFarm(const ClientOptions& options, const std::string& cache_key,
                                          const std::filesystem::path& out_dir);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_CLIENT_H_
