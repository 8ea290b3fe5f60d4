// A small tmpfs that a full-disk test mounts on a directory of its own, and
// unmounts on scope exit (also when an assertion returns early). Mounting
// needs root: a test skips when mounted() is false, naming error().
#ifndef IMPOSTOR_TESTS_INTEGRATION_TMPFS_MOUNT_H_
#define IMPOSTOR_TESTS_INTEGRATION_TMPFS_MOUNT_H_

#include <sys/mount.h>

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
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

// Writes `path` until the filesystem refuses another byte.
inline void FillDisk(const std::filesystem::path& path) {
  std::ofstream out(path, std::ios::binary);
  const std::string chunk(4096, 'f');
  while (out.write(chunk.data(), static_cast<std::streamsize>(chunk.size())) && out.flush()) {
  }
}

}  // namespace impostor::testing

// Declares `tmpfs`, an 8 MiB tmpfs on `mount_dir`, or skips the test (not
// root, or the mount failed); `what` names what the test puts there.
#define IMPOSTOR_MOUNT_TMPFS_OR_SKIP(mount_dir, tmpfs, what)                                          \
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a tmpfs for " << (what);              \
  ::impostor::testing::TmpfsMount tmpfs(mount_dir, "8m");                                           \
  if (!tmpfs.mounted()) GTEST_SKIP() << "cannot mount a tmpfs on " << (mount_dir) << ": " << tmpfs.error()

#endif  // IMPOSTOR_TESTS_INTEGRATION_TMPFS_MOUNT_H_
