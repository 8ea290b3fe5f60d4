#include "server/scheduler/manifest_stamp.h"

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
  // Depth is checked while parsing: nothing deeper is ever built, so the
  // recursive dump and destructor below stay shallow (a worker's 120 KB of
  // nested brackets crashed the server on the stack).
  bool too_deep = false;
  nlohmann::json j = nlohmann::json::parse(
      *text,
      [&too_deep](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
        if (depth > kMaxManifestDepth) too_deep = true;
        return !too_deep;
      },
      /*allow_exceptions=*/false);
  if (too_deep) {
    return absl::InvalidArgumentError(
        absl::StrCat("result.manifest_json: nested deeper than ", kMaxManifestDepth, " levels"));
  }
  if (!j.is_object()) return absl::InvalidArgumentError("result.manifest_json: not a JSON object");
  j["baked_by"] = baked_by;
  // Indented for people reading manifest.json, unless that inflates it:
  // indentation grows with depth per element (a deep array of small numbers
  // grows 30-fold), so then it stays compact, about the upload's size.
  // Invalid UTF-8 from a worker must not throw: replace it.
  std::string stamped = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  if (manifest_json.size_bytes() <= kMaxIndentedManifestBytes) {
    std::string indented = j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    if (indented.size() <= kMaxIndentGrowth * stamped.size() + kIndentAllowanceBytes) stamped = std::move(indented);
  }
  const BlobDigest digest{Sha256Hex(stamped), static_cast<int64_t>(stamped.size())};
  if (auto put = blobs.Put(digest, stamped); !put.ok()) return put.status();
  v1::Digest out;
  out.set_hash(digest.hash);
  out.set_size_bytes(digest.size_bytes);
  return out;
}

}  // namespace impostor
