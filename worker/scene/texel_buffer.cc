#include "worker/scene/texel_buffer.h"

#include <cstring>

#include "worker/scene/texel_arena.h"

namespace impostor {

TexelBuffer::TexelBuffer(std::vector<uint8_t> bytes)
    : heap_(std::make_shared<std::vector<uint8_t>>(std::move(bytes))) {
  owner_ = heap_;
  Refresh();
}

TexelBuffer TexelBuffer::CopyOf(std::span<const uint8_t> bytes) {
  if (TexelArena* arena = CurrentTexelArena()) return arena->Copy(bytes);
  return TexelBuffer(std::vector<uint8_t>(bytes.begin(), bytes.end()));
}

bool TexelBuffer::Equal(std::span<const uint8_t> a, std::span<const uint8_t> b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size()) == 0);
}

std::vector<uint8_t>& TexelBuffer::Own() {
  if (!heap_ || heap_.use_count() > 1) {
    heap_ = std::make_shared<std::vector<uint8_t>>(begin(), end());
    owner_ = heap_;
    arena_ = nullptr;
    arena_offset_ = 0;
    Refresh();
  }
  return *heap_;
}

}  // namespace impostor
