#include "tests/delivery/nginx_process.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"

namespace impostor::testing {
namespace {

namespace fs = std::filesystem;

// A port the kernel considers free right now. nginx binds it a moment
// later; Start chooses again when another process took it meanwhile.
int FreeLoopbackPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(absl::StrCat("socket: ", std::strerror(errno)));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    const int err = errno;
    ::close(fd);
    throw std::runtime_error(absl::StrCat("bind 127.0.0.1:0: ", std::strerror(err)));
  }
  ::close(fd);
  return ntohs(addr.sin_port);
}

std::string Config(const fs::path& dir, const NginxSite& site, int port) {
  const std::string d = dir.string();
  std::ostringstream conf;
  // As root, nginx would hand requests to workers running as `nobody`, who
  // may not read a test's temp directory nor write its cache.
  if (::geteuid() == 0) conf << "user root root;\n";
  conf << "worker_processes " << site.worker_processes << ";\n"
       << "pid " << d << "/nginx.pid;\n"
       // stderr lands in the ChildProcess's log (dumped when a test fails,
       // and where readiness is read); error.log keeps the details.
       << "error_log stderr notice;\n"
       << "error_log " << d << "/error.log info;\n"
       << "worker_rlimit_nofile 16384;\n"
       << "events { worker_connections 8192; }\n"
       << "http {\n"
       << "  default_type application/octet-stream;\n"
       << "  access_log off;\n"
       // Debian's compiled-in temp paths are under /var/lib/nginx.
       << "  client_body_temp_path " << d << "/tmp/body;\n"
       << "  proxy_temp_path " << d << "/tmp/proxy;\n"
       << "  fastcgi_temp_path " << d << "/tmp/fastcgi;\n"
       << "  uwsgi_temp_path " << d << "/tmp/uwsgi;\n"
       << "  scgi_temp_path " << d << "/tmp/scgi;\n"
       << "  sendfile on;\n"
       << "  tcp_nopush on;\n"
       << "  keepalive_timeout 120s;\n"
       << "  keepalive_requests 100000;\n"
       << absl::StrReplaceAll(site.http, {{"{dir}", d}}) << "\n"
       << "  server {\n"
       << "    listen 127.0.0.1:" << port << " backlog=4096;\n"
       << absl::StrReplaceAll(site.server, {{"{dir}", d}}) << "\n"
       << "  }\n"
       << "}\n";
  return conf.str();
}

}  // namespace

absl::StatusOr<std::unique_ptr<NginxProcess>> NginxProcess::Start(const fs::path& dir, NginxSite site,
                                                                  std::chrono::milliseconds timeout) {
  std::error_code ec;
  fs::create_directories(dir / "tmp", ec);
  if (ec) return absl::InternalError(absl::StrCat(dir.string(), ": ", ec.message()));
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  std::string last_log;
  for (int attempt = 0; attempt < 5; ++attempt) {
    const int port = FreeLoopbackPort();
    {
      std::ofstream conf(dir / "nginx.conf", std::ios::trunc);
      conf << Config(dir, site, port);
      if (!conf) return absl::InternalError(absl::StrCat((dir / "nginx.conf").string(), ": cannot write"));
    }
    auto self = std::unique_ptr<NginxProcess>(new NginxProcess);
    self->dir_ = dir;
    self->port_ = port;
    self->url_ = absl::StrCat("http://127.0.0.1:", port);
    ProcessOptions options;
    options.name = "nginx-" + site.name;
    // -e: the log nginx writes before it has read the configuration.
    self->process_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{kNginxBinary, "-e", "stderr", "-p", dir.string() + "/", "-c",
                                 (dir / "nginx.conf").string(), "-g", "daemon off;"},
        std::move(options));
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (self->process_->WaitForLog("start worker processes", 1, std::max(left, std::chrono::milliseconds(1)))) {
      return self;
    }
    last_log = self->process_->Stderr();
    self->process_->KillAndReap();
    if (last_log.find("Address already in use") == std::string::npos) break;
  }
  if (last_log.size() > 4000) last_log = last_log.substr(last_log.size() - 4000);
  return absl::UnavailableError(absl::StrCat("nginx ", site.name, " in ", dir.string(), " did not start:\n", last_log));
}

NginxProcess::~NginxProcess() = default;

void NginxProcess::Pause() { process_->Signal(SIGSTOP); }
void NginxProcess::Resume() { process_->Signal(SIGCONT); }

NginxSite OriginSite(const fs::path& release_root) {
  NginxSite site;
  site.name = "origin";
  site.http = "  log_format requests '$request_method $request_uri $status';\n";
  site.server = absl::StrCat(
      "    access_log {dir}/access.log requests;\n"
      "    root ", release_root.string(), ";\n"
      "    etag on;\n"
      "    location /v1/blobs/ { add_header Cache-Control \"public, max-age=31536000, immutable\" always; }\n"
      "    location /v1/catalogs/ { add_header Cache-Control \"public, max-age=31536000, immutable\" always; }\n"
      "    location /v1/channels/ { add_header Cache-Control \"public, max-age=10\" always; }\n"
      "    location / { return 404; }\n");
  return site;
}

NginxSite EdgeSite(const std::string& upstream_url, int worker_processes) {
  NginxSite site;
  site.name = "edge";
  site.worker_processes = worker_processes;
  site.http =
      "  log_format requests '$request_method $request_uri $status $upstream_cache_status';\n"
      "  proxy_cache_path {dir}/cache levels=1:2 keys_zone=edge:16m max_size=8g inactive=30d use_temp_path=off;\n";
  const std::string proxy = absl::StrCat("proxy_pass ", upstream_url, ";");
  site.server = absl::StrCat(
      "    access_log {dir}/access.log requests;\n"
      "    proxy_http_version 1.1;\n"
      "    proxy_set_header Connection \"\";\n"
      "    proxy_cache edge;\n"
      // The query string is not part of the key: ?cachebuster=... is one object.
      "    proxy_cache_key $scheme$proxy_host$uri;\n"
      // One upstream request per object, however many clients miss it at
      // once and however long the origin takes (up to a minute; nginx's
      // default 5 s would let the waiting clients through to the origin).
      "    proxy_cache_lock on;\n"
      "    proxy_cache_lock_timeout 60s;\n"
      "    proxy_cache_lock_age 60s;\n"
      "    proxy_cache_revalidate on;\n"
      "    add_header X-Cache-Status $upstream_cache_status always;\n"
      "    location /v1/blobs/ { ", proxy, " proxy_cache_valid 200 1y; }\n"
      "    location / { ", proxy, " }\n");
  return site;
}

std::vector<AccessLogLine> ReadAccessLog(const fs::path& path) {
  std::vector<AccessLogLine> lines;
  std::ifstream in(path);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // A line still being written (no newline yet) is not counted.
  const size_t end = text.rfind('\n');
  if (end == std::string::npos) return lines;
  for (absl::string_view raw : absl::StrSplit(absl::string_view(text).substr(0, end), '\n')) {
    std::vector<std::string> fields = absl::StrSplit(raw, ' ');
    if (fields.size() < 3) continue;
    AccessLogLine line;
    line.method = fields[0];
    line.uri = fields[1];
    line.status = std::atoi(fields[2].c_str());
    if (fields.size() > 3) line.cache_status = fields[3];
    lines.push_back(std::move(line));
  }
  return lines;
}

std::map<std::string, int> CountGets(const std::vector<AccessLogLine>& lines, const std::string& prefix) {
  std::map<std::string, int> counts;
  for (const AccessLogLine& line : lines) {
    if (line.method == "GET" && line.uri.rfind(prefix, 0) == 0) counts[line.uri] += 1;
  }
  return counts;
}

SilentPort::SilentPort() {
  fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(absl::StrCat("socket: ", std::strerror(errno)));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 || ::listen(fd_, 64) != 0 ||
      ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    const int err = errno;
    ::close(fd_);
    throw std::runtime_error(absl::StrCat("silent port: ", std::strerror(err)));
  }
  port_ = ntohs(addr.sin_port);
}

SilentPort::~SilentPort() {
  if (fd_ >= 0) ::close(fd_);
}

void RaiseOpenFileLimit() {
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) == 0 && limit.rlim_cur < limit.rlim_max) {
    limit.rlim_cur = limit.rlim_max;
    ::setrlimit(RLIMIT_NOFILE, &limit);
  }
}

}  // namespace impostor::testing
