// libFuzzer target over the worker's mesh loading and validation path: the
// bytes are a .glb or .gltf (format by magic bytes) loaded from memory with
// LoadGltfSceneFromMemory (JSON pre-checks, tinygltf, the load budget, the
// scene builder, texture decoding), then taken through what the bake does
// before any GPU work (bounding sphere, atlas cameras, ValidateRenderRequest).
// run.sh runs it with -rss_limit_mb: under the load budget no input may
// make it allocate near that.
//
// Beyond the sanitizers' checks, it traps when the loader breaks its
// contract: a failure with a code other than INVALID_ARGUMENT or
// RESOURCE_EXHAUSTED, or with an empty or multi-line message; or a scene
// that loads but that the renderer's validation refuses (indices, batches,
// materials or textures out of range); or a scene larger than the load
// budget computed from the file's declared counts (the budget must never
// under-count what the builder makes, or it bounds nothing).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "common/atlas/frame_camera.h"
#include "worker/gpu/render_validation.h"
#include "worker/scene/bounding_sphere.h"
#include "worker/scene/gltf_loader.h"
#include "worker/scene/gltf_sandbox.h"
#include "worker/scene/load_budget.h"

namespace {

// Limits well below the worker's so one input cannot make the fuzzer
// allocate gigabytes (libFuzzer's -rss_limit_mb would call that a crash);
// they bound what the defaults bound, only smaller.
impostor::GltfLoadLimits FuzzLimits() {
  impostor::GltfLoadLimits limits;
  limits.max_triangles = 1 << 20;
  limits.max_texture_dimension = 2048;
  limits.max_texture_bytes = 64 << 20;
  limits.max_node_depth = 64;
  limits.max_draws = 1 << 14;
  limits.max_load_bytes = 256 << 20;
  return limits;
}

// The load budget's view of the same bytes: tinygltf with the loader's
// settings (no file system, images kept encoded).
bool KeepEncoded(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                 const unsigned char* bytes, int size, void*) {
  if (size > 0) image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

std::optional<impostor::gltf_internal::LoadCost> BudgetOf(std::string_view bytes) {
  tinygltf::Model model;
  tinygltf::TinyGLTF gltf;
  gltf.SetFsCallbacks(impostor::gltf_internal::NoFileSystemCallbacks());
  gltf.SetImageLoader(&KeepEncoded, nullptr);
  std::string err, warn;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const auto size = static_cast<unsigned int>(bytes.size());
  const bool ok = bytes.substr(0, 4) == "glTF"
                      ? gltf.LoadBinaryFromMemory(&model, &err, &warn, data, size, "")
                      : gltf.LoadASCIIFromString(&model, &err, &warn, bytes.data(), size, "");
  if (!ok) return std::nullopt;
  return impostor::gltf_internal::ComputeLoadCost(model);
}

[[noreturn]] void Fail(const char* what, const absl::Status& status) {
  std::fprintf(stderr, "gltf_load_fuzzer: %s: %s\n", what, status.ToString().c_str());
  __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  absl::StatusOr<impostor::Scene> scene =
      impostor::LoadGltfSceneFromMemory(bytes, "fuzz.glb", FuzzLimits());
  if (!scene.ok()) {
    const absl::Status& s = scene.status();
    if (s.code() != absl::StatusCode::kInvalidArgument &&
        s.code() != absl::StatusCode::kResourceExhausted) {
      Fail("unexpected error code", s);
    }
    if (s.message().empty() || s.message().find('\n') != std::string_view::npos) {
      Fail("error message is empty or not one line", s);
    }
    return 0;
  }
  // The budget counted at least what was built.
  if (const std::optional<impostor::gltf_internal::LoadCost> cost = BudgetOf(bytes)) {
    if (cost->drawn_vertices < scene->vertices.size() || cost->drawn_triangles < scene->TriangleCount() ||
        cost->draws < scene->batches.size()) {
      Fail("the load budget under-counts the scene",
           absl::InternalError(absl::StrCat("budget ", cost->drawn_vertices, " vertices, ", cost->drawn_triangles,
                                            " triangles, ", cost->draws, " draws; scene ", scene->vertices.size(),
                                            ", ", scene->TriangleCount(), ", ", scene->batches.size())));
    }
  }
  // The same preparation as the bake (worker/bake/atlas_bake.cc).
  const impostor::BoundingSphere sphere = impostor::ComputeBoundingSphere(*scene);
  if (!(sphere.radius > 0.0f) || !std::isfinite(sphere.radius)) return 0;  // refused by the bake
  const std::vector<impostor::FrameCamera> cameras =
      impostor::AtlasCameras(impostor::LayoutKind::kOctahedral, /*frames=*/2, /*resolution=*/64);
  const absl::Status valid = impostor::gpu::ValidateRenderRequest(
      *scene, sphere, cameras, /*atlas_size=*/64, /*max_image_dimension=*/65535);
  if (!valid.ok()) Fail("a loaded scene fails render validation", valid);
  return 0;
}
