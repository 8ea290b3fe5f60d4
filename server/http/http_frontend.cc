#include "server/http/http_frontend.h"

#include <httplib.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>

#include "absl/flags/flag.h"
#include "absl/strings/str_cat.h"
#include "common/util/log_escape.h"
#include "server/http/api_params.h"
#include "server/http/blob_response.h"
#include "server/http/bounded_http_server.h"
#include "server/http/impostor_runtime_glsl.h"  // generated
#include "server/http/http_authorize.h"
#include "server/auth/loopback_host.h"
#include "server/http/login_page.h"
#include "server/http/json_api.h"
#include "server/http/release_response.h"
#include "common/net/farm_http_base.h"
#include "server/metrics/rpc_metrics_interceptor.h"

#ifndef IMPOSTOR_WEB_DIR
#define IMPOSTOR_WEB_DIR "web"
#endif

ABSL_FLAG(std::string, http_listen, "",
          "HOST:PORT for /metrics, /healthz, /readyz, the JSON API and the dashboard; port 0 picks a free port "
          "(empty = no HTTP)");
ABSL_FLAG(std::string, http_static_dir, "",
          "Directory of the dashboard's files (default: share/impostor/web of the installation the binary is in, "
          "else web/ of the source tree it was built from)");
// Issue 40: the farm as an origin for game clients (release_response.h).
ABSL_FLAG(std::string, http_releases, "",
          "DIR of a release tree (written by `impostor publish`: the directory that holds v1/) to serve as plain "
          "files under /releases/, so http://HOST:PORT/releases is a mirror base URL; needs --http-listen");
// Issue 45: clients fetch a result's large files from the front end.
ABSL_FLAG(std::string, http_advertise, "",
          "The HTTP front end's base URL as clients reach it (e.g. https://farm.example.com, a TLS proxy in front of "
          "--http-listen): sent with every GetResult answer, so the SDK and the CLI fetch a result's large files "
          "from BASE/api/v1/results/KEY/files/NAME with their token instead of over gRPC, unless told "
          "--farm-http none; needs --http-listen; https:// only when gRPC is TLS (empty = not advertised)");
ABSL_FLAG(bool, http_releases_require_token, false,
          "With --http-releases and --auth token: /releases/ needs a reader, submitter or admin token, as the API "
          "does (off: open to all, as its files are named by their 256-bit digests)");

namespace impostor {
namespace {

constexpr size_t kHttpThreads = 32;
constexpr size_t kKeepAliveRequests = 100;

// Blobs served through the API at most this large (atlases are tens of MB
// at most; a bigger blob is fetched over gRPC). They stream in chunks
// (blob_response.h), so the cap bounds how long one of kHttpThreads is held,
// not memory.
constexpr int64_t kMaxServedBlobBytes = int64_t{512} << 20;

// One line per refused request, as the gRPC side logs event=auth_refused
// (authorized_services.cc): guessed tokens on /login show up too.
void LogRefusal(const httplib::Request& req, const HttpAuthorization& auth) {
  spdlog::warn("event=auth_refused listener=http method={} path=\"{}\" peer=\"{}\" status={} reason=\"{}\"",
               req.method, EscapeUntrusted(req.path, 200), EscapeUntrusted(req.remote_addr, 80), auth.status,
               EscapeUntrusted(auth.message, 300));
}

int HttpStatusFor(const absl::Status& s) {
  switch (s.code()) {
    case absl::StatusCode::kInvalidArgument: return 400;
    case absl::StatusCode::kNotFound: return 404;
    case absl::StatusCode::kFailedPrecondition: return 409;
    case absl::StatusCode::kResourceExhausted: return 413;
    case absl::StatusCode::kUnavailable: return 503;
    default: return 500;
  }
}

std::string Dump(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

void SendJson(httplib::Response& res, const nlohmann::json& j) {
  res.status = 200;
  res.set_header("Cache-Control", "no-store");
  res.set_content(Dump(j), "application/json");
}

void SendError(httplib::Response& res, const absl::Status& s) {
  res.status = HttpStatusFor(s);
  res.set_content(ErrorJson(res.status, std::string(s.message())), "application/json");
}

QueryParams Params(const httplib::Request& req) { return QueryParams(req.params.begin(), req.params.end()); }

const char* ContentTypeFor(const std::string& file) {
  auto ends = [&](std::string_view ext) {
    return file.size() >= ext.size() && file.compare(file.size() - ext.size(), ext.size(), ext) == 0;
  };
  if (ends(".png")) return "image/png";
  if (ends(".json") || ends(".gltf")) return "application/json";
  if (ends(".glb")) return "model/gltf-binary";
  if (ends(".jpg") || ends(".jpeg")) return "image/jpeg";
  if (ends(".ktx2")) return "image/ktx2";
  return "application/octet-stream";
}

}  // namespace

namespace {

// --http-static-dir, or where the dashboard's files are: installed beside
// the binary (/usr/bin/../share/impostor/web from the package), else the
// source tree of a build-tree binary.
std::filesystem::path StaticDirFromFlag() {
  if (std::string dir = absl::GetFlag(FLAGS_http_static_dir); !dir.empty()) return dir;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path installed = exe.parent_path().parent_path() / "share" / "impostor" / "web";
    if (std::filesystem::is_directory(installed, ec)) return installed;
  }
  return IMPOSTOR_WEB_DIR;
}

}  // namespace

absl::StatusOr<std::string> AdvertisedHttpFromFlags(bool grpc_tls) {
  std::string url = absl::GetFlag(FLAGS_http_advertise);
  if (url.empty()) return std::string();
  if (absl::GetFlag(FLAGS_http_listen).empty()) {
    return absl::InvalidArgumentError(
        "--http-advertise: needs --http-listen (it names the HTTP front end as clients reach it)");
  }
  if (absl::Status s = ValidateFarmHttpBase(url, grpc_tls); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("--http-advertise: ", s.message()));
  }
  while (!url.empty() && url.back() == '/') url.pop_back();
  return url;
}

absl::StatusOr<std::unique_ptr<HttpFrontend>> HttpFrontend::StartFromFlags(BakeScheduler* scheduler,
                                                                           BlobStore* blobs,
                                                                           Authenticator* authenticator) {
  const std::string listen = absl::GetFlag(FLAGS_http_listen);
  const std::string releases = absl::GetFlag(FLAGS_http_releases);
  const bool releases_require_token = absl::GetFlag(FLAGS_http_releases_require_token);
  if (releases_require_token && releases.empty()) {
    return absl::InvalidArgumentError("--http-releases-require-token: needs --http-releases (the release tree it "
                                      "guards)");
  }
  if (listen.empty()) {
    if (!releases.empty()) {
      return absl::InvalidArgumentError(
          "--http-releases: needs --http-listen (the release tree is served by the HTTP front end, e.g. "
          "--http-listen=0.0.0.0:8080 serves it at http://HOST:8080/releases)");
    }
    return std::unique_ptr<HttpFrontend>();
  }
  auto address = ParseListenAddress(listen, "--http-listen");
  if (!address.ok()) return address.status();
  const std::filesystem::path static_dir = StaticDirFromFlag();
  std::error_code ec;
  if (!std::filesystem::is_directory(static_dir, ec)) {
    // Named by the admin: a typo, refused. Found by default: the API and
    // /metrics still serve; the dashboard's pages would answer 404.
    if (!absl::GetFlag(FLAGS_http_static_dir).empty()) {
      return absl::InvalidArgumentError(absl::StrCat("--http-static-dir: ", static_dir.string(),
                                                     " is not a directory (the dashboard's files)"));
    }
    spdlog::warn("event=http_static_missing dir={} note=\"the dashboard's pages answer 404; the JSON API and "
                 "/metrics serve; give --http-static-dir\"",
                 static_dir.string());
  }
  return Start(scheduler, blobs,
               {.listen = *address,
                .static_dir = static_dir,
                .authenticator = authenticator,
                .releases_dir = releases,
                .releases_require_token = releases_require_token});
}

HttpFrontend::HttpFrontend(BakeScheduler* scheduler, BlobStore* blobs, Options options)
    : scheduler_(scheduler),
      blobs_(blobs),
      options_(std::move(options)),
      metrics_(scheduler, blobs),
      server_(std::make_unique<BoundedHttpServer>()) {}

absl::StatusOr<std::unique_ptr<HttpFrontend>> HttpFrontend::Start(BakeScheduler* scheduler, BlobStore* blobs,
                                                                  Options options) {
  std::unique_ptr<HttpFrontend> http(new HttpFrontend(scheduler, blobs, std::move(options)));
  if (const std::filesystem::path& dir = http->options_.releases_dir; !dir.empty()) {
    auto tree = ReleaseTree::Open(dir);
    if (!tree.ok()) return absl::InvalidArgumentError(absl::StrCat("--http-releases: ", tree.status().message()));
    http->releases_ = std::move(*tree);
  }
  http->Route();
  const ListenAddress& a = http->options_.listen;
  if (a.port == 0) {
    http->port_ = http->server_->bind_to_any_port(a.host);
    if (http->port_ <= 0) http->port_ = 0;
  } else if (http->server_->bind_to_port(a.host, a.port)) {
    http->port_ = a.port;
  }
  if (http->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("--http-listen: cannot listen on ", a.host, ":", a.port,
                                               " (address in use, or not an address of this host)"));
  }
  scheduler->SetObserver(&http->metrics_);
  http->thread_ = std::thread([server = http->server_.get()] { server->listen_after_bind(); });
  spdlog::info("event=http_listening address={}:{} static_dir={}", a.host, http->port_,
               http->options_.static_dir.string());
  if (http->releases_) {
    spdlog::info("event=http_releases dir={} url=http://{}:{}/releases require_token={}",
                 http->releases_->root().string(), a.host, http->port_,
                 http->options_.releases_require_token ? "true" : "false");
    if (http->options_.releases_require_token && http->options_.authenticator == nullptr) {
      spdlog::warn("event=http_releases_open note=\"--http-releases-require-token asks nothing with --auth none: "
                   "/releases/ is open, as the whole HTTP side is\"");
    }
  }
  // As the gRPC port warns (tls_credentials.cc): this one has no TLS at all,
  // and its bearer tokens and login cookie would cross the network in clear.
  if (!IsLoopbackHost(a.host)) {
    spdlog::warn("event=plaintext_listener host={} listener=http note=\"no TLS: tokens, cookies and assets sent "
                 "to this port can be read on the network; put it behind a TLS proxy or listen on 127.0.0.1\"",
                 a.host);
  }
  return http;
}

HttpFrontend::~HttpFrontend() {
  scheduler_->SetObserver(nullptr);
  server_->stop();
  if (thread_.joinable()) thread_.join();
}

std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> HttpFrontend::InterceptorCreators() {
  std::vector<std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface>> out;
  out.push_back(std::make_unique<RpcMetricsInterceptorFactory>(&metrics_));
  return out;
}

void HttpFrontend::AnnounceAddress() const {
  std::printf("impostor-server http listening on %s:%d\n", options_.listen.host.c_str(), port_);
  std::fflush(stdout);
}

bool HttpFrontend::IsOpenRelease(const httplib::Request& req) const {
  // Both the path as sent and as decoded are under the prefix, so the
  // request is routed to ServeReleaseFile and nowhere else.
  return releases_ != nullptr && !options_.releases_require_token && (req.method == "GET" || req.method == "HEAD") &&
         req.target.starts_with(kReleasesUrlPrefix) && req.path.starts_with(kReleasesUrlPrefix);
}

JobViewer HttpFrontend::Viewer(const httplib::Request& req) const {
  return ViewerOf({.method = req.method,
                   .path = req.path,
                   .authorization = req.get_header_value("Authorization"),
                   .cookie = req.get_header_value("Cookie")},
                  options_.authenticator);
}

void HttpFrontend::Route() {
  httplib::Server& s = *server_;
  // SO_REUSEADDR only: the library's default adds SO_REUSEPORT, which would
  // let a second server share a port already in use instead of failing.
  // More threads than cpp-httplib's default (8): a dashboard and a scrape
  // waiting on a busy scheduler (up to BakeScheduler::kViewLockWaitMs) must
  // not leave /healthz and /readyz without a thread.
  s.new_task_queue = [] { return new httplib::ThreadPool(kHttpThreads); };
  // No Nagle: the library writes a response's headers and its body (each
  // chunk of a streamed blob) in separate sends, and on a kept-alive
  // connection the second waited for the client's delayed ACK: 40 ms for
  // every request after a connection's first (a game's HTTP client, or
  // libcurl fetching a release's files one after another on one connection).
  // Inherited by every accepted connection.
  s.set_tcp_nodelay(true);
  // A client fetching a result's or a release's files one after another
  // keeps its connection for 100 requests, not the library's 5 (a new
  // connection, a new handshake, every five files; Apache's default is 100,
  // nginx's 1000). An idle connection still lets its thread go after the
  // keep-alive timeout.
  s.set_keep_alive_max_count(kKeepAliveRequests);
  s.set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  s.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (IsOpenRelease(req)) return httplib::Server::HandlerResponse::Unhandled;
    const HttpAuthorization auth = AuthorizeRequest({.method = req.method,
                                                     .path = req.path,
                                                     .authorization = req.get_header_value("Authorization"),
                                                     .cookie = req.get_header_value("Cookie")},
                                                    options_.authenticator, scheduler_);
    if (auth.allowed) return httplib::Server::HandlerResponse::Unhandled;
    if (auth.to_login) {  // a browser's first visit: not worth a warning
      res.set_redirect("/login", 303);
      return httplib::Server::HandlerResponse::Handled;
    }
    LogRefusal(req, auth);
    res.status = auth.status;
    if (auth.status == 401) res.set_header("WWW-Authenticate", "Bearer realm=\"impostor\"");
    res.set_content(ErrorJson(auth.status, auth.message), "application/json");
    return httplib::Server::HandlerResponse::Handled;
  });
  // The login form: open to all; a good token becomes an HttpOnly cookie.
  s.Get("/login", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(LoginPageHtml(""), "text/html; charset=utf-8");
  });
  s.Post("/login", [this](const httplib::Request& req, httplib::Response& res) {
    if (options_.authenticator == nullptr) {
      res.set_redirect("/", 303);  // --auth none: nothing to sign in to
      return;
    }
    const std::string token = req.get_param_value("token");
    const HttpAuthorization auth = AuthorizeRequest(
        {.method = "GET", .path = "/api/v1/summary", .authorization = token.empty() ? "" : "Bearer " + token},
        options_.authenticator, scheduler_);
    if (!auth.allowed) {
      LogRefusal(req, auth);
      res.status = auth.status;
      res.set_content(LoginPageHtml(auth.message), "text/html; charset=utf-8");
      return;
    }
    res.set_header("Set-Cookie", TokenCookieHeader(token));
    res.set_redirect("/", 303);
  });
  s.set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;
    if (res.status == 404) {
      res.set_content(ErrorJson(404, absl::StrCat("no such path: ", EscapeUntrusted(req.path, 200))),
                      "application/json");
    }
  });
  s.set_logger([](const httplib::Request& req, const httplib::Response& res) {
    if (res.status >= 500) {
      spdlog::warn("event=http_error method={} path=\"{}\" status={}", req.method, EscapeUntrusted(req.path, 200),
                   res.status);
    } else {
      spdlog::debug("event=http method={} path=\"{}\" status={}", req.method, EscapeUntrusted(req.path, 200),
                    res.status);
    }
  });
  if (std::filesystem::is_directory(options_.static_dir)) s.set_mount_point("/static", options_.static_dir.string());

  s.Get("/metrics", [this](const httplib::Request&, httplib::Response& res) {
    res.set_content(metrics_.Scrape(), "text/plain; version=0.0.4; charset=utf-8");
  });
  s.Get("/healthz", [](const httplib::Request&, httplib::Response& res) { res.set_content("ok\n", "text/plain"); });
  s.Get("/readyz", [this](const httplib::Request&, httplib::Response& res) {
    const absl::Status ready = scheduler_->CheckReady();
    res.status = ready.ok() ? 200 : 503;
    res.set_content(ready.ok() ? "ready\n" : absl::StrCat("not ready: ", ready.message(), "\n"), "text/plain");
  });
  // The release tree (GET and HEAD; HEAD is served by the GET handler).
  // Every path below the prefix is routed here ([\s\S]: a decoded %0A
  // too) and parsed strictly there.
  if (releases_) {
    const std::string pattern = std::string(kReleasesUrlPrefix) + R"([\s\S]*)";
    s.Get(pattern, [this](const httplib::Request& req, httplib::Response& res) {
      ServeReleaseFile(*releases_, req, res);
    });
  }

  // Every API handler: check the query, then answer or map the status.
  auto api = [this, &s](const std::string& pattern, std::set<std::string> known,
                        std::function<absl::Status(const httplib::Request&, const QueryParams&, httplib::Response&)> fn) {
    s.Get(pattern, [known = std::move(known), fn = std::move(fn)](const httplib::Request& req, httplib::Response& res) {
      const QueryParams params = Params(req);
      absl::Status st = CheckKnownParams(params, known);
      if (st.ok()) st = fn(req, params, res);
      if (!st.ok()) SendError(res, st);
    });
  };

  api("/api/v1/summary", {}, [this](const httplib::Request&, const QueryParams&, httplib::Response& res) {
    auto counts = scheduler_->JobCountsByState();
    if (!counts.ok()) return counts.status();
    auto workers = scheduler_->Workers();
    if (!workers.ok()) return workers.status();
    const int64_t now = std::chrono::duration_cast<std::chrono::milliseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    SendJson(res, SummaryJson(*counts, *workers, metrics_.totals(), blobs_->total_bytes(), now));
    return absl::OkStatus();
  });
  api("/api/v1/jobs", {"state", "page_size", "page_token"},
      [this](const httplib::Request& req, const QueryParams& params, httplib::Response& res) {
        auto state = ParseStateFilter(params);
        if (!state.ok()) return state.status();
        auto size = ParsePageSize(params);
        if (!size.ok()) return size.status();
        auto after = ParseJobPageToken(params);
        if (!after.ok()) return after.status();
        auto jobs = scheduler_->ListJobs(*state, *size, *after);
        if (!jobs.ok()) return jobs.status();
        SendJson(res, JobsPageJson(*jobs, *size, Viewer(req)));
        return absl::OkStatus();
      });
  api(R"(/api/v1/jobs/([^/]+))", {}, [this](const httplib::Request& req, const QueryParams&, httplib::Response& res) {
    auto job = scheduler_->DescribeJob(req.matches[1]);
    if (!job.ok()) return job.status();
    SendJson(res, JobJson(*job, true, Viewer(req)));
    return absl::OkStatus();
  });
  // The mesh a job was submitted with, file by file (the viewer loads the
  // original glTF from here): PATH is the entry's path or one of its files'.
  api(R"(/api/v1/jobs/([^/]+)/mesh/(.+))", {},
      [this](const httplib::Request& req, const QueryParams&, httplib::Response& res) {
        auto job = scheduler_->DescribeJob(req.matches[1]);
        if (!job.ok()) return job.status();
        const std::string path = req.matches[2];
        const v1::InputFile* file = nullptr;
        if (job->mesh.entry().path() == path) file = &job->mesh.entry();
        for (const auto& f : job->mesh.files()) {
          if (f.path() == path) file = &f;
        }
        if (file == nullptr) {
          return absl::NotFoundError(absl::StrCat("path: job ", job->job.job_id(), " has no mesh file \"",
                                                  EscapeUntrusted(path, 200), "\""));
        }
        if (file->digest().size_bytes() > kMaxServedBlobBytes) {
          return absl::ResourceExhaustedError("mesh file is over the HTTP limit; fetch it over gRPC");
        }
        return ServeBlob(*blobs_, {file->digest().hash(), file->digest().size_bytes()}, ContentTypeFor(path), req, res);
      });
  api("/api/v1/workers", {}, [this](const httplib::Request&, const QueryParams&, httplib::Response& res) {
    auto workers = scheduler_->Workers();
    if (!workers.ok()) return workers.status();
    SendJson(res, WorkersJson(*workers, metrics_));
    return absl::OkStatus();
  });
  api("/api/v1/pools", {}, [this](const httplib::Request&, const QueryParams&, httplib::Response& res) {
    auto pools = scheduler_->Pools();
    if (!pools.ok()) return pools.status();
    SendJson(res, PoolsJson(*pools));
    return absl::OkStatus();
  });
  api("/api/v1/results", {"page_size", "page_token"},
      [this](const httplib::Request&, const QueryParams& params, httplib::Response& res) {
        auto size = ParsePageSize(params);
        if (!size.ok()) return size.status();
        auto after = ParseResultPageToken(params);
        if (!after.ok()) return after.status();
        auto results = scheduler_->ListResults(*size, *after);
        if (!results.ok()) return results.status();
        SendJson(res, ResultsPageJson(*results, *size));
        return absl::OkStatus();
      });
  api(R"(/api/v1/results/([^/]+))", {}, [this](const httplib::Request& req, const QueryParams&, httplib::Response& res) {
    auto result = scheduler_->PeekResult(req.matches[1]);
    if (!result.ok()) return result.status();
    SendJson(res, ResultJson(*result));
    return absl::OkStatus();
  });
  // A result's listing as gRPC's GetResult answers it (impostor.v1.Manifest,
  // binary): with it and the files below a client fetches a result over
  // HTTP alone, never opening a gRPC channel. A use, as GetResult is: it
  // verifies the blobs are there and moves the result up the LRU.
  api(R"(/api/v1/results/([^/]+)/manifest)", {},
      [this](const httplib::Request& req, const QueryParams&, httplib::Response& res) {
        absl::StatusOr<v1::Manifest> manifest = scheduler_->GetResult(req.matches[1]);
        if (!manifest.ok()) return manifest.status();
        std::string body = manifest->SerializeAsString();
        res.set_header("Cache-Control", "no-store");
        res.set_header(kReprDigestHeader, ReprDigestSha256(body));
        res.set_content(std::move(body), kResultManifestMediaType);
        return absl::OkStatus();
      });
  // A result's files: manifest.json, its maps, and the product's own files.
  api(R"(/api/v1/results/([^/]+)/files/([^/]+))", {},
      [this](const httplib::Request& req, const QueryParams&, httplib::Response& res) {
        auto result = scheduler_->PeekResult(req.matches[1]);
        if (!result.ok()) return result.status();
        const v1::Manifest& m = result->manifest;
        const std::string name = req.matches[2];
        std::optional<v1::Digest> digest;
        if (name == "manifest.json") digest = m.manifest_json();
        for (const auto& map : m.maps()) {
          if (map.file() == name) digest = map.digest();
        }
        if (m.has_cards() && m.cards().file() == name) digest = m.cards().digest();
        for (const auto& lod : m.lods()) {
          if (lod.file() == name) digest = lod.digest();
        }
        if (!digest) {
          return absl::NotFoundError(
              absl::StrCat("file: result ", m.cache_key(), " has no file \"", EscapeUntrusted(name, 200), "\""));
        }
        if (digest->size_bytes() > kMaxServedBlobBytes) {
          return absl::ResourceExhaustedError("file is over the HTTP limit; fetch it over gRPC");
        }
        const absl::Status served =
            ServeBlob(*blobs_, {digest->hash(), digest->size_bytes()}, ContentTypeFor(name), req, res);
        // Content-addressed: the bytes (and a 416 for a range past them)
        // never change; an error may (a re-bake restores an evicted blob).
        if (served.ok()) res.set_header("Cache-Control", "max-age=86400, immutable");
        return served;
      });

  // The runtime shader, for the viewer's WebGL2 impostor (GLSL ES 3.00
  // accepts it unchanged once a #version and precision lines are prepended).
  s.Get("/runtime/impostor_runtime.glsl", [](const httplib::Request&, httplib::Response& res) {
    res.set_content(kImpostorRuntimeGlsl, "text/plain; charset=utf-8");
  });

  // Dashboard pages: static HTML that reads the API.
  auto page = [this, &s](const std::string& pattern, const std::string& file) {
    s.Get(pattern, [this, file](const httplib::Request&, httplib::Response& res) {
      const std::filesystem::path path = options_.static_dir / file;
      FILE* f = std::fopen(path.c_str(), "rb");
      if (f == nullptr) {
        res.status = 404;
        res.set_content(ErrorJson(404, "dashboard file missing: " + path.string() + " (--http-static-dir)"),
                        "application/json");
        return;
      }
      std::string body;
      char buf[65536];
      size_t n;
      while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) body.append(buf, n);
      std::fclose(f);
      res.set_header("Cache-Control", "no-store");
      res.set_content(std::move(body), "text/html; charset=utf-8");
    });
  };
  page("/", "index.html");
  page(R"(/jobs/([^/]+))", "job.html");
  page(R"(/results/([^/]+))", "result.html");
}

}  // namespace impostor
