// The worker's bake pipeline for atlas impostors, by stage:
//   load (glTF -> Scene) -> prepare (bounding sphere, frame cameras)
//   -> render (GPU, all frames) -> post-process (dilation per tile)
//   -> write (PNG maps + manifest.json into an output directory).
// It knows nothing of gRPC or of where inputs came from: the worker loop
// hands it a local entry file and uploads what it writes.
//
// Thread-safety: one bake per AtlasRenderer at a time.
#ifndef IMPOSTOR_WORKER_BAKE_ATLAS_BAKE_H_
#define IMPOSTOR_WORKER_BAKE_ATLAS_BAKE_H_

#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "impostor/v1/types.pb.h"
#include "common/util/sha256.h"
#include "worker/bake/quality_pass.h"
#include "worker/gpu/atlas_renderer.h"
#include "worker/scene/gltf_loader.h"

namespace impostor {

struct AtlasBakeRequest {
  std::filesystem::path entry_file;  // .glb / .gltf with its files beside it
  v1::BakeParameters parameters;     // normalised
  std::string cache_key;
  std::filesystem::path output_dir;  // exists and is empty
  GltfLoadLimits load_limits;        // the worker's configured input limits
  // The scene of entry_file as the worker already loaded it (in its
  // isolated child, isolated_load.h); null: the bake loads entry_file.
  std::shared_ptr<const Scene> scene;
  // Encode the maps before the quality pass instead of beside it. The
  // output bytes are the same either way (tested); for that test and for
  // profiling a stage alone.
  bool serial_encode = false;
  // Measuring tools only (bench/quality_table): changes to the quality
  // pass's rules; the manifest records the view size used.
  QualityPassOverrides quality_overrides = {};
  // Called once for each map file (albedo_alpha, normal_depth, orm,
  // emissive; PNG or KTX2) as soon as its bytes are final, with their
  // digest, while the bake goes on (the quality pass runs for seconds after
  // the maps are written): the worker starts uploading them then
  // (early_result_upload.h). Called from the encoders' threads, several at
  // once; must return quickly. Null: not called.
  std::function<void(const std::filesystem::path& file, const BlobDigest& digest)> map_written;
};

struct AtlasBakeOutput {
  // Complete manifest, maps' digests filled; manifest_json set to the digest
  // of output_dir/manifest.json.
  v1::Manifest manifest;
  std::filesystem::path manifest_path;
};

// Stage name ("load", "render", "encode"...) and fraction of the whole bake.
using BakeProgress = std::function<void(std::string_view stage, double fraction)>;

// The request's scene: `request.scene`, or entry_file loaded now.
absl::StatusOr<std::shared_ptr<const Scene>> SceneOf(const AtlasBakeRequest& request);

// Runs the pipeline. INVALID_ARGUMENT for a mesh that cannot be baked (the
// message says why); CANCELLED when `cancelled` turns true between stages;
// other codes for infrastructure failures (worth a retry elsewhere).
absl::StatusOr<AtlasBakeOutput> BakeAtlas(const AtlasBakeRequest& request, AtlasRenderer& renderer,
                                          const BakeProgress& progress, const std::atomic<bool>& cancelled);

}  // namespace impostor

#endif  // IMPOSTOR_WORKER_BAKE_ATLAS_BAKE_H_
