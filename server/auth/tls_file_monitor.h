// Says what gRPC's certificate reload does not. gRPC re-reads the TLS files
// every --tls-reload-seconds (tls_credentials.h) and takes whatever it
// finds: files it cannot use (missing, not PEM, a key that does not match
// the certificate) make every new handshake fail, and an expired
// certificate is served as it is, so every client refuses it. Either way
// gRPC's own log names neither the flag nor the certificate. This monitor
// checks the same files on the same period with the start's checks
// (ReadServableCertificate) and logs one line per change of outcome:
//  - event=tls_reloaded (info): new files in use, with the expiry;
//  - event=tls_files_refused (error): the flags, the files and why; new
//    connections fail until the files are fixed;
//  - event=tls_cert_expired (error): the certificate in use expired
//    (swapped in so, or run out while served);
//  - event=tls_cert_expiring_soon (warn): fewer than 30 days left, once a
//    day.
// A callback gets the served certificate's expiry (Unix seconds; 0 while
// the files are unusable), for the impostor_tls_cert_expiry_timestamp_seconds
// gauge: an alert on it catches both.
//
// Thread-safety: CheckNow may be called from any thread; the destructor
// stops the monitor's thread.
#ifndef IMPOSTOR_SERVER_AUTH_TLS_FILE_MONITOR_H_
#define IMPOSTOR_SERVER_AUTH_TLS_FILE_MONITOR_H_

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "server/auth/tls_credentials.h"

namespace impostor {

class TlsFileMonitor {
 public:
  // `options` must have TLS enabled and have passed ValidateServerTls (the
  // files as they are now are the ones served). `now_unix_seconds` is the
  // clock (tests pass their own). `on_expiry` (may be empty) is called with
  // the expiry of the certificate in use, at construction and at each
  // reload.
  TlsFileMonitor(ServerTlsOptions options, std::function<int64_t()> now_unix_seconds,
                 std::function<void(int64_t not_after)> on_expiry);
  ~TlsFileMonitor();
  TlsFileMonitor(const TlsFileMonitor&) = delete;
  TlsFileMonitor& operator=(const TlsFileMonitor&) = delete;

  // Starts checking every options.reload_seconds on a thread of its own.
  void Start();
  // One check now: the files' state (OK, or the error that was logged).
  absl::Status CheckNow();

 private:
  // Identity of the three files (path, size, mtime, inode): a change
  // means gRPC will read them again.
  std::string Fingerprint() const;

  const ServerTlsOptions options_;
  const std::function<int64_t()> now_;
  const std::function<void(int64_t)> on_expiry_;

  std::mutex mu_;
  std::string fingerprint_;
  std::string last_error_;        // the refusal last logged ('' when none)
  int64_t not_after_ = 0;         // of the certificate in use; 0 while the files are unusable
  bool expired_logged_ = false;
  int64_t expiring_logged_at_ = 0;  // Unix seconds of the last expiring-soon line

  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace impostor

#endif  // IMPOSTOR_SERVER_AUTH_TLS_FILE_MONITOR_H_
