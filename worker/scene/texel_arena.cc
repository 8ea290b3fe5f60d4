#include "worker/scene/texel_arena.h"

#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <new>
#include <vector>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

thread_local TexelArena* current_arena = nullptr;

// Texel memfds whose scene is gone, kept with their pages for the next
// load: writing into pages that exist costs a copy, where a new memfd's
// pages are allocated and zeroed first (what made the isolated load slower
// than an in-process load, whose heap is warm).
constexpr size_t kMaxIdleTexelFds = 2;
constexpr off_t kMaxRecycledBytes = off_t{512} << 20;

struct TexelFdPool {
  std::mutex mu;
  std::vector<int> idle;
};

TexelFdPool& FdPool() {
  static TexelFdPool* pool = new TexelFdPool();
  return *pool;
}

void GiveBackTexelFd(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) == 0 && st.st_size <= kMaxRecycledBytes) {
    TexelFdPool& pool = FdPool();
    std::lock_guard<std::mutex> lock(pool.mu);
    if (pool.idle.size() < kMaxIdleTexelFds) {
      pool.idle.push_back(fd);
      return;
    }
  }
  ::close(fd);
}

uint64_t PageSize() { return static_cast<uint64_t>(::sysconf(_SC_PAGESIZE)); }

void GiveBackTexelFd(int fd);

// Unmaps a region when the last buffer viewing it goes (and gives the
// memfd behind it back for the next load, when it is one).
struct Mapping {
  void* address = nullptr;
  size_t length = 0;
  int recycle_fd = -1;
  ~Mapping() {
    if (address != nullptr) ::munmap(address, length);
    if (recycle_fd >= 0) GiveBackTexelFd(recycle_fd);
  }
};

}  // namespace

TexelBuffer TexelArena::Copy(std::span<const uint8_t> bytes) {
  if (bytes.empty()) return TexelBuffer();
  const uint64_t page = PageSize();
  const uint64_t length = (bytes.size() + page - 1) / page * page;
  uint64_t offset;
  {
    // The region is this call's from here on; mapping and copying it need
    // no lock.
    std::lock_guard lock(mu_);
    offset = end_;
    // A recycled memfd (TakeTexelFd) is already long enough, its pages
    // there to be overwritten: it only ever grows.
    if (size_ < 0) {
      struct stat st {};
      size_ = ::fstat(fd_, &st) == 0 ? st.st_size : 0;
    }
    if (static_cast<uint64_t>(size_) < offset + length) {
      if (::ftruncate(fd_, static_cast<off_t>(offset + length)) != 0) throw std::bad_alloc();
      size_ = static_cast<off_t>(offset + length);
    }
    end_ = offset + length;
  }
  // Populated at once: the decoder's copy then writes into pages that are
  // there, instead of taking a fault per page.
  void* address =
      ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_POPULATE, fd_, static_cast<off_t>(offset));
  if (address == MAP_FAILED) throw std::bad_alloc();
  auto mapping = std::make_shared<Mapping>();
  mapping->address = address;
  mapping->length = length;
  std::memcpy(address, bytes.data(), bytes.size());
  TexelBuffer buffer(std::shared_ptr<const void>(mapping, address),
                     std::span(static_cast<const uint8_t*>(address), bytes.size()));
  buffer.arena_ = this;
  buffer.arena_offset_ = offset;
  return buffer;
}

ScopedTexelArena::ScopedTexelArena(TexelArena* arena) : previous_(current_arena) { current_arena = arena; }
ScopedTexelArena::~ScopedTexelArena() { current_arena = previous_; }

TexelArena* CurrentTexelArena() { return current_arena; }

int TakeTexelFd() {
  {
    TexelFdPool& pool = FdPool();
    std::lock_guard<std::mutex> lock(pool.mu);
    if (!pool.idle.empty()) {
      const int fd = pool.idle.back();
      pool.idle.pop_back();
      return fd;
    }
  }
  return ::memfd_create("impostor-texels", MFD_CLOEXEC);
}

absl::StatusOr<MappedTexels> MapTexelArena(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    ::close(fd);
    return absl::InternalError(absl::StrCat("fstat: ", std::strerror(err)));
  }
  if (st.st_size == 0) {
    GiveBackTexelFd(fd);
    return MappedTexels{};
  }
  const size_t size = static_cast<size_t>(st.st_size);
  // Populated at once: one call instead of a fault per page as the upload
  // reads them.
  void* address = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
  if (address == MAP_FAILED) {
    const int err = errno;
    ::close(fd);
    return absl::InternalError(absl::StrCat("mmap: ", std::strerror(err)));
  }
  auto mapping = std::make_shared<Mapping>();
  mapping->address = address;
  mapping->length = size;
  mapping->recycle_fd = fd;
  return MappedTexels{std::shared_ptr<const void>(mapping, address),
                      std::span(static_cast<const uint8_t*>(address), size)};
}

}  // namespace impostor
