#include "worker/scene/gltf_loader.h"

#include <spdlog/spdlog.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/str_cat.h"
#include "worker/scene/gltf_sandbox.h"
#include "worker/scene/gltf_scene_builder.h"
#include "worker/scene/image_predecode.h"
#include "worker/scene/load_budget.h"

namespace impostor {
namespace {

namespace fs = std::filesystem;
using gltf_internal::Sandbox;

// tinygltf converts JSON `extras`/`extensions` to its Value type
// recursively; 256 levels is far beyond any real asset and far below what
// a worker thread's stack takes.
constexpr int kMaxJsonNesting = 256;

// extensionsRequired entries the bake can honour. Material extensions only
// change lighting terms the unlit albedo/normal/ORM bake does not use
// (KHR_materials_emissive_strength scales the emissive map);
// KHR_texture_transform is applied per texture slot (gltf_materials.cc, in
// the bake shader); KHR_mesh_quantization is read by gltf_accessor.cc.
// Everything else required -- KHR_draco_mesh_compression,
// EXT_meshopt_compression, KHR_texture_basisu, EXT_texture_webp, ... -- is
// INVALID_ARGUMENT naming the extension: the file has no fallback data.
const std::set<std::string>& SupportedRequiredExtensions() {
  static const std::set<std::string> kSupported = {
      "KHR_mesh_quantization",      "KHR_texture_transform",
      "KHR_materials_unlit",        "KHR_materials_emissive_strength",
      "KHR_materials_ior",          "KHR_materials_specular",
      "KHR_materials_clearcoat",    "KHR_materials_sheen",
      "KHR_materials_transmission", "KHR_materials_volume",
      "KHR_materials_iridescence",  "KHR_materials_anisotropy",
      "KHR_materials_dispersion",   "KHR_lights_punctual",
      "EXT_mesh_gpu_instancing",
  };
  return kSupported;
}

// tinygltf's multi-line error text as one log-friendly line.
std::string OneLine(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '\n' || c == '\r') {
      if (!out.empty() && out.back() != ' ') out += "; ";
    } else {
      out.push_back(c);
    }
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == ';')) out.pop_back();
  constexpr size_t kMax = 600;
  if (out.size() > kMax) out = out.substr(0, kMax) + "...";
  return out;
}

absl::Status CheckLimits(const GltfLoadLimits& limits) {
  if (limits.max_triangles < 1 || limits.max_triangles > (uint64_t{1} << 31) / 3 ||
      limits.max_texture_dimension < 1 || limits.max_texture_dimension > 65535 ||
      limits.max_node_depth < 1 || limits.max_node_depth > 100000 || limits.max_draws < 1 ||
      limits.max_draws > (uint64_t{1} << 31) || limits.max_load_bytes < 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "GltfLoadLimits out of range: max_triangles ", limits.max_triangles,
        ", max_texture_dimension ", limits.max_texture_dimension, ", max_node_depth ",
        limits.max_node_depth, ", max_draws ", limits.max_draws, ", max_load_bytes ",
        limits.max_load_bytes));
  }
  return absl::OkStatus();
}

// Image loader for tinygltf that keeps the encoded bytes: images are decoded
// later, only if the default scene uses them, after their header was checked
// against the limits (gltf_materials.cc).
struct ImageLoaderContext {
  const tinygltf::Model* model = nullptr;
};

bool KeepEncodedImage(tinygltf::Image* image, const int image_idx, std::string* err, std::string*,
                      int, int, const unsigned char* bytes, int size, void* user_data) {
  const auto* ctx = static_cast<const ImageLoaderContext*>(user_data);
  if (image->bufferView != -1) {
    // tinygltf 2.7 hands over &buffer.data[bufferView.byteOffset] with
    // bufferView.byteLength without checking either against the buffer.
    const tinygltf::BufferView& view = ctx->model->bufferViews[image->bufferView];
    const std::vector<unsigned char>& data = ctx->model->buffers[view.buffer].data;
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset ||
        size < 0 || static_cast<size_t>(size) != view.byteLength) {
      if (err) {
        *err += absl::StrCat("image[", image_idx, "] bufferView ", image->bufferView,
                             " (byteOffset ", view.byteOffset, ", byteLength ", view.byteLength,
                             ") exceeds buffer ", view.buffer, " of ", data.size(), " bytes\n");
      }
      return false;
    }
  }
  if (size > 0) image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

struct EntryFile {
  bool is_glb = false;
  std::optional<std::string> json;  // the JSON text, when it could be located
};

// Reads what the pre-checks need: the magic bytes and the JSON text.
absl::StatusOr<EntryFile> ReadEntry(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat("glTF file '", path.string(), "' does not exist"));
  }
  const uintmax_t size = fs::file_size(path, ec);
  if (ec) return absl::NotFoundError(absl::StrCat("cannot stat '", path.string(), "'"));
  if (size == 0) {
    return absl::InvalidArgumentError(absl::StrCat("'", path.filename().string(), "' is empty"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open '", path.string(), "'"));
  EntryFile entry;
  char header[20] = {};
  in.read(header, static_cast<std::streamsize>(std::min<uintmax_t>(size, sizeof(header))));
  entry.is_glb = size >= 4 && std::memcmp(header, "glTF", 4) == 0;
  if (entry.is_glb) {
    if (size < 20) return entry;  // tinygltf names the problem
    std::vector<uint8_t> head(header, header + 20);
    uint32_t chunk_length;
    std::memcpy(&chunk_length, header + 12, 4);
    if (uint64_t{20} + chunk_length > size) return entry;
    head.resize(20 + chunk_length);
    in.read(reinterpret_cast<char*>(head.data() + 20), chunk_length);
    if (std::optional<std::string_view> json = gltf_internal::GlbJsonChunk(head)) {
      entry.json = std::string(*json);
    }
    return entry;
  }
  std::string text(static_cast<size_t>(size), '\0');
  in.seekg(0);
  in.read(text.data(), static_cast<std::streamsize>(size));
  entry.json = std::move(text);
  return entry;
}

absl::Status CheckRequiredExtensions(const tinygltf::Model& model) {
  for (const std::string& ext : model.extensionsRequired) {
    if (!SupportedRequiredExtensions().count(ext)) {
      return absl::InvalidArgumentError(
          absl::StrCat("extensionsRequired: ", ext, " is not supported"));
    }
  }
  return absl::OkStatus();
}

// What is known about an entry before tinygltf parses it.
struct ParseInput {
  std::string name;                // file name, for messages
  bool is_glb = false;             // GLB magic bytes present
  bool named_glb = false;          // the name ends in .glb
  const std::optional<std::string>* json = nullptr;  // for the pre-checks
  const Sandbox* sandbox = nullptr;                  // null: from memory
};

// Pre-checks, tinygltf (through `parse`, which reads the entry from wherever
// it is) and the scene builder: the part LoadGltfScene and
// LoadGltfSceneFromMemory share.
template <typename Parse>
absl::StatusOr<Scene> ParseAndBuild(const ParseInput& in, const GltfLoadLimits& limits,
                                    Parse parse) {
  const auto start = std::chrono::steady_clock::now();
  if (in.json->has_value()) {
    const std::string& json = **in.json;
    if (absl::Status s = gltf_internal::CheckJsonNesting(json, kMaxJsonNesting); !s.ok()) {
      return s;
    }
    if (absl::Status s =
            gltf_internal::PrecheckJson(in.sandbox, json, SupportedRequiredExtensions());
        !s.ok()) {
      return s;
    }
  }

  tinygltf::Model model;
  ImageLoaderContext image_ctx{&model};
  tinygltf::TinyGLTF gltf;
  gltf.SetFsCallbacks(in.sandbox ? in.sandbox->FsCallbacks()
                                 : gltf_internal::NoFileSystemCallbacks());
  gltf.SetImageLoader(&KeepEncodedImage, &image_ctx);
  std::string err, warn;
  bool parsed = false;
  try {
    parsed = parse(gltf, &model, &err, &warn);
  } catch (const std::exception& e) {
    // tinygltf indexes some fields with vector::at or lets nlohmann::json
    // throw on a malformed file: a refused file, never a crashed worker.
    return absl::InvalidArgumentError(
        absl::StrCat("cannot parse '", in.name, "': tinygltf failed on a malformed field (", e.what(), ")"));
  }
  if (!parsed) {
    std::string message = OneLine(err.empty() ? warn : err);
    if (message.empty()) message = "tinygltf rejected the file without a message";
    if (!in.is_glb && in.named_glb) message += " (named .glb but has no GLB magic bytes)";
    return absl::InvalidArgumentError(absl::StrCat("cannot parse '", in.name, "': ", message));
  }
  if (!warn.empty()) spdlog::debug("gltf: {}: tinygltf: {}", in.name, OneLine(warn));
  if (absl::Status s = CheckRequiredExtensions(model); !s.ok()) return s;
  // Declared counts against the limits before anything is read per element.
  absl::StatusOr<gltf_internal::LoadCost> cost = gltf_internal::CheckLoadBudget(model, limits);
  if (!cost.ok()) return cost.status();
  // The textures decoded side by side first, when the budget has room for
  // all the decodes at once (image_predecode.h).
  gltf_internal::PredecodedImages predecoded;
  if (gltf_internal::FitsDecodingAtOnce(*cost, limits)) {
    predecoded = gltf_internal::PredecodeImages(model, cost->decodable_images, limits);
  }

  absl::StatusOr<Scene> scene = gltf_internal::BuildScene(model, limits, &predecoded);
  if (scene.ok()) {
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    spdlog::debug(
        "gltf: loaded {}: {} triangles, {} vertices, {} batches, {} materials, {} "
        "textures in {:.1f} ms",
        in.name, scene->TriangleCount(), scene->vertices.size(), scene->batches.size(),
        scene->materials.size(), scene->textures.size(), ms);
  }
  return scene;
}

// Every error leaves the loader as one line, whatever library text (tinygltf,
// stb_image) it carries: workers put it into a job status and a log line.
absl::StatusOr<Scene> WithOneLineError(absl::StatusOr<Scene> result) {
  if (result.ok()) return result;
  return absl::Status(result.status().code(), OneLine(std::string(result.status().message())));
}

}  // namespace

absl::StatusOr<Scene> LoadGltfScene(const fs::path& entry_file, const GltfLoadLimits& limits) {
  if (absl::Status s = CheckLimits(limits); !s.ok()) return s;
  std::error_code ec;
  const fs::path path = fs::absolute(entry_file, ec);
  if (ec) return absl::NotFoundError(absl::StrCat("bad path '", entry_file.string(), "'"));
  absl::StatusOr<EntryFile> entry = ReadEntry(path);
  if (!entry.ok()) return entry.status();

  const Sandbox sandbox(path.parent_path());
  const ParseInput in{.name = path.filename().string(),
                      .is_glb = entry->is_glb,
                      .named_glb = path.extension() == ".glb",
                      .json = &entry->json,
                      .sandbox = &sandbox};
  return WithOneLineError(ParseAndBuild(in, limits,
                       [&](tinygltf::TinyGLTF& gltf, tinygltf::Model* model, std::string* err,
                           std::string* warn) {
                         return entry->is_glb
                                    ? gltf.LoadBinaryFromFile(model, err, warn, path.string())
                                    : gltf.LoadASCIIFromFile(model, err, warn, path.string());
                       }));
}

absl::StatusOr<Scene> LoadGltfSceneFromMemory(std::string_view bytes, std::string_view name,
                                              const GltfLoadLimits& limits) {
  if (absl::Status s = CheckLimits(limits); !s.ok()) return s;
  const std::string display_name(name);
  if (bytes.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("'", display_name, "' is empty"));
  }
  // tinygltf takes the length as unsigned int.
  if (bytes.size() > std::numeric_limits<unsigned int>::max()) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", display_name, "' is ", bytes.size(), " bytes, over 4 GiB"));
  }
  const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
  const bool is_glb = bytes.size() >= 4 && std::memcmp(data, "glTF", 4) == 0;
  std::optional<std::string> json;
  if (!is_glb) {
    json = std::string(bytes);
  } else if (std::optional<std::string_view> chunk =
                 gltf_internal::GlbJsonChunk(std::span<const uint8_t>(data, bytes.size()))) {
    json = std::string(*chunk);
  }
  const bool named_glb = name.size() >= 4 && name.substr(name.size() - 4) == ".glb";
  const ParseInput in{.name = display_name,
                      .is_glb = is_glb,
                      .named_glb = named_glb,
                      .json = &json,
                      .sandbox = nullptr};
  return WithOneLineError(ParseAndBuild(in, limits,
                       [&](tinygltf::TinyGLTF& gltf, tinygltf::Model* model, std::string* err,
                           std::string* warn) {
                         const auto size = static_cast<unsigned int>(bytes.size());
                         return is_glb ? gltf.LoadBinaryFromMemory(model, err, warn, data, size,
                                                                   /*base_dir=*/"")
                                       : gltf.LoadASCIIFromString(model, err, warn, bytes.data(),
                                                                  size, /*base_dir=*/"");
                       }));
}

}  // namespace impostor
