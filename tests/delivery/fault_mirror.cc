#include "tests/delivery/fault_mirror.h"

#include <httplib.h>

#include <chrono>
#include <fstream>
#include <sstream>

#include "absl/strings/match.h"
#include "common/net/farm_http_base.h"

namespace impostor::testing {
namespace {

std::string ReadAll(const std::filesystem::path& path, bool* found) {
  std::ifstream in(path, std::ios::binary);
  *found = static_cast<bool>(in);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

FaultMirror::FaultMirror(std::filesystem::path root) : root_(std::move(root)), server_(new httplib::Server) {
  // As the farm's own front end: without it each request after a kept-alive
  // connection's first waits 40 ms for a delayed ACK.
  server_->set_tcp_nodelay(true);
  server_->Get(R"(/(v1/.*))", [this](const httplib::Request& req, httplib::Response& res) {
    const std::string path = req.matches[1];
    Fault fault;
    {
      std::lock_guard lock(mu_);
      requests_[path] += 1;
      auto it = faults_.find(path);
      fault = it == faults_.end() ? Fault::kNone : it->second;
    }
    if (path.find("..") != std::string::npos) {
      res.status = 404;
      return;
    }
    bool found = false;
    std::string bytes = ReadAll(root_ / path, &found);
    // A farm result's listing (.../results/KEY/manifest), as the farm sends
    // it: its digest of the bytes before any fault spoils them.
    const bool listing = absl::EndsWith(path, "/manifest");
    if (listing && found) res.set_header(kReprDigestHeader, ReprDigestSha256(bytes));
    switch (fault) {
      case Fault::kNotFound: found = false; break;
      case Fault::kFlipByte:
        if (!bytes.empty()) bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x20);
        break;
      case Fault::kHtml200:
        res.status = 200;
        res.set_content("<html><body><h1>Service Unavailable</h1>Please try again later.</body></html>",
                        "text/html");
        return;
      case Fault::kTruncate: bytes.resize(bytes.size() / 2); break;
      case Fault::kStall: {
        std::unique_lock lock(mu_);
        stopping_cv_.wait_for(lock, std::chrono::seconds(30), [this] { return stopping_; });
        res.status = 503;
        return;
      }
      case Fault::kNone: break;
    }
    if (!found) {
      res.status = 404;
      res.set_content("not found", "text/plain");
      return;
    }
    res.set_header("ETag", "\"" + std::to_string(std::hash<std::string>{}(bytes)) + "\"");
    // cpp-httplib answers Range requests on set_content (206, Content-Range).
    res.set_content(bytes, listing                                       ? kResultManifestMediaType
                           : path.find("channels/") != std::string::npos ? "application/json"
                                                                         : "application/octet-stream");
  });
  // Stop() waits for idle keep-alive connections to time out, and an SDK
  // thread keeps its connection open: 1 s instead of the library's 5.
  server_->set_keep_alive_timeout(1);
  port_ = server_->bind_to_any_port("127.0.0.1");
  thread_ = std::thread([this] { server_->listen_after_bind(); });
  // bind_to_any_port listens already: connections queue until the loop
  // accepts them.
}

FaultMirror::~FaultMirror() { Stop(); }

void FaultMirror::Stop() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  stopping_cv_.notify_all();
  if (server_ != nullptr) server_->stop();
  if (thread_.joinable()) thread_.join();
}

std::string FaultMirror::url() const { return "http://127.0.0.1:" + std::to_string(port_); }

void FaultMirror::SetFault(const std::string& path, Fault fault) {
  std::lock_guard lock(mu_);
  faults_[path] = fault;
}

int FaultMirror::Requests(const std::string& path) {
  std::lock_guard lock(mu_);
  auto it = requests_.find(path);
  return it == requests_.end() ? 0 : it->second;
}

int FaultMirror::TotalRequests() {
  std::lock_guard lock(mu_);
  int n = 0;
  for (const auto& [path, count] : requests_) n += count;
  return n;
}

}  // namespace impostor::testing
