#include "client/base/early_sync.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <utility>

#include "client/base/local_io_error.h"

namespace impostor::sdk {

EarlySync::~EarlySync() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
    pending_.clear();
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void EarlySync::Add(int fd, int64_t size_bytes, const std::filesystem::path& name) {
  if (fd < 0 || size_bytes < kMinBytes) return;
  std::lock_guard lock(mu_);
  if (stopping_ || pending_.size() >= kMaxPending || !first_error_.ok()) return;
  UniqueFd copy(::fcntl(fd, F_DUPFD_CLOEXEC, 0));
  if (!copy.valid()) return;  // out of descriptors: the final sync covers it
  pending_.push_back({std::move(copy), name});
  if (!thread_.joinable()) thread_ = std::thread([this] { Run(); });
  cv_.notify_all();
}

void EarlySync::Run() {
  std::unique_lock lock(mu_);
  for (;;) {
    cv_.wait(lock, [this] { return stopping_ || !pending_.empty(); });
    if (stopping_) return;
    Pending next = std::move(pending_.front());
    pending_.pop_front();
    syncing_ = true;
    lock.unlock();
    const int rc = ::fdatasync(next.fd.get());
    const int err = errno;
    next.fd.Reset();
    lock.lock();
    syncing_ = false;
    if (rc != 0 && first_error_.ok()) {
      first_error_ = LocalIoError("cannot sync", next.name, err);
      pending_.clear();
    } else if (rc == 0) {
      ++synced_;
    }
    cv_.notify_all();
  }
}

absl::Status EarlySync::Finish() {
  std::unique_lock lock(mu_);
  cv_.wait(lock, [this] { return pending_.empty() && !syncing_; });
  return first_error_;
}

int EarlySync::synced() const {
  std::lock_guard lock(mu_);
  return synced_;
}

}  // namespace impostor::sdk
