// Test helper: an HTTP mirror of a release tree (cpp-httplib, in process,
// on 127.0.0.1 and a kernel-chosen port) that can misbehave per path: serve
// a flipped byte, an HTML page with status 200, a truncated body, a 404, or
// stall (send nothing until the test ends). Counts the requests per path,
// so a test can tell which source gave each file. Range requests are
// answered as a static host does (206 from the asked offset). A path
// ending in "/manifest" is a farm result's listing: sent as the farm sends
// it (its media type, a Repr-Digest of the file's unspoiled bytes).
//
// Threads: the server answers on its own pool; every method may be called
// from any thread. The destructor stops the server (stalled handlers end).
#ifndef IMPOSTOR_TESTS_DELIVERY_FAULT_MIRROR_H_
#define IMPOSTOR_TESTS_DELIVERY_FAULT_MIRROR_H_

#include <condition_variable>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace httplib {
class Server;
}

namespace impostor::testing {

enum class Fault { kNone, kFlipByte, kHtml200, kTruncate, kStall, kNotFound };

class FaultMirror {
 public:
  explicit FaultMirror(std::filesystem::path root);
  ~FaultMirror();
  FaultMirror(const FaultMirror&) = delete;
  FaultMirror& operator=(const FaultMirror&) = delete;

  // Base URL: "http://127.0.0.1:PORT".
  std::string url() const;
  // `path` relative to the root, e.g. "v1/blobs/sha256/ab/ab...".
  void SetFault(const std::string& path, Fault fault);
  int Requests(const std::string& path);
  int TotalRequests();
  // Stops answering (connections refused afterwards).
  void Stop();

 private:
  std::filesystem::path root_;
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  int port_ = 0;
  std::mutex mu_;
  std::condition_variable stopping_cv_;
  bool stopping_ = false;
  std::map<std::string, Fault> faults_;
  std::map<std::string, int> requests_;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_DELIVERY_FAULT_MIRROR_H_
