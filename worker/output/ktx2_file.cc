#include "worker/output/ktx2_file.h"

#include <algorithm>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace impostor {
namespace {

constexpr unsigned char kIdentifier[12] = {0xAB, 'K', 'T', 'X', ' ', '2', '0', 0xBB, '\r', '\n', 0x1A, '\n'};
constexpr size_t kHeaderBytes = 80;
constexpr size_t kLevelIndexEntryBytes = 24;

template <typename T>
T Load(std::string_view b, size_t at) {
  T v{};
  std::memcpy(&v, b.data() + at, sizeof(T));  // KTX2 is little-endian, as is every target here
  return v;
}

template <typename T>
void Store(std::string* b, size_t at, T v) {
  std::memcpy(b->data() + at, &v, sizeof(T));
}

bool Inside(uint64_t offset, uint64_t length, size_t size) { return offset <= size && length <= size - offset; }

size_t AlignUp(size_t v, size_t a) { return a <= 1 ? v : (v + a - 1) / a * a; }

}  // namespace

uint32_t Ktx2Texture::ColorModel() const {
  // dfdTotalSize, then the basic block: descriptor type/vendor (4),
  // versionNumber/descriptorBlockSize (4), colorModel (1 byte), ...
  return dfd.size() >= 16 ? static_cast<uint8_t>(dfd[12]) : 0;
}

uint32_t Ktx2Texture::Transfer() const { return dfd.size() >= 16 ? static_cast<uint8_t>(dfd[14]) : 0; }

absl::StatusOr<Ktx2Texture> ParseKtx2(std::string_view b) {
  if (b.size() < kHeaderBytes || std::memcmp(b.data(), kIdentifier, sizeof(kIdentifier)) != 0) {
    return absl::InvalidArgumentError("ktx2: no KTX 2.0 identifier");
  }
  Ktx2Texture t;
  t.vk_format = Load<uint32_t>(b, 12);
  t.type_size = Load<uint32_t>(b, 16);
  t.width = Load<uint32_t>(b, 20);
  t.height = Load<uint32_t>(b, 24);
  const uint32_t depth = Load<uint32_t>(b, 28), layers = Load<uint32_t>(b, 32), faces = Load<uint32_t>(b, 36);
  const uint32_t levels = Load<uint32_t>(b, 40);
  t.supercompression = Load<uint32_t>(b, 44);
  if (depth != 0 || layers != 0 || faces != 1) {
    return absl::InvalidArgumentError(absl::StrCat("ktx2: pixelDepth ", depth, ", layerCount ", layers,
                                                   ", faceCount ", faces, "; only 2D textures are read"));
  }
  if (t.width == 0 || t.height == 0) return absl::InvalidArgumentError("ktx2: pixelWidth/pixelHeight is 0");
  const uint32_t level_count = std::max<uint32_t>(levels, 1);
  if (level_count > 32) return absl::InvalidArgumentError(absl::StrCat("ktx2: levelCount ", levels, " > 32"));
  const uint32_t dfd_off = Load<uint32_t>(b, 48), dfd_len = Load<uint32_t>(b, 52);
  const uint32_t kvd_off = Load<uint32_t>(b, 56), kvd_len = Load<uint32_t>(b, 60);
  const uint64_t sgd_off = Load<uint64_t>(b, 64), sgd_len = Load<uint64_t>(b, 72);
  if (!Inside(dfd_off, dfd_len, b.size()) || dfd_len < 4) return absl::InvalidArgumentError("ktx2: dfdByteOffset/Length");
  if (!Inside(kvd_off, kvd_len, b.size())) return absl::InvalidArgumentError("ktx2: kvdByteOffset/Length");
  if (!Inside(sgd_off, sgd_len, b.size())) return absl::InvalidArgumentError("ktx2: sgdByteOffset/Length");
  if (!Inside(kHeaderBytes, uint64_t{level_count} * kLevelIndexEntryBytes, b.size())) {
    return absl::InvalidArgumentError("ktx2: level index runs past the end of the file");
  }
  t.dfd = std::string(b.substr(dfd_off, dfd_len));
  if (Load<uint32_t>(t.dfd, 0) != dfd_len) return absl::InvalidArgumentError("ktx2: dfdTotalSize != dfdByteLength");
  t.kvd = std::string(b.substr(kvd_off, kvd_len));
  t.sgd = std::string(b.substr(sgd_off, sgd_len));
  for (uint32_t i = 0; i < level_count; ++i) {
    const size_t at = kHeaderBytes + i * kLevelIndexEntryBytes;
    const uint64_t off = Load<uint64_t>(b, at), len = Load<uint64_t>(b, at + 8);
    if (!Inside(off, len, b.size())) {
      return absl::InvalidArgumentError(absl::StrCat("ktx2: level ", i, " lies outside the file"));
    }
    t.levels.push_back({std::string(b.substr(off, len)), Load<uint64_t>(b, at + 16)});
  }
  return t;
}

absl::StatusOr<std::string> SerializeKtx2(const Ktx2Texture& t) {
  if (t.levels.empty()) return absl::InvalidArgumentError("ktx2: no levels");
  if (t.dfd.size() < 16) return absl::InvalidArgumentError("ktx2: the DFD has no basic descriptor block");
  const size_t n = t.levels.size();
  const size_t dfd_off = kHeaderBytes + n * kLevelIndexEntryBytes;
  const size_t kvd_off = dfd_off + t.dfd.size();
  size_t end = kvd_off + t.kvd.size();
  const size_t sgd_off = t.sgd.empty() ? 0 : AlignUp(end, 8);
  if (!t.sgd.empty()) end = sgd_off + t.sgd.size();
  // Level alignment (spec 3.9.7): lcm(texel block size, 4) without
  // supercompression (16 for UASTC's 16-byte blocks), 1 with it.
  const size_t align = t.supercompression == kKtx2SupercompressionNone ? 16 : 1;
  std::vector<size_t> offsets(n);
  for (size_t i = n; i-- > 0;) {  // smallest level first in the file
    end = AlignUp(end, align);
    offsets[i] = end;
    end += t.levels[i].data.size();
  }
  std::string out(end, '\0');
  std::memcpy(out.data(), kIdentifier, sizeof(kIdentifier));
  Store<uint32_t>(&out, 12, t.vk_format);
  Store<uint32_t>(&out, 16, t.type_size);
  Store<uint32_t>(&out, 20, t.width);
  Store<uint32_t>(&out, 24, t.height);
  Store<uint32_t>(&out, 28, 0);
  Store<uint32_t>(&out, 32, 0);
  Store<uint32_t>(&out, 36, 1);
  Store<uint32_t>(&out, 40, static_cast<uint32_t>(n));
  Store<uint32_t>(&out, 44, t.supercompression);
  Store<uint32_t>(&out, 48, static_cast<uint32_t>(dfd_off));
  Store<uint32_t>(&out, 52, static_cast<uint32_t>(t.dfd.size()));
  Store<uint32_t>(&out, 56, t.kvd.empty() ? 0u : static_cast<uint32_t>(kvd_off));
  Store<uint32_t>(&out, 60, static_cast<uint32_t>(t.kvd.size()));
  Store<uint64_t>(&out, 64, sgd_off);
  Store<uint64_t>(&out, 72, t.sgd.size());
  for (size_t i = 0; i < n; ++i) {
    const size_t at = kHeaderBytes + i * kLevelIndexEntryBytes;
    Store<uint64_t>(&out, at, offsets[i]);
    Store<uint64_t>(&out, at + 8, t.levels[i].data.size());
    Store<uint64_t>(&out, at + 16, t.levels[i].uncompressed_byte_length);
    std::memcpy(out.data() + offsets[i], t.levels[i].data.data(), t.levels[i].data.size());
  }
  std::memcpy(out.data() + dfd_off, t.dfd.data(), t.dfd.size());
  std::memcpy(out.data() + kvd_off, t.kvd.data(), t.kvd.size());
  if (!t.sgd.empty()) std::memcpy(out.data() + sgd_off, t.sgd.data(), t.sgd.size());
  return out;
}

}  // namespace impostor
