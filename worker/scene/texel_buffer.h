// The bytes of a decoded texture (RGBA8), shared and read-only once built.
//
// A scene's textures are most of its memory (a 2048² map is 16 MiB), and
// they are written once, by the decoder, then only read (uploaded to the
// GPU). TexelBuffer lets them live wherever they were decoded: on the heap
// in an in-process load, or in the isolated loader's shared memory
// (texel_arena.h), which the worker maps instead of copying. Copies share
// the bytes (a glTF image used with two samplers is one buffer).
//
// Building one element by element (tests, procedural textures) works as on
// a vector: a mutator first makes the bytes this buffer's own.
//
// Thread-safety: like a const std::vector once built; mutators are not
// thread-safe.
#ifndef IMPOSTOR_WORKER_SCENE_TEXEL_BUFFER_H_
#define IMPOSTOR_WORKER_SCENE_TEXEL_BUFFER_H_

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <span>
#include <vector>

namespace impostor {

class TexelArena;

class TexelBuffer {
 public:
  using value_type = uint8_t;
  using size_type = size_t;
  using const_iterator = const uint8_t*;
  using iterator = const_iterator;

  TexelBuffer() = default;
  TexelBuffer(std::initializer_list<uint8_t> bytes) : TexelBuffer(std::vector<uint8_t>(bytes)) {}
  explicit TexelBuffer(std::vector<uint8_t> bytes);
  // A view of bytes someone else owns; `owner` keeps them alive.
  TexelBuffer(std::shared_ptr<const void> owner, std::span<const uint8_t> bytes)
      : owner_(std::move(owner)), data_(bytes.data()), size_(bytes.size()) {}

  // A copy of `bytes`, in the texel arena installed on this thread
  // (ScopedTexelArena) when there is one, else on the heap. Throws
  // std::bad_alloc when neither can hold it.
  static TexelBuffer CopyOf(std::span<const uint8_t> bytes);

  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const_iterator begin() const { return data_; }
  const_iterator end() const { return data_ + size_; }
  uint8_t operator[](size_t i) const { return data_[i]; }
  std::span<const uint8_t> span() const { return {data_, size_}; }

  // The arena holding these bytes and their offset in it, when they are in
  // one (the isolated loader's child hands such textures over by offset).
  const TexelArena* arena() const { return arena_; }
  uint64_t arena_offset() const { return arena_offset_; }

  void push_back(uint8_t value) { Own().push_back(value), Refresh(); }
  void assign(size_t count, uint8_t value) { Own().assign(count, value), Refresh(); }
  void clear() { *this = TexelBuffer(); }
  uint8_t* mutable_data() { return Own().data(); }

  friend bool operator==(const TexelBuffer& a, const TexelBuffer& b) { return Equal(a.span(), b.span()); }
  friend bool operator==(const TexelBuffer& a, const std::vector<uint8_t>& b) { return Equal(a.span(), b); }

 private:
  friend class TexelArena;
  static bool Equal(std::span<const uint8_t> a, std::span<const uint8_t> b);
  // The heap vector behind this buffer, made its own first (copied out of
  // an arena or away from other buffers sharing it).
  std::vector<uint8_t>& Own();
  void Refresh() { data_ = heap_->data(), size_ = heap_->size(); }

  std::shared_ptr<const void> owner_;
  std::shared_ptr<std::vector<uint8_t>> heap_;  // set when the bytes are on the heap
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
  const TexelArena* arena_ = nullptr;
  uint64_t arena_offset_ = 0;
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_SCENE_TEXEL_BUFFER_H_
