#include "worker/bake/bake_outputs.h"

#include <cmath>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "common/request/layout_parameters.h"
#include "common/manifest/manifest_json.h"
#include "common/util/sha256.h"
#include "worker/scene/bounding_sphere.h"

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

absl::StatusOr<AtlasBakeOutput> WriteManifest(const std::filesystem::path& dir, v1::Manifest manifest) {
  AtlasBakeOutput out;
  out.manifest_path = dir / "manifest.json";
  auto digest = WriteFileWithDigest(out.manifest_path, ManifestToJson(manifest));
  if (!digest.ok()) return digest.status();
  *manifest.mutable_manifest_json() = *digest;
  out.manifest = std::move(manifest);
  return out;
}

absl::StatusOr<BoundingSphere> FramingSphere(const Scene& scene) {
  const BoundingSphere sphere = ComputeBoundingSphere(scene);
  if (!(sphere.radius > 0.0f) || !std::isfinite(sphere.radius)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "mesh: its bounding sphere has radius ", sphere.radius, "; a mesh needs extent to be baked"));
  }
  return sphere;
}

}  // namespace impostor
