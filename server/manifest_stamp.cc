#include "server/manifest_stamp.h"

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"

namespace impostor {

absl::StatusOr<v1::Digest> StampBakedBy(BlobStore& blobs, const v1::Digest& manifest_json,
                                        const std::string& baked_by) {
  if (manifest_json.size_bytes() > kMaxStampedManifestBytes) {
    return absl::InvalidArgumentError(absl::StrCat("result.manifest_json: ", manifest_json.size_bytes(),
                                                   " bytes, the limit is ", kMaxStampedManifestBytes));
  }
  auto text = blobs.ReadAll({manifest_json.hash(), manifest_json.size_bytes()});
  if (absl::IsNotFound(text.status())) {
    return absl::FailedPreconditionError("result.manifest_json: blob is not in the store; upload it first");
  }
  if (!text.ok()) return text.status();
  nlohmann::json j = nlohmann::json::parse(*text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return absl::InvalidArgumentError("result.manifest_json: not a JSON object");
  j["baked_by"] = baked_by;
  // Invalid UTF-8 from a worker must not throw: replace it.
  const std::string stamped = j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  const BlobDigest digest{Sha256Hex(stamped), static_cast<int64_t>(stamped.size())};
  if (auto put = blobs.Put(digest, stamped); !put.ok()) return put.status();
  v1::Digest out;
  out.set_hash(digest.hash);
  out.set_size_bytes(digest.size_bytes);
  return out;
}

}  // namespace impostor
