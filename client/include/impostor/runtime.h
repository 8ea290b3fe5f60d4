// Impostor runtime math for game programmers: which baked frames to blend
// for a view, with what weights, and where each frame is sampled. Plain C++
// (no gRPC, protobuf or glm types); the same math as the CPU reference
// renderer and the reference shader shaders/impostor_runtime.glsl, and the
// same direction <-> frame mapping the baker used (one implementation).
//
// Conventions (manifest.json, manifest_format.md in share/doc/impostor): object space is
// the glTF scene's space, +Y up. A view direction is the unit vector from the
// bounding sphere's centre TOWARD the camera (for a perspective camera at
// eye e: normalize(e - center)). Frame indices are those of the manifest's
// `views` (row * frames + col on the grid layouts).
//
// Layouts: the octahedral ones, and azimuth-elevation, ring-top and
// billboard. A layout is described by an AtlasLayout; build it from the
// manifest with AtlasLayoutFromManifest(manifest["layout"],
// manifest["frames"], manifest["views"].size()) (ring-top's ring count is
// views - 1), or from a cached result with AtlasLayoutFromManifest(
// result.layout(), result.frames(), result.view_count()). The (Layout,
// frames) overloads below are kept for the layouts `frames` describes fully
// (all but ring-top). An AtlasLayout no bake produces (a ring-top through
// those overloads, whose ring count `frames` does not give; frames out of
// 2..64; an even azimuth-elevation grid) gets empty answers: no blend
// entries (count 0), an invalid FrameUv, a zero FrameBasis, coverage 0.
//
// Typical per-instance use (the shader does the per-pixel part), with the
// manifest parsed by nlohmann::json:
//
//   auto layout = impostor::sdk::AtlasLayoutFromManifest(
//       manifest["layout"].get<std::string>(), manifest["frames"].get<int>(),
//       static_cast<int>(manifest["views"].size()));
//   if (!layout) ...  // not an atlas this runtime can draw
//   float dir[3] = {...};  // object space, centre -> camera
//   impostor::sdk::FrameBlend blend = impostor::sdk::BlendFrames(
//       *layout, dir, impostor::sdk::BlendMode::kTriangle3);
//   for (int i = 0; i < blend.count; ++i)
//     ... blend.entries[i].frame, blend.entries[i].weight ...
//
// Blend modes: kTriangle3 (Ryan Brucks' octahedral impostors: the three
// frames of the grid triangle the view lies in, barycentric weights) and
// kBilinear4 (the four frames of the grid cell, bilinear weights). Weights
// are positive, sum to 1, vary continuously with the view, and are 1 on a
// frame seen from exactly its own direction. Duplicate frames of the
// octahedron's folded border are merged into the lowest-numbered one (the
// manifest's `same_view_as`). Azimuth-elevation blends the 2 x 2 frames
// around the view in (azimuth, elevation), wrapping in azimuth, with the
// pole caps handed to one frame; ring-top and billboard blend the two ring
// frames around the azimuth with the top frame by elevation (both modes);
// the exact weights are runtime.md's (share/doc/impostor) and impostor_runtime.glsl's
// (share/impostor/shaders), the same math.
//
// All functions are pure and thread-safe.
#ifndef IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_RUNTIME_H_
#define IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_RUNTIME_H_

#include <functional>
#include <optional>
#include <string_view>

namespace impostor::sdk {

enum class Layout {
  kOctahedral,        // "octahedral": full sphere
  kHemiOctahedral,    // "hemi-octahedral": upper hemisphere
  kAzimuthElevation,  // "azimuth-elevation": N x N azimuth columns x elevation rows
  kRingTop,           // "ring-top": K horizontal views + 1 from above
  kBillboard,         // "billboard": 8 horizontal views + 1 from above, 3 x 3
};

// The manifest's `layout` string; nullopt if unknown.
std::optional<Layout> LayoutFromName(std::string_view manifest_name);
std::string_view LayoutName(Layout layout);

struct AtlasLayout {
  Layout layout = Layout::kOctahedral;
  int frames = 0;      // the manifest's `frames`: frames per axis, or the atlas grid side (ring-top, billboard)
  int ring_views = 0;  // ring-top: K; billboard: 8; others 0
};

// From the manifest's `layout`, `frames` and the length of its `views`
// list; nullopt for an unknown layout name or a view count that does not
// fit the layout (frames * frames, or K + 1 with K >= 1 for ring-top, 9 for
// billboard).
std::optional<AtlasLayout> AtlasLayoutFromManifest(std::string_view layout, int frames, int view_count);
// Frames in the atlas (the manifest's views.size()).
int FrameCount(const AtlasLayout& layout);

enum class BlendMode {
  kTriangle3,  // "triangle3": up to 3 frames
  kBilinear4,  // "bilinear4": up to 4 frames
};

std::optional<BlendMode> BlendModeFromName(std::string_view name);
std::string_view BlendModeName(BlendMode mode);

struct FrameWeight {
  int frame = 0;        // index, row * frames + col
  float weight = 0.0f;  // > 0
};

// Entries come in no particular order (not by weight): pick the dominant
// frame by its weight. Within float rounding of a frame's own direction its
// neighbours may still appear, with weights near 1e-7.
struct FrameBlend {
  int count = 0;           // entries used, 1..4 (0: the layout is not one a bake produces)
  FrameWeight entries[4];  // weights sum to 1
};

// The frames to blend for `view_dir` (object space, centre -> camera; need
// not be normalised; a zero or non-finite vector is taken as +Y). `frames` =
// the manifest's `frames`.
FrameBlend BlendFrames(const AtlasLayout& layout, const float view_dir[3], BlendMode mode);
FrameBlend BlendFrames(Layout layout, int frames, const float view_dir[3], BlendMode mode);

// The camera that baked `frame` (the manifest's `views[frame]`): direction
// (centre -> camera), up (toward tile row 0) and right, all unit length.
struct FrameBasis {
  float direction[3];
  float up[3];
  float right[3];
};
FrameBasis FrameCameraBasis(const AtlasLayout& layout, int frame);
FrameBasis FrameCameraBasis(Layout layout, int frames, int frame);

// Where a view ray samples a frame, in the frame's tile: u from 0 (left) to
// 1 (right), v from 0 (top row) to 1 (bottom). Outside [0, 1] the ray passes
// outside the frame's view square (nothing there). `valid` is false when the
// frame faces away from the ray (or the parallax march found no surface).
struct FrameUv {
  bool valid = false;
  float u = 0.0f;
  float v = 0.0f;
};

// The view ray in object space: `ray_origin` any point on it (e.g. the eye,
// or the impostor card's fragment position), `ray_dir` its direction from
// the eye into the scene. The ray is intersected with the frame's virtual
// plane (through the sphere centre, normal = the frame's direction, shifted
// by `height` x radius along that normal) and the hit projected with the
// frame's bake camera.
FrameUv VirtualPlaneUv(const AtlasLayout& layout, int frame, const float sphere_center[3], float sphere_radius,
                       const float ray_origin[3], const float ray_dir[3], float height = 0.0f);
FrameUv VirtualPlaneUv(Layout layout, int frames, int frame, const float sphere_center[3], float sphere_radius,
                       const float ray_origin[3], const float ray_dir[3], float height = 0.0f);

// The same with parallax: marches the ray through the frame's captured depth
// (16 steps from the front of the bounding sphere to the back, then 4
// bisection steps; see runtime.md in share/doc/impostor). `read_depth(u, v,
// &depth01)` returns the frame's depth (the normal_depth map's A channel,
// 0..1) at tile coordinates (u, v), or false where the frame is empty
// (coverage below 0.5).
using FrameDepthReader = std::function<bool(float u, float v, float* depth01)>;
FrameUv VirtualPlaneUvParallax(const AtlasLayout& layout, int frame, const float sphere_center[3],
                               float sphere_radius, const float ray_origin[3], const float ray_dir[3],
                               const FrameDepthReader& read_depth);
FrameUv VirtualPlaneUvParallax(Layout layout, int frames, int frame, const float sphere_center[3],
                               float sphere_radius, const float ray_origin[3], const float ray_dir[3],
                               const FrameDepthReader& read_depth);

// Atlas texture coordinates (0..1 over the whole atlas, v down) of a frame's
// tile coordinates, for an atlas of `resolution` pixels: square tiles of the
// manifest's `tile_size` pixels from the top-left corner (floor(resolution /
// side) rounded down to a multiple of a power of two so that mip levels never
// mix tiles; manifest_format.md), the rest of the atlas empty. The
// AtlasLayout form places frame i in tile (i % side, i / side) of the
// layout's side x side grid (side = frames, or ceil(sqrt(K + 1)) for
// ring-top, 3 for billboard); the int form is for the grid layouts.
// Texture-array results (CachedResult::texture_array()) have no atlas: use
// layer `frame` at `uv` directly.
void FrameUvToAtlasUv(const AtlasLayout& layout, int resolution, int frame, const FrameUv& uv, float atlas_uv[2]);
void FrameUvToAtlasUv(int frames, int resolution, int frame, const FrameUv& uv, float atlas_uv[2]);

// ---- Reconstruction modes (runtime.md: cost of each) ----
// plain: each blended frame sampled on its virtual plane (VirtualPlaneUv, or
// VirtualPlaneUvParallax). depth: every blended frame samples the same
// surface point and frames that did not see it drop out, which removes the
// double image between frames (runtime.md).
enum class Reconstruction { kPlain, kDepth };
std::optional<Reconstruction> ReconstructionFromName(std::string_view name);  // "plain", "depth"
std::string_view ReconstructionName(Reconstruction mode);

// Depth mode for one view ray. `read(entry, u, v, &depth01)` returns blend
// entry `entry`'s filtered coverage (0..1) at its tile coordinates (u, v)
// and, where > 0, its depth (normal_depth's A). The answer: coverage (the
// pixel is covered iff >= 0.5) and per blend entry where to sample it (uv)
// and its share of the shading (weight; the used entries' weights sum to 1
// where covered, 0 for entries that did not see the point).
using FrameSurfaceReader = std::function<float(int entry, float u, float v, float* depth01)>;
struct DepthReconstruction {
  float coverage = 0.0f;
  FrameUv uv[4];
  float weight[4] = {0.0f, 0.0f, 0.0f, 0.0f};
};
DepthReconstruction ReconstructDepth(const AtlasLayout& layout, const FrameBlend& blend, const float sphere_center[3],
                                     float sphere_radius, const float ray_origin[3], const float ray_dir[3],
                                     const FrameSurfaceReader& read);

}  // namespace impostor::sdk

#endif  // IMPOSTOR_CLIENT_INCLUDE_IMPOSTOR_RUNTIME_H_
