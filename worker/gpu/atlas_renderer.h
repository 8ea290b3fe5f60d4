// Headless Vulkan renderer that bakes a Scene into the three impostor atlas
// maps. The only part of the worker that sees Vulkan: callers hand in plain
// data (Scene, FrameCamera list) and get plain pixels back.
//
// Thread-safety: one AtlasRenderer per thread; the object owns its VkDevice
// and queue. Creating one picks a device (discrete GPU > integrated > virtual
// > CPU/lavapipe) and logs, one line each, the device chosen and why every
// other device was passed over.
#ifndef IMPOSTOR_WORKER_GPU_ATLAS_RENDERER_H_
#define IMPOSTOR_WORKER_GPU_ATLAS_RENDERER_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/atlas/frame_camera.h"
#include "common/runtime/reference_renderer.h"
#include "worker/scene/scene.h"

namespace impostor {

// CPU copy of the baked atlas maps. All images are `width` x `height`,
// rows top to bottom, tightly packed, 4 channels.
struct AtlasImages {
  int width = 0;
  int height = 0;
  // R,G,B = base colour texture x factor x COLOR_0 (sRGB-encoded, unlit),
  // A = coverage
  // (0 empty, 255 covered). Empty texels are 0,0,0,0.
  std::vector<uint8_t> albedo_alpha;
  // R,G,B = scene-space unit normal (normal map applied) * 0.5 + 0.5,
  // A = depth along the view direction normalised to the bounding sphere:
  // 0 = nearest point of the sphere to the camera, 1 = farthest
  // (see common/atlas/frame_camera.h). Empty texels: normal 0.5,0.5,0.5, depth 1.
  std::vector<uint16_t> normal_depth;
  // R = occlusion, G = roughness, B = metalness, A = coverage (as albedo).
  std::vector<uint8_t> orm;
  // Only when set_emissive(true): R,G,B = emissive texture x emissiveFactor x
  // KHR_materials_emissive_strength, sRGB-encoded and clamped to 0..1 (an
  // 8-bit map, not HDR), A = coverage (as albedo). Empty texels 0,0,0,0.
  std::vector<uint8_t> emissive;
};

struct RenderTimings {
  double upload_seconds = 0;    // scene buffers + textures to the device
  double render_seconds = 0;    // command recording + GPU execution
  double readback_seconds = 0;  // device -> host copy of the three maps
};

struct DeviceInfo {
  std::string name;         // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string type;         // "discrete", "integrated", "virtual", "cpu", "other"
  uint32_t api_version = 0;
  std::string driver;       // driverName / driverInfo
  // The largest device-local heap and VkPhysicalDeviceMaintenance3Properties::
  // maxMemoryAllocationSize, bytes (what a bake may ask of the device:
  // gpu/device_memory_limits.h); 0 when unknown.
  int64_t device_local_heap_bytes = 0;
  int64_t max_allocation_bytes = 0;
};

// An impostor atlas held on the device, drawn by the shipped runtime shader
// (shaders/impostor_runtime.glsl). Made by AtlasRenderer::UploadImpostor;
// must not outlive it. Thread-safety: as its AtlasRenderer.
class DeviceImpostor {
 public:
  virtual ~DeviceImpostor() = default;
  // Every camera's orthographic view of the impostor, pixels x pixels,
  // framed, shaded, encoded and covered (alpha >= 0.5) exactly as
  // RenderImpostorView draws it with `options` (camera.tile is ignored); the
  // device's float rounding may flip a pixel whose choice sits on a tie
  // (tests/runtime/glsl_runtime_test.cc bounds how many).
  virtual absl::StatusOr<std::vector<ViewImages>> RenderViews(const std::vector<FrameCamera>& cameras, int pixels,
                                                              const ReferenceRenderOptions& options) = 0;
};

class AtlasRenderer {
 public:
  // Creates the Vulkan 1.3 instance and device (no window system, no
  // surface). `preferred_device` (substring of a device name; empty = any)
  // lets an operator pin a GPU. UNAVAILABLE when no device supports
  // Vulkan 1.3 with dynamic rendering; every failed VkResult becomes a status
  // naming the call.
  static absl::StatusOr<std::unique_ptr<AtlasRenderer>> Create(
      const std::string& preferred_device = "");
  virtual ~AtlasRenderer() = default;

  virtual const DeviceInfo& device() const = 0;

  // Renders every camera's view of `scene` into its tile of an atlas of
  // `atlas_size` x `atlas_size` pixels and reads the three maps back.
  // The scene is framed by `sphere`. `progress` (may be empty) is called with
  // the fraction of frames rendered, 0..1, from the calling thread.
  // INVALID_ARGUMENT if a tile lies outside the atlas or the atlas exceeds
  // the device's maxImageDimension2D (the message names both numbers);
  // RESOURCE_EXHAUSTED if device memory runs out.
  virtual absl::StatusOr<AtlasImages> Render(
      const Scene& scene, const BoundingSphere& sphere,
      const std::vector<FrameCamera>& cameras, int atlas_size,
      const std::function<void(double)>& progress, RenderTimings* timings) = 0;

  // Keeps `scene`'s device upload (buffers, textures) once a Render of that
  // Scene object made it, so later Render calls of the same object skip the
  // upload, whatever their texture filter (set_supersampling): only the
  // samplers are made again when it changes. nullptr (the default) frees it.
  // The scene must stay alive and unchanged until then. A worker keeps its
  // scene from the bake through its quality pass, which renders the mesh
  // again (ScopedKeptScene below).
  virtual void KeepSceneUploaded(const Scene* scene) = 0;

  // Uploads `atlas` (its maps; the atlas itself need not outlive the
  // result) for views drawn on the device by the runtime shader: what the
  // quality pass draws its impostor side with on a GPU, where the CPU
  // reference renderer would cost most of the pass. INVALID_ARGUMENT for an
  // inconsistent atlas; the device's limits and errors otherwise.
  virtual absl::StatusOr<std::unique_ptr<DeviceImpostor>> UploadImpostor(const ImpostorAtlas& atlas) = 0;

  // While set, Render checks `*flag` after each submitted chunk of frames
  // (well under a second of work on lavapipe for typical meshes) and returns
  // CANCELLED once it is true. The flag must outlive the Render calls; pass
  // nullptr to clear.
  void set_cancel_flag(const std::atomic<bool>* flag) { cancel_flag_ = flag; }

  // Whether later Render calls also bake the emissive map
  // (AtlasImages::emissive). Off by default: it costs a fourth target.
  void set_emissive(bool on) { emissive_ = on; }

  // The supersampling factor of the tiles later Render calls get (the
  // caller scales them and filters the maps down): with 2 or more, textures
  // are sampled trilinear with a sharpening mip bias instead of
  // anisotropically (gpu/texture_filter.h says why). 1 by default.
  void set_supersampling(int factor) { supersampling_ = factor; }

  // With supersampling 2 or more: whether later Render calls filter the
  // maps down by the factor on the device (the semantics of
  // worker/output/supersample.h, shaders/supersample_resolve.comp) and
  // return atlas_size / factor maps, reading back only those. Off by
  // default: Render returns the maps as rendered and the caller filters
  // them (DownsampleMaps, the reference the device resolve is tested
  // against). INVALID_ARGUMENT when atlas_size is not a multiple of the
  // factor.
  void set_resolve_on_device(bool on) { resolve_on_device_ = on; }

 protected:
  bool cancel_requested() const { return cancel_flag_ != nullptr && cancel_flag_->load(); }
  bool emissive_requested() const { return emissive_; }
  int supersampling() const { return supersampling_; }
  // The factor Render filters down by on the device: 1 = none.
  int device_resolve_factor() const { return resolve_on_device_ && supersampling_ > 1 ? supersampling_ : 1; }

 private:
  const std::atomic<bool>* cancel_flag_ = nullptr;
  bool emissive_ = false;
  int supersampling_ = 1;
  bool resolve_on_device_ = false;
};

// `cameras` with every tile `factor` times larger: what Render takes for
// tiles rendered at set_supersampling(factor).
inline std::vector<FrameCamera> SupersampledCameras(std::vector<FrameCamera> cameras, int factor) {
  for (FrameCamera& c : cameras) {
    c.tile = {c.tile.x * factor, c.tile.y * factor, c.tile.width * factor, c.tile.height * factor};
  }
  return cameras;
}

// KeepSceneUploaded(&scene) for the object's lifetime, then nullptr, on
// every path out of the scope that renders the scene more than once.
class ScopedKeptScene {
 public:
  ScopedKeptScene(AtlasRenderer& renderer, const Scene& scene) : renderer_(renderer) {
    renderer_.KeepSceneUploaded(&scene);
  }
  ~ScopedKeptScene() { renderer_.KeepSceneUploaded(nullptr); }
  ScopedKeptScene(const ScopedKeptScene&) = delete;
  ScopedKeptScene& operator=(const ScopedKeptScene&) = delete;

 private:
  AtlasRenderer& renderer_;
};

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_GPU_ATLAS_RENDERER_H_
