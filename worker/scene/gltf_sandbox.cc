#include "worker/scene/gltf_sandbox.h"

#include <cctype>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/util/percent_decode.h"

namespace impostor::gltf_internal {
namespace {

namespace fs = std::filesystem;

// Largest external file tinygltf may read: glTF buffers are at most 2^32
// bytes by the GLB format and tinygltf indexes images with int.
constexpr uintmax_t kMaxExternalFileBytes = uintmax_t{2} << 30;

bool HasScheme(std::string_view uri) {
  // RFC 3986: scheme = ALPHA *( ALPHA / DIGIT / "+" / "-" / "." ) ":".
  // Also catches Windows drive letters ("C:/...").
  if (uri.empty() || !std::isalpha(static_cast<unsigned char>(uri[0]))) return false;
  for (char c : uri.substr(1)) {
    if (c == ':') return true;
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '+' && c != '-' && c != '.') {
      return false;
    }
  }
  return false;
}

bool IsDataUri(std::string_view uri) { return uri.substr(0, 5) == "data:"; }

bool FileExistsCallback(const std::string& abs_filename, void* user_data) {
  const auto* sandbox = static_cast<const Sandbox*>(user_data);
  std::error_code ec;
  return sandbox->Contains(abs_filename) && fs::is_regular_file(abs_filename, ec);
}

// tinygltf's default expands `~` and `$VAR` through wordexp; a file name is
// a file name here.
std::string ExpandFilePathCallback(const std::string& path, void*) { return path; }

bool ReadWholeFileCallback(std::vector<unsigned char>* out, std::string* err,
                           const std::string& filepath, void* user_data) {
  const auto* sandbox = static_cast<const Sandbox*>(user_data);
  if (!sandbox->Contains(filepath)) {
    if (err) *err += "refused: '" + filepath + "' is outside the asset directory";
    return false;
  }
  std::error_code ec;
  const uintmax_t size = fs::file_size(filepath, ec);
  if (ec || size > kMaxExternalFileBytes) {
    if (err) *err += ec ? "cannot stat '" + filepath + "'" : "'" + filepath + "' is over 2 GiB";
    return false;
  }
  std::ifstream in(filepath, std::ios::binary);
  if (!in) {
    if (err) *err += "cannot open '" + filepath + "'";
    return false;
  }
  out->resize(static_cast<size_t>(size));
  if (size > 0 &&
      !in.read(reinterpret_cast<char*>(out->data()), static_cast<std::streamsize>(size))) {
    if (err) *err += "cannot read '" + filepath + "'";
    return false;
  }
  return true;
}

bool WriteWholeFileCallback(std::string* err, const std::string&, const std::vector<unsigned char>&,
                            void*) {
  if (err) *err += "writing is disabled";
  return false;
}

std::string Describe(std::string_view kind, size_t index, const nlohmann::json& entry) {
  std::string s = absl::StrCat(std::string(kind), "[", index, "]");
  auto name = entry.find("name");
  if (name != entry.end() && name->is_string()) {
    absl::StrAppend(&s, " '", name->get<std::string>(), "'");
  }
  return s;
}

absl::Status CheckUri(const Sandbox* sandbox, const std::string& what, const std::string& uri) {
  if (IsDataUri(uri)) return absl::OkStatus();
  if (sandbox == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, ": uri '", uri, "' names an external file; a glTF loaded from memory may only use data: uris"));
  }
  const absl::StatusOr<std::string> decoded = impostor::PercentDecode(uri);
  if (!decoded.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": uri '", uri, "' has a malformed %-escape"));
  }
  if (decoded->empty()) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": empty uri"));
  }
  if ((*decoded)[0] == '/' || (*decoded)[0] == '\\') {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": absolute uri '", uri, "' is not allowed (relative paths only)"));
  }
  if (HasScheme(*decoded)) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, ": uri '", uri, "' has a scheme; only relative paths and data: uris are allowed"));
  }
  const fs::path resolved = sandbox->root() / fs::path(*decoded);
  if (!sandbox->Contains(resolved)) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, ": uri '", uri, "' resolves outside the asset directory"));
  }
  std::error_code ec;
  if (!fs::is_regular_file(resolved, ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " refers to missing file '", *decoded, "'"));
  }
  return absl::OkStatus();
}

}  // namespace

Sandbox::Sandbox(const fs::path& root) {
  std::error_code ec;
  root_ = fs::weakly_canonical(fs::absolute(root, ec), ec);
  if (ec) root_ = fs::absolute(root, ec).lexically_normal();
}

bool Sandbox::Contains(const fs::path& path) const {
  std::error_code ec;
  const fs::path absolute = fs::absolute(path, ec);
  if (ec) return false;
  // weakly_canonical resolves every symlink in the existing prefix and
  // normalises `..` in the rest, so both `..` escapes and links that lead
  // out end up outside root_.
  const fs::path canonical = fs::weakly_canonical(absolute, ec);
  if (ec) return false;
  const fs::path rel = canonical.lexically_relative(root_);
  if (rel.empty() || rel == ".") return false;
  return *rel.begin() != "..";
}

tinygltf::FsCallbacks Sandbox::FsCallbacks() const {
  tinygltf::FsCallbacks callbacks;
  callbacks.FileExists = &FileExistsCallback;
  callbacks.ExpandFilePath = &ExpandFilePathCallback;
  callbacks.ReadWholeFile = &ReadWholeFileCallback;
  callbacks.WriteWholeFile = &WriteWholeFileCallback;
  callbacks.user_data = const_cast<Sandbox*>(this);
  return callbacks;
}

tinygltf::FsCallbacks NoFileSystemCallbacks() {
  tinygltf::FsCallbacks callbacks;
  callbacks.FileExists = [](const std::string&, void*) { return false; };
  callbacks.ExpandFilePath = &ExpandFilePathCallback;
  callbacks.ReadWholeFile = [](std::vector<unsigned char>*, std::string* err, const std::string& filepath,
                               void*) {
    if (err) *err += "refused: '" + filepath + "': a glTF loaded from memory has no external files";
    return false;
  };
  callbacks.WriteWholeFile = &WriteWholeFileCallback;
  callbacks.user_data = nullptr;
  return callbacks;
}

absl::Status CheckJsonNesting(std::string_view json, int max_depth) {
  int depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < json.size(); ++i) {
    const char c = json[i];
    if (in_string) {
      if (c == '\\') {
        ++i;  // skip the escaped character
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_depth) {
        return absl::InvalidArgumentError(
            absl::StrCat("JSON is nested deeper than ", max_depth, " levels (at byte ", i, ")"));
      }
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return absl::OkStatus();
}

std::optional<std::string_view> GlbJsonChunk(std::span<const uint8_t> glb) {
  auto u32 = [&](size_t offset) {
    uint32_t v;
    std::memcpy(&v, glb.data() + offset, 4);  // GLB is little-endian, as is the worker
    return v;
  };
  if (glb.size() < 20 || std::memcmp(glb.data(), "glTF", 4) != 0) return std::nullopt;
  const uint64_t chunk_length = u32(12);
  if (u32(16) != 0x4E4F534Au /* "JSON" */ || 20 + chunk_length > glb.size()) return std::nullopt;
  return std::string_view(reinterpret_cast<const char*>(glb.data() + 20), chunk_length);
}

absl::Status PrecheckJson(const Sandbox* sandbox, std::string_view json,
                          const std::set<std::string>& supported_required) {
  const nlohmann::json doc = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return absl::OkStatus();
  if (auto required = doc.find("extensionsRequired");
      required != doc.end() && required->is_array()) {
    for (const nlohmann::json& ext : *required) {
      if (ext.is_string() && !supported_required.count(ext.get<std::string>())) {
        return absl::InvalidArgumentError(
            absl::StrCat("extensionsRequired: ", ext.get<std::string>(), " is not supported"));
      }
    }
  }
  // tinygltf 2.7 fails on a skin without `joints` (required by the spec)
  // without saying why.
  if (auto skins = doc.find("skins"); skins != doc.end() && skins->is_array()) {
    for (size_t i = 0; i < skins->size(); ++i) {
      const nlohmann::json& skin = (*skins)[i];
      if (skin.is_object() && !skin.contains("joints")) {
        return absl::InvalidArgumentError(
            absl::StrCat(Describe("skin", i, skin), ": required property 'joints' is missing"));
      }
    }
  }
  // tinygltf 2.7 reads a GLB's binary chunk for a buffer of byteLength 0
  // with vector::at and throws (found by fuzz/run.sh); the spec's minimum is 1.
  if (auto buffers = doc.find("buffers"); buffers != doc.end() && buffers->is_array()) {
    for (size_t i = 0; i < buffers->size(); ++i) {
      const nlohmann::json& buffer = (*buffers)[i];
      if (!buffer.is_object()) continue;
      auto length = buffer.find("byteLength");
      if (length != buffer.end() && length->is_number() && !(length->get<double>() >= 1.0)) {
        return absl::InvalidArgumentError(absl::StrCat(Describe("buffer", i, buffer), ": byteLength ",
                                                       length->dump(), " is below the minimum 1"));
      }
    }
  }
  for (const char* kind : {"buffers", "images"}) {
    auto array = doc.find(kind);
    if (array == doc.end() || !array->is_array()) continue;
    const std::string_view singular = std::string_view(kind).substr(0, std::strlen(kind) - 1);
    for (size_t i = 0; i < array->size(); ++i) {
      const nlohmann::json& entry = (*array)[i];
      if (!entry.is_object()) continue;
      auto uri = entry.find("uri");
      if (uri == entry.end() || !uri->is_string()) continue;
      absl::Status status =
          CheckUri(sandbox, Describe(singular, i, entry), uri->get<std::string>());
      if (!status.ok()) return status;
    }
  }
  return absl::OkStatus();
}

}  // namespace impostor::gltf_internal
