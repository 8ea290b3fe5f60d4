// A file descriptor closed by its owner, movable: for a file an operation
// opens once and keeps using (the cache's partial downloads, kept open until
// the install has synced and cleaned them up).
#ifndef IMPOSTOR_CLIENT_BASE_UNIQUE_FD_H_
#define IMPOSTOR_CLIENT_BASE_UNIQUE_FD_H_

#include <unistd.h>

#include <utility>

namespace impostor::sdk {

class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) : fd_(fd) {}
  ~UniqueFd() { Reset(); }
  UniqueFd(UniqueFd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  UniqueFd& operator=(UniqueFd&& other) noexcept {
    if (this != &other) {
      Reset();
      fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
  }
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;

  int get() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  // Closes it now (dropping its flock, if it holds one).
  void Reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_BASE_UNIQUE_FD_H_
