#include "server/auth/tls_file_monitor.h"

#include <sys/stat.h>

#include <chrono>
#include <utility>

#include <spdlog/spdlog.h>

#include "absl/strings/str_cat.h"
#include "common/util/log_escape.h"
#include "common/net/tls_files.h"

namespace impostor {
namespace {

constexpr int64_t kDaySeconds = 86400;
constexpr int64_t kExpiringSoonSeconds = 30 * kDaySeconds;

}  // namespace

TlsFileMonitor::TlsFileMonitor(ServerTlsOptions options, std::function<int64_t()> now_unix_seconds,
                               std::function<void(int64_t)> on_expiry)
    : options_(std::move(options)), now_(std::move(now_unix_seconds)), on_expiry_(std::move(on_expiry)) {
  fingerprint_ = Fingerprint();
  if (absl::StatusOr<std::string> cert = ReadServableCertificate(options_); cert.ok()) {
    if (absl::StatusOr<int64_t> not_after = CertificateNotAfter(*cert); not_after.ok()) not_after_ = *not_after;
  }
  // LogServerTls has just said whether it expires soon.
  expiring_logged_at_ = now_();
  if (on_expiry_ && not_after_ > 0) on_expiry_(not_after_);
}

TlsFileMonitor::~TlsFileMonitor() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void TlsFileMonitor::Start() {
  thread_ = std::thread([this] {
    std::unique_lock lock(mu_);
    while (!stop_) {
      // A periodic timer (gRPC's own reload period), not synchronisation.
      stop_cv_.wait_for(lock, std::chrono::seconds(options_.reload_seconds), [this] { return stop_; });
      if (stop_) break;
      lock.unlock();
      (void)CheckNow();
      lock.lock();
    }
  });
}

std::string TlsFileMonitor::Fingerprint() const {
  std::string out;
  for (const std::string* path : {&options_.cert_file, &options_.key_file, &options_.client_ca_file}) {
    if (path->empty()) continue;
    struct stat st {};
    if (::stat(path->c_str(), &st) != 0) {
      absl::StrAppend(&out, *path, ":missing;");
      continue;
    }
    absl::StrAppend(&out, *path, ":", st.st_ino, ":", st.st_size, ":", st.st_mtim.tv_sec, ".", st.st_mtim.tv_nsec,
                    ";");
  }
  return out;
}

absl::Status TlsFileMonitor::CheckNow() {
  std::lock_guard lock(mu_);
  const int64_t now = now_();
  absl::Status refused;
  if (const std::string fingerprint = Fingerprint(); fingerprint != fingerprint_) {
    fingerprint_ = fingerprint;
    absl::StatusOr<std::string> cert = ReadServableCertificate(options_);
    absl::StatusOr<int64_t> not_after = cert.ok() ? CertificateNotAfter(*cert) : cert.status();
    if (!not_after.ok()) {
      refused = not_after.status();
      if (refused.message() != last_error_) {
        last_error_ = std::string(refused.message());
        // Some reasons name the flags only (a key that does not match).
        if (last_error_.find(options_.cert_file) == std::string::npos &&
            last_error_.find(options_.key_file) == std::string::npos) {
          last_error_ += absl::StrCat(" (--tls-cert ", options_.cert_file, ", --tls-key ", options_.key_file, ")");
        }
        spdlog::error("event=tls_files_refused error=\"{}\" note=\"every new TLS connection fails until the files "
                      "are fixed; open ones keep working\"",
                      EscapeUntrusted(last_error_));
        not_after_ = 0;
        if (on_expiry_) on_expiry_(0);
      }
    } else {
      last_error_.clear();
      not_after_ = *not_after;
      expired_logged_ = false;
      expiring_logged_at_ = 0;
      // An expired one is served too, but is no reload to announce: the
      // tls_cert_expired line below says what it is.
      if (not_after_ > now) {
        spdlog::info("event=tls_reloaded cert={} cert_expires=\"{}\"", options_.cert_file, FormatUtc(not_after_));
      }
      if (on_expiry_) on_expiry_(not_after_);
    }
  } else if (!last_error_.empty()) {
    refused = absl::InvalidArgumentError(last_error_);
  }

  // The certificate in use (none while the files are refused).
  if (not_after_ > 0 && now >= not_after_) {
    if (!expired_logged_) {
      expired_logged_ = true;
      spdlog::error("event=tls_cert_expired cert={} expired=\"{}\" note=\"clients refuse every new connection; "
                    "replace --tls-cert and --tls-key\"",
                    options_.cert_file, FormatUtc(not_after_));
    }
    if (refused.ok()) {
      refused = absl::FailedPreconditionError(
          absl::StrCat("--tls-cert: ", options_.cert_file, ": expired on ", FormatUtc(not_after_)));
    }
  } else if (not_after_ > 0 && not_after_ - now < kExpiringSoonSeconds && now - expiring_logged_at_ >= kDaySeconds) {
    expiring_logged_at_ = now;
    spdlog::warn("event=tls_cert_expiring_soon cert={} days_left={}", options_.cert_file,
                 (not_after_ - now) / kDaySeconds);
  }
  return refused;
}

}  // namespace impostor
