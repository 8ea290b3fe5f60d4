#include "worker/bake/bake_outputs.h"

#include <fstream>

#include "absl/strings/str_cat.h"
#include "common/layout_parameters.h"
#include "common/sha256.h"

namespace impostor {

LayoutKind ToLayoutKind(v1::Layout layout) { return LayoutKindOf(layout); }

absl::StatusOr<v1::Digest> WriteFileWithDigest(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) return absl::InternalError(absl::StrCat("cannot write ", path.string()));
  v1::Digest d;
  d.set_hash(Sha256Hex(bytes));
  d.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return d;
}

}  // namespace impostor
