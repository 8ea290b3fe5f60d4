#include "client/transfer/mesh_files.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <set>
#include <system_error>

#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "common/request/bake_request.h"

namespace impostor::sdk {
namespace {

namespace fs = std::filesystem;

constexpr uint32_t kGlbMagic = 0x46546C67;      // "glTF"
constexpr uint32_t kGlbJsonChunk = 0x4E4F534A;  // "JSON"
constexpr size_t kGlbHeaderBytes = 12;
constexpr size_t kChunkHeaderBytes = 8;
// The JSON of any sane glTF is far smaller; the cap keeps a corrupt length
// field from making us allocate gigabytes.
constexpr uint32_t kMaxJsonBytes = 256u << 20;

uint32_t ReadLe32(const char* p) {
  const auto* u = reinterpret_cast<const unsigned char*>(p);
  return uint32_t{u[0]} | (uint32_t{u[1]} << 8) | (uint32_t{u[2]} << 16) | (uint32_t{u[3]} << 24);
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

absl::StatusOr<std::string> ReadPrefix(const fs::path& path, size_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::InternalError(absl::StrCat("cannot open ", path.string(), ": ", std::strerror(errno)));
  }
  std::string bytes(max_bytes, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(max_bytes));
  if (in.bad()) return absl::InternalError(absl::StrCat("read error on ", path.string()));
  bytes.resize(static_cast<size_t>(in.gcount()));
  return bytes;
}

absl::StatusOr<std::string> ReadGltfJson(const fs::path& model, bool is_glb) {
  const std::string name = model.string();
  if (!is_glb) {
    std::error_code ec;
    const uintmax_t size = fs::file_size(model, ec);
    if (ec) return absl::InternalError(absl::StrCat("cannot stat ", name, ": ", ec.message()));
    if (size > kMaxJsonBytes) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": glTF JSON of ", size, " bytes is too large"));
    }
    return ReadPrefix(model, static_cast<size_t>(size));
  }
  absl::StatusOr<std::string> header = ReadPrefix(model, kGlbHeaderBytes + kChunkHeaderBytes);
  if (!header.ok()) return header.status();
  if (header->size() == kGlbHeaderBytes + kChunkHeaderBytes) {
    const uint32_t json_len = ReadLe32(header->data() + kGlbHeaderBytes);
    if (json_len > kMaxJsonBytes) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": corrupt GLB header: JSON chunk length ", json_len, " is too large"));
    }
    header = ReadPrefix(model, kGlbHeaderBytes + kChunkHeaderBytes + json_len);
    if (!header.ok()) return header.status();
  }
  return GlbJsonChunk(*header, name);
}

// Turns a glTF URI into a safe relative path, or says why it cannot be one.
absl::StatusOr<std::string> UriToRelativePath(const std::string& uri, const std::string& user) {
  const std::string quoted = absl::StrCat(user, " \"", uri, "\"");
  // A scheme ("http:", "file:", or a Windows drive "C:") before any '/'.
  const size_t colon = uri.find(':');
  if (colon != std::string::npos && colon < uri.find('/') && colon > 0 &&
      std::isalpha(static_cast<unsigned char>(uri[0]))) {
    return absl::InvalidArgumentError(
        absl::StrCat(quoted, ": absolute URIs are not supported; files must be relative to the model"));
  }
  absl::StatusOr<std::string> decoded = PercentDecode(uri);
  if (!decoded.ok()) return absl::InvalidArgumentError(absl::StrCat(quoted, ": ", decoded.status().message()));
  if (decoded->empty()) return absl::InvalidArgumentError(absl::StrCat(quoted, ": empty URI"));
  if (decoded->front() == '/' || decoded->front() == '\\') {
    return absl::InvalidArgumentError(absl::StrCat(quoted, ": absolute paths are not allowed"));
  }
  // Drop "." and empty components (harmless on any filesystem); refuse ".."
  // outright, as the server does, since the bake sees only the uploaded tree.
  std::string path;
  size_t start = 0;
  while (start <= decoded->size()) {
    size_t end = decoded->find('/', start);
    if (end == std::string::npos) end = decoded->size();
    const std::string part = decoded->substr(start, end - start);
    if (part == "..") {
      return absl::InvalidArgumentError(
          absl::StrCat(quoted, ": \"..\" is not allowed; files must lie inside the model's directory"));
    }
    if (!part.empty() && part != ".") {
      if (!path.empty()) path += '/';
      path += part;
    }
    start = end + 1;
  }
  if (absl::Status s = ValidateRelativePath(quoted, path); !s.ok()) return s;
  return path;
}

// OK if `rel` under `dir`, with every symbolic link resolved, is still
// inside `dir` (or `follow` is set). PERMISSION_DENIED naming the first link
// on the way that leads out, and its target, otherwise.
absl::Status CheckStaysInside(const fs::path& dir, const std::string& rel, bool follow,
                              const std::string& user, const std::string& model_name) {
  if (follow) return absl::OkStatus();
  std::error_code ec;
  const fs::path root = fs::canonical(dir, ec);
  if (ec) return absl::InternalError(absl::StrCat("cannot resolve ", dir.string(), ": ", ec.message()));
  auto inside = [&](const fs::path& p) {
    const fs::path r = p.lexically_relative(root);
    return !r.empty() && *r.begin() != "..";
  };
  const fs::path resolved = fs::canonical(dir / rel, ec);
  if (!ec && inside(resolved)) return absl::OkStatus();
  fs::path link = dir;
  for (const fs::path& part : fs::path(rel)) {
    link /= part;
    if (!fs::is_symlink(link, ec)) continue;
    const fs::path target = fs::read_symlink(link, ec);
    const fs::path where = fs::canonical(link, ec);
    if (!ec && inside(where)) continue;
    return absl::PermissionDeniedError(absl::StrCat(
        link.string(), " (", user, " of ", model_name, ") is a symbolic link to ", target.string(),
        ", outside the model's folder ", root.string(),
        "; pass --follow-symlinks (BakeSettings::follow_symlinks) to upload it anyway"));
  }
  return absl::PermissionDeniedError(absl::StrCat(
      (dir / rel).string(), " (", user, " of ", model_name, ") resolves to ", resolved.string(),
      ", outside the model's folder ", root.string()));
}

// Adds the external files named by json[array_name][i].uri to `out`.
absl::Status CollectUris(const nlohmann::json& json, const char* array_name, const fs::path& dir,
                         const std::string& model_name, bool follow_symlinks,
                         std::set<std::string>* seen, std::vector<MeshFile>* out) {
  auto it = json.find(array_name);
  if (it == json.end()) return absl::OkStatus();
  if (!it->is_array()) {
    return absl::InvalidArgumentError(absl::StrCat(model_name, ": \"", array_name, "\" is not an array"));
  }
  for (size_t i = 0; i < it->size(); ++i) {
    const nlohmann::json& item = (*it)[i];
    const std::string user = absl::StrCat(array_name, "[", i, "].uri");
    if (!item.is_object()) {
      return absl::InvalidArgumentError(absl::StrCat(model_name, ": ", array_name, "[", i, "] is not an object"));
    }
    auto uri_it = item.find("uri");
    if (uri_it == item.end()) continue;  // GLB buffer 0 or an image in a bufferView
    if (!uri_it->is_string()) {
      return absl::InvalidArgumentError(absl::StrCat(model_name, ": ", user, " is not a string"));
    }
    const std::string uri = uri_it->get<std::string>();
    if (uri.rfind("data:", 0) == 0) continue;  // embedded
    absl::StatusOr<std::string> rel = UriToRelativePath(uri, user);
    if (!rel.ok()) return rel.status();
    if (!seen->insert(*rel).second) continue;  // several users of one file
    const fs::path local = dir / fs::path(*rel);
    std::error_code ec;
    if (!fs::is_regular_file(local, ec)) {
      return absl::NotFoundError(absl::StrCat("file ", local.string(), " not found (used by ", user,
                                              " \"", uri, "\" of ", model_name, ")"));
    }
    if (absl::Status s = CheckStaysInside(dir, *rel, follow_symlinks, user, model_name); !s.ok()) {
      return s;
    }
    out->push_back(MeshFile{*rel, local});
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::string> GlbJsonChunk(std::string_view glb, std::string_view name) {
  const std::string n(name);
  // The magic first: a file that is not a GLB at all says so, however short.
  if (glb.size() < 4 || ReadLe32(glb.data()) != kGlbMagic) {
    return absl::InvalidArgumentError(absl::StrCat(n, ": corrupt GLB header: magic is not \"glTF\""));
  }
  if (glb.size() < kGlbHeaderBytes + kChunkHeaderBytes) {
    return absl::InvalidArgumentError(absl::StrCat(n, ": corrupt GLB header: file is ", glb.size(),
                                                   " bytes, shorter than the 12-byte header and the first "
                                                   "chunk's 8-byte header"));
  }
  if (const uint32_t version = ReadLe32(glb.data() + 4); version != 2) {
    return absl::InvalidArgumentError(
        absl::StrCat(n, ": corrupt GLB header: version ", version, ", only glTF 2 is supported"));
  }
  const uint32_t total = ReadLe32(glb.data() + 8);
  const uint32_t json_len = ReadLe32(glb.data() + kGlbHeaderBytes);
  const uint32_t type = ReadLe32(glb.data() + kGlbHeaderBytes + 4);
  if (type != kGlbJsonChunk) {
    return absl::InvalidArgumentError(absl::StrCat(n, ": corrupt GLB header: first chunk is not JSON"));
  }
  if (uint64_t{json_len} + kGlbHeaderBytes + kChunkHeaderBytes > total) {
    return absl::InvalidArgumentError(absl::StrCat(n, ": corrupt GLB header: JSON chunk of ", json_len,
                                                   " bytes overruns the declared length ", total));
  }
  if (glb.size() < kGlbHeaderBytes + kChunkHeaderBytes + json_len) {
    return absl::InvalidArgumentError(absl::StrCat(n, ": truncated GLB: JSON chunk of ", json_len,
                                                   " bytes but the file ends first"));
  }
  return std::string(glb.substr(kGlbHeaderBytes + kChunkHeaderBytes, json_len));
}

absl::StatusOr<MeshFiles> CollectMeshFiles(const fs::path& model, const CollectOptions& options) {
  const std::string name = model.string();
  std::error_code ec;
  if (!fs::exists(model, ec)) return absl::NotFoundError(absl::StrCat("model ", name, " not found"));
  if (!fs::is_regular_file(model, ec)) {
    return absl::InvalidArgumentError(absl::StrCat("model ", name, " is not a regular file"));
  }
  const std::string ext = Lower(model.extension().string());
  if (ext != ".gltf" && ext != ".glb") {
    return absl::InvalidArgumentError(
        absl::StrCat("model ", name, ": expected a .gltf or .glb file, got \"", ext, "\""));
  }
  absl::StatusOr<std::string> text = ReadGltfJson(model, ext == ".glb");
  if (!text.ok()) return text.status();
  nlohmann::json json = nlohmann::json::parse(*text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return absl::InvalidArgumentError(absl::StrCat(name, ": invalid JSON"));
  if (!json.is_object()) return absl::InvalidArgumentError(absl::StrCat(name, ": glTF JSON is not an object"));

  MeshFiles result;
  result.entry = model;
  result.entry_name = model.filename().string();
  const fs::path dir = model.has_parent_path() ? model.parent_path() : fs::path(".");
  std::set<std::string> seen;
  for (const char* array : {"buffers", "images"}) {
    if (absl::Status s = CollectUris(json, array, dir, name, options.follow_symlinks, &seen, &result.files); !s.ok()) return s;
  }
  return result;
}

}  // namespace impostor::sdk
