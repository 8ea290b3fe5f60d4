// A small tmpfs that a full-disk test mounts on a directory of its own, and
// unmounts on scope exit (also when an assertion returns early). Mounting
// needs root: a test skips when mounted() is false, naming error().
#ifndef IMPOSTOR_TESTS_INTEGRATION_TMPFS_MOUNT_H_
#define IMPOSTOR_TESTS_INTEGRATION_TMPFS_MOUNT_H_

#include <sys/mount.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

namespace impostor::testing {

class TmpfsMount {
 public:
  // `size` as mount(8) takes it, e.g. "8m".
  explicit TmpfsMount(std::filesystem::path dir, const std::string& size = "8m") : dir_(std::move(dir)) {
    const std::string options = "size=" + size;
    mounted_ = ::mount("tmpfs", dir_.c_str(), "tmpfs", 0, options.c_str()) == 0;
    if (!mounted_) error_ = std::strerror(errno);
  }
  ~TmpfsMount() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
  }
  TmpfsMount(const TmpfsMount&) = delete;
  TmpfsMount& operator=(const TmpfsMount&) = delete;
  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }

 private:
  std::filesystem::path dir_;
  bool mounted_ = false;
  std::string error_;
};

}  // namespace impostor::testing

#endif  // IMPOSTOR_TESTS_INTEGRATION_TMPFS_MOUNT_H_
