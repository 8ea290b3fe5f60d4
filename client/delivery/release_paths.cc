#include "client/delivery/release_paths.h"

#include "absl/strings/string_view.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace impostor::delivery {
namespace {

bool IsNameChar(char c) { return absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-'; }

std::string Shown(absl::string_view name) {
  // Names come from users and reports: shown clipped, never whole if huge.
  return name.size() <= 80 ? std::string(name) : absl::StrCat(name.substr(0, 80), "...");
}

}  // namespace

absl::Status ValidateAssetName(absl::string_view name, absl::string_view field) {
  auto bad = [&](absl::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat(field, " \"", Shown(name), "\": ", why));
  };
  if (name.empty()) return bad("must not be empty");
  if (name.size() > kMaxAssetNameLength) {
    return bad(absl::StrCat("is ", name.size(), " characters; the limit is ", kMaxAssetNameLength));
  }
  for (char c : name) {
    if (c != '/' && !IsNameChar(c)) {
      return bad("may hold only letters, digits and . _ - / (one character is outside that set)");
    }
  }
  if (name.front() == '/') return bad("must not start with / (names are relative)");
  if (name.back() == '/') return bad("must not end with /");
  for (absl::string_view segment : absl::StrSplit(name, '/')) {
    if (segment.empty()) return bad("has an empty segment (//)");
    if (segment == "." || segment == "..") return bad("has a . or .. segment");
  }
  return absl::OkStatus();
}

absl::Status ValidateChannelName(absl::string_view name, absl::string_view field) {
  auto bad = [&](absl::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat(field, " \"", Shown(name), "\": ", why));
  };
  if (name.empty()) return bad("must not be empty");
  if (name.size() > kMaxChannelNameLength) {
    return bad(absl::StrCat("is ", name.size(), " characters; the limit is ", kMaxChannelNameLength));
  }
  if (!absl::ascii_isalnum(static_cast<unsigned char>(name.front()))) return bad("must start with a letter or digit");
  for (char c : name) {
    if (!IsNameChar(c)) return bad("may hold only letters, digits and . _ -");
  }
  return absl::OkStatus();
}

std::string BlobPath(absl::string_view hex) { return absl::StrCat("v1/blobs/sha256/", hex.substr(0, 2), "/", hex); }

std::string CatalogPath(absl::string_view hex) {
  return absl::StrCat("v1/catalogs/sha256/", hex.substr(0, 2), "/", hex);
}

std::string ChannelPath(absl::string_view channel) { return absl::StrCat("v1/channels/", channel, ".json"); }

std::string JoinUrl(absl::string_view base, absl::string_view path) {
  while (!base.empty() && base.back() == '/') base.remove_suffix(1);
  while (!path.empty() && path.front() == '/') path.remove_prefix(1);
  return absl::StrCat(base, "/", path);
}

std::string MediaTypeForFile(absl::string_view file_name) {
  const std::string lower = absl::AsciiStrToLower(file_name);
  if (absl::EndsWith(lower, ".png")) return "image/png";
  if (absl::EndsWith(lower, ".ktx2")) return "image/ktx2";
  if (absl::EndsWith(lower, ".json")) return "application/json";
  if (absl::EndsWith(lower, ".glb")) return "model/gltf-binary";
  if (absl::EndsWith(lower, ".jpg") || absl::EndsWith(lower, ".jpeg")) return "image/jpeg";
  if (absl::EndsWith(lower, ".webp")) return "image/webp";
  return "application/octet-stream";
}

bool IsQualityViewSemantic(absl::string_view semantic) {
  return semantic == "contact_sheet" || semantic == "quality_worst_view" || semantic == "quality_view_mesh" ||
         semantic == "quality_view_impostor" || semantic == "quality_views";
}

}  // namespace impostor::delivery
