// nginx (Debian's /usr/sbin/nginx) as a child process of a test or bench:
// a CDN origin serving a release tree, a caching edge in front of it, or a
// misbehaving edge. Each instance has a directory of its own holding its
// nginx.conf, pid file, temp and cache directories, error.log and
// access.log; it runs in the foreground (`daemon off`) in its own process
// group (tests/support/server_process.h's ChildProcess: killed with the
// test, its stderr in a log that is dumped when the test fails), never as a
// system service, on a 127.0.0.1 port the kernel picked.
//
// Threads: an NginxProcess is used from one thread at a time, as a
// ChildProcess is; the free functions may be called from any thread.
#ifndef IMPOSTOR_TESTS_DELIVERY_NGINX_PROCESS_H_
#define IMPOSTOR_TESTS_DELIVERY_NGINX_PROCESS_H_

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "tests/support/server_process.h"

namespace impostor::testing {

inline constexpr char kNginxBinary[] = "/usr/sbin/nginx";

// What differs between the nginx instances a test runs. Paths written into
// the text must be absolute; `{dir}` is replaced by the instance's directory.
struct NginxSite {
  // Names the process in logs and the instance's directory ("origin", "edge").
  std::string name;
  // Directives at `http` level: log formats, proxy_cache_path, ...
  std::string http;
  // The body of the one `server` block, after its `listen` line.
  std::string server;
  int worker_processes = 1;
};

// One running nginx. The destructor kills its process group.
class NginxProcess {
 public:
  // Writes `dir`/nginx.conf for `site` (dir is created; it must not hold
  // another running instance) and starts nginx on a free loopback port,
  // ready to serve when this returns: it has logged "start worker processes",
  // which it does after binding. A port taken between choosing and binding
  // is chosen again. Errors: UNAVAILABLE (nginx refused the configuration or
  // did not start within `timeout`: the message holds its log's tail).
  static absl::StatusOr<std::unique_ptr<NginxProcess>> Start(
      const std::filesystem::path& dir, NginxSite site, std::chrono::milliseconds timeout = kStartTimeout);

  ~NginxProcess();
  NginxProcess(const NginxProcess&) = delete;
  NginxProcess& operator=(const NginxProcess&) = delete;

  // "http://127.0.0.1:PORT", a mirror base URL.
  const std::string& url() const { return url_; }
  int port() const { return port_; }
  const std::filesystem::path& dir() const { return dir_; }
  // Where `{dir}/access.log` of the site's text lands.
  std::filesystem::path access_log() const { return dir_ / "access.log"; }
  ChildProcess& process() { return *process_; }

  // SIGSTOP / SIGCONT to the master and its workers: while paused, new
  // connections complete in the kernel's backlog and wait there unanswered.
  void Pause();
  void Resume();

 private:
  NginxProcess() = default;

  std::filesystem::path dir_;
  int port_ = 0;
  std::string url_;
  std::unique_ptr<ChildProcess> process_;
};

// The origin of a CDN serving `release_root` (holding v1/) as plain files,
// as release_format.md asks a static host to: ETags on, blobs and catalogs
// `Cache-Control: public, max-age=31536000, immutable`, channels
// `public, max-age=10`. Its access log has one line per request:
// "METHOD REQUEST_URI STATUS".
NginxSite OriginSite(const std::filesystem::path& release_root);

// A CDN edge caching everything `upstream_url` serves (in {dir}/cache, key
// "$scheme$proxy_host$uri": the query string is not part of it),
// collapsing concurrent misses of one path into one upstream request
// (proxy_cache_lock, held for as long as the upstream takes up to a
// minute), keeping 200s of blobs for a year and otherwise what the
// upstream's Cache-Control says, and naming the outcome in an
// X-Cache-Status header. Access log lines:
// "METHOD REQUEST_URI STATUS UPSTREAM_CACHE_STATUS".
NginxSite EdgeSite(const std::string& upstream_url, int worker_processes = 2);

// One line of an access log, split at spaces.
struct AccessLogLine {
  std::string method;
  std::string uri;
  int status = 0;
  std::string cache_status;  // the edge's 4th field; "" elsewhere ("-" for a request that never reached the cache)
};
// Every complete line of the access log at `path` (none if it is missing).
std::vector<AccessLogLine> ReadAccessLog(const std::filesystem::path& path);
// How many GET lines of `lines` have each URI that starts with `prefix`.
std::map<std::string, int> CountGets(const std::vector<AccessLogLine>& lines, const std::string& prefix);

// A loopback port that accepts connections (the kernel completes them into
// the listen backlog) and never reads or answers: a stalled upstream, for
// as long as this object lives. Deterministic, with no thread.
class SilentPort {
 public:
  SilentPort();
  ~SilentPort();
  SilentPort(const SilentPort&) = delete;
  SilentPort& operator=(const SilentPort&) = delete;
  int port() const { return port_; }

 private:
  int fd_ = -1;
  int port_ = 0;
};

// Raises this process's open-file soft limit to its hard limit (a fleet of
// caches holds a connection per download thread); children inherit it.
void RaiseOpenFileLimit();

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_DELIVERY_NGINX_PROCESS_H_
