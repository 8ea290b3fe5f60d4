// Level-of-detail selection for a baked LOD chain (product "lod-chain"):
// the original mesh (lod0.glb), simplified levels (lod1.glb, ...) and an
// atlas impostor as the last level (impostor.json, an atlas manifest).
//
// Plain C++ (no gRPC, no protobuf); link impostor::lod (installed SDK:
// find_package(impostor), libimpostor_runtime.so; in this build tree the
// static impostor_lod_sdk). LoadLodChain
// reads a result directory's manifest.json once; SelectLod / SelectLods are
// pure functions of their arguments, cheap enough to run per instance per
// frame, and thread-safe.
//
// THE RULE. Thresholds are screen scales: pixels per scene unit of object
// size, independent of resolution and field of view. For an object at
// distance d (scene units, camera to the chain's bounding-sphere centre)
// seen by a camera with vertical field of view fov_y and a viewport
// viewport_height_px pixels tall,
//
//   s = viewport_height_px / (2 * tan(fov_y / 2) * d)
//
// is how many pixels one scene unit covers. Level i (i < last) is drawn while
// s >= threshold[i]; below it the next level takes over. The last level
// (the impostor) has threshold 0. The thresholds are non-increasing, so
// without history the level is the first i with s >= threshold[i].
// Equivalently, level i gives way at the distance
//
//   d_i = viewport_height_px / (2 * tan(fov_y / 2) * threshold[i])
//
// (SwitchDistance). The baker chose threshold[i] = pixel_error / error[i+1]
// (the next level's geometric error, scene units, projects to the pixel
// budget, 1 px by default, exactly at the switch) and, for the last mesh
// level, good_up_to_pixels / (2 * radius): the impostor takes over when the
// bounding sphere's diameter covers fewer pixels than its quality pass found
// it good for (manifest quality.good_up_to_pixels, issue 43), or fewer than
// 16 px when the bake measured no such size. SetImpostorSwitchPixels moves
// that switch to a size of the caller's.
//
// HYSTERESIS. With the level drawn last frame, moving to a coarser level
// happens at the threshold as above (so the error budget always holds);
// moving back to a finer level across threshold[i] needs
// s >= threshold[i] * (1 + hysteresis), i.e. the object must come closer
// than d_i / (1 + hysteresis). An object sitting between the two does not
// toggle.
//
// CROSS-FADE. Instead of popping from level i to i + 1 in one frame, both
// can be drawn over a band of screen scales above the switch, each
// discarding a complementary, instance-seeded dither of pixels
// (CrossFadeDrawsImpostor / CrossFadeDrawsMesh; the same function as
// shaders/impostor_crossfade.glsl). The fade factor t goes from 0 at
// s = threshold[i] * (1 + band) (only level i) to 1 at s = threshold[i]
// (only level i + 1), linearly in s, i.e. in on-screen size; it is a
// function of s alone, so the picture is the same coming and going and the
// hysteresis above only decides which level SelectLod reports.
#ifndef IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_LOD_H_
#define IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_LOD_H_

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace impostor::sdk {

struct LodLevelInfo {
  enum class Kind { kMesh, kImpostor };
  int level = 0;  // 0 = the original mesh
  Kind kind = Kind::kMesh;
  // File in the result directory: a .glb (mesh) or the impostor's atlas
  // manifest (impostor.json).
  std::string file;
  std::string digest_hash;  // lowercase hex SHA-256 of the file
  int64_t size_bytes = 0;
  uint64_t triangles = 0;   // impostor: 2
  float target_ratio = 0;   // asked for: 1 for LOD0, 0 for the impostor
  float error = 0;          // geometric error, scene units (0 for LOD0)
  // Pixels per scene unit below which the next level takes over (see THE
  // RULE above); 0 for the last level.
  float threshold = 0;
  bool sloppy = false;      // sloppy simplification was needed
};

struct LodChain {
  std::vector<LodLevelInfo> levels;  // nearest first; the last is the impostor
  std::array<float, 3> center{};     // bounding sphere, scene space
  float radius = 0;                  // scene units
  // The on-screen size (bounding-sphere diameter, pixels) up to which the
  // impostor meets its targets (manifest quality.good_up_to_pixels); 0 when
  // the bake did not measure it.
  uint32_t good_up_to_pixels = 0;
  std::filesystem::path directory;   // where manifest.json was read

  // Absolute path of a level's file.
  std::filesystem::path LevelPath(int level) const { return directory / levels.at(level).file; }
};

struct LodSelectOptions {
  // Width of the hysteresis band as a fraction of the threshold, applied on
  // the way back to a finer level. Default 0.1; range 0..1 (clamped).
  float hysteresis = 0.1f;
};

struct LodCrossFadeOptions {
  // Width of the cross-fade band above each switch, as a fraction of the
  // switch's screen scale (threshold): the fade starts at threshold *
  // (1 + band) and ends at the switch. Default 0.1 (the object's on-screen
  // size shrinks by a tenth while it fades); range 0..1 (clamped); 0 is a
  // hard switch.
  float band = 0.1f;
};

// What to draw at one screen scale during a cross-fade.
struct LodCrossFade {
  int level = 0;  // the finer level: drawn alone when t == 0
  // 0: `level` only; 1: `level` + 1 only; between: both, `level` where
  // CrossFadeDrawsMesh(t, ...) and `level` + 1 where CrossFadeDrawsImpostor.
  float t = 0;
};

// Reads `manifest_json` (a lod-chain result's manifest.json). NOT_FOUND when
// the file is missing; INVALID_ARGUMENT naming the key when it is not a
// lod-chain manifest, lacks the lods list, has levels out of order, a last
// level that is not the impostor, or thresholds that are negative or
// increase.
absl::StatusOr<LodChain> LoadLodChain(const std::filesystem::path& manifest_json);

// Pixels per scene unit at `distance`: viewport_height_px /
// (2 tan(fov_y / 2) distance); +infinity for distance <= 0.
float ScreenScale(float distance, float fov_y_radians, float viewport_height_px);

// The level to draw at screen scale `pixels_per_unit` given the level drawn
// last frame (`previous_level` < 0 or out of range: no history).
int SelectLodForScale(const LodChain& chain, float pixels_per_unit, int previous_level,
                      const LodSelectOptions& options = {});

// The level to draw for an object at `distance` scene units (SelectLodForScale
// of ScreenScale). An empty chain gives 0.
int SelectLod(const LodChain& chain, float distance, float fov_y_radians, float viewport_height_px,
              int previous_level, const LodSelectOptions& options = {});

// SelectLod for many instances: levels[i] = SelectLod(chain, distances[i],
// ..., previous_levels[i]). `levels` may be the same memory as
// `previous_levels` (updated in place). INVALID_ARGUMENT when the three spans
// differ in size.
absl::Status SelectLods(const LodChain& chain, std::span<const float> distances, float fov_y_radians,
                        float viewport_height_px, std::span<const int> previous_levels, std::span<int> levels,
                        const LodSelectOptions& options = {});

// Moves the switch from the last mesh level to the impostor to where the
// bounding sphere's diameter covers `diameter_pixels` (e.g. a smaller size
// than chain.good_up_to_pixels for a hero asset): the last mesh level's
// threshold becomes diameter_pixels / (2 * radius), and a finer level whose
// threshold would then be smaller takes it too (it is never drawn, as with
// the baker's own thresholds). INVALID_ARGUMENT for a size that is not
// finite and > 0, or a chain without a mesh level or with radius <= 0.
absl::Status SetImpostorSwitchPixels(LodChain& chain, float diameter_pixels);

// Distance at which `level` gives way to the next one for this camera
// (+infinity for the last level).
float SwitchDistance(const LodChain& chain, int level, float fov_y_radians, float viewport_height_px);

// Fade factor at screen scale `pixels_per_unit` for a switch at
// `switch_scale` (the finer level's threshold): 0 at or above switch_scale
// * (1 + band), 1 at or below switch_scale, linear between. A band of 0 (or
// a switch_scale <= 0) gives the hard switch: 0 above, 1 at or below.
float CrossFadeFactor(float pixels_per_unit, float switch_scale, const LodCrossFadeOptions& options = {});

// The level and fade factor at screen scale `pixels_per_unit`: `level` is
// SelectLodForScale's without history, t the CrossFadeFactor of its switch
// (0 for the last level). An empty chain gives {0, 0}.
LodCrossFade SelectLodCrossFade(const LodChain& chain, float pixels_per_unit, const LodCrossFadeOptions& options = {});

// The dither that splits pixels between the two levels (pixel (x, y) in
// the render target's pixel grid, e.g. floor(gl_FragCoord.xy); `seed` per
// instance, e.g. its index): a 4 x 4 ordered (Bayer) threshold whose levels
// are rotated by the top 4 bits of seed * 2654435769 (Fibonacci hashing), so
// neighbouring instances fading together use different pixels. Threshold:
// (level + 0.5) / 16, one of 16 values in (0, 1).
float CrossFadeThreshold(uint32_t seed, int x, int y);

// The coarser level (the impostor) draws pixel (x, y) iff threshold < t;
// the finer (the mesh) iff not. Complementary at every t: each pixel is
// drawn by exactly one; over any aligned 4 x 4 block the coarser level's
// share is within 1/32 of t (exactly t for t = k / 16). t <= 0: the mesh
// everywhere; t >= 1: the impostor everywhere.
bool CrossFadeDrawsImpostor(float t, uint32_t seed, int x, int y);
bool CrossFadeDrawsMesh(float t, uint32_t seed, int x, int y);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_LOD_H_
