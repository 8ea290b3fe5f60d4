#include "worker/scene/texel_arena.h"

#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <new>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

thread_local TexelArena* current_arena = nullptr;

uint64_t PageSize() { return static_cast<uint64_t>(::sysconf(_SC_PAGESIZE)); }

// Unmaps a region when the last buffer viewing it goes.
struct Mapping {
  void* address = nullptr;
  size_t length = 0;
  ~Mapping() {
    if (address != nullptr) ::munmap(address, length);
  }
};

}  // namespace

TexelBuffer TexelArena::Copy(std::span<const uint8_t> bytes) {
  if (bytes.empty()) return TexelBuffer();
  const uint64_t page = PageSize();
  const uint64_t offset = end_;
  const uint64_t length = (bytes.size() + page - 1) / page * page;
  if (::ftruncate(fd_, static_cast<off_t>(offset + length)) != 0) throw std::bad_alloc();
  void* address = ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, static_cast<off_t>(offset));
  if (address == MAP_FAILED) throw std::bad_alloc();
  auto mapping = std::make_shared<Mapping>();
  mapping->address = address;
  mapping->length = length;
  std::memcpy(address, bytes.data(), bytes.size());
  end_ = offset + length;
  TexelBuffer buffer(std::shared_ptr<const void>(mapping, address),
                     std::span(static_cast<const uint8_t*>(address), bytes.size()));
  buffer.arena_ = this;
  buffer.arena_offset_ = offset;
  return buffer;
}

ScopedTexelArena::ScopedTexelArena(TexelArena* arena) : previous_(current_arena) { current_arena = arena; }
ScopedTexelArena::~ScopedTexelArena() { current_arena = previous_; }

TexelArena* CurrentTexelArena() { return current_arena; }

absl::StatusOr<MappedTexels> MapTexelArena(int fd) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) return absl::InternalError(absl::StrCat("fstat: ", std::strerror(errno)));
  if (st.st_size == 0) return MappedTexels{};
  const size_t size = static_cast<size_t>(st.st_size);
  // Populated at once: one call instead of a fault per page as the upload
  // reads them.
  void* address = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
  if (address == MAP_FAILED) return absl::InternalError(absl::StrCat("mmap: ", std::strerror(errno)));
  auto mapping = std::make_shared<Mapping>();
  mapping->address = address;
  mapping->length = size;
  return MappedTexels{std::shared_ptr<const void>(mapping, address),
                      std::span(static_cast<const uint8_t*>(address), size)};
}

}  // namespace impostor
