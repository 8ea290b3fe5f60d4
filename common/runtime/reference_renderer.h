// CPU reference renderer for impostors of every layout: draws a baked atlas for
// any orthographic camera exactly as a game's impostor shader would, using
// the runtime math of frame_blend.h and virtual_plane.h (the same math as the
// SDK header client/include/impostor/runtime.h and the reference shader
// shaders/impostor_runtime.glsl). It is the oracle for game-side shaders and
// for the bake quality pass; it is plain loops on one thread (about 14 ms for
// a 128 x 128 view, 130 ms with parallax) and thread-safe (pure).
//
// Per output pixel (x, y) of a `pixels` x `pixels` view, at view coordinates
//   s = (x + 0.5) / pixels * 2 - 1,  t = 1 - (y + 0.5) / pixels * 2
// (frame_camera.h, row 0 = camera up):
//  1. Frames and weights w_i: BlendFrames(AtlasViewLayout(atlas),
//     camera.direction, options.blend) — one set for the whole view, because
//     the view is orthographic (every pixel has the same view direction).
//  2. Each frame i is sampled through its virtual plane (ProjectToFrame, or
//     ProjectToFrameParallax when options.parallax) at tile pixel coordinates
//     FrameStToPixel (with parallax, a ray that misses the frame's height
//     field gives an empty sample). Sampling is bilinear over the 2x2
//     nearest texel centres of that frame's tile only, texel indices clamped
//     to the tile, so no neighbouring tile ever bleeds in. A sample whose point falls outside the
//     tile's square (|s_f| or |t_f| > 1, i.e. outside the bounding sphere's
//     view square) or that has no plane intersection is empty (alpha 0).
//     Within a frame the bilinear filter is alpha-weighted (premultiplied):
//     colour, normal, ORM and depth of a sample average only covered texels,
//     so the dilated (or undilated) colour of empty texels never leaks in.
//     Albedo is filtered and blended in linear space (sRGB decoded first, as a
//     GPU samples an sRGB texture) and re-encoded to sRGB at the end.
//  3. Blended alpha A = sum_i w_i * a_i. The pixel is covered iff A >= 0.5
//     (the bake's coverage is binary; 0.5 is the midpoint, a game would use
//     the same alpha-test threshold). Covered pixels get alpha 255.
//  4. Colour, ORM and depth: sum_i w_i a_i X_i / sum_i w_i a_i, i.e. straight
//     alpha colours blended among the covered samples, each by its weight
//     times its coverage. Normals: the same weighted sum, renormalised.
//  5. Depth: each sample's frame depth d01 is first turned into its point
//        p = c + r * (s_f * right_f + t_f * up_f + (1 - 2 * d01) * dir_f)
//     and then into the view camera's depth (1 - dot(p - c, v) / r) / 2, so
//     the output depth uses the view camera's convention (frame_camera.h).
//  6. Empty pixels are encoded exactly as AtlasImages's empty texels:
//     albedo 0,0,0,0; normal_depth 32768,32768,32768,65535 (0.5, 0.5, 0.5,
//     1.0 in UNORM16, as the bake's clear value); orm 0,0,0,0.
// With options.reconstruction == kDepth, steps 2..5 follow
// depth_reconstruction.h: coverage from each frame's march hit, colour and
// depth from every frame's sample at the common point P, weighted by
// w_i * a_i * agreement_i.
// ORM is produced only when atlas.orm is non-empty (otherwise ViewImages.orm
// stays empty).
//
// With the camera on a frame's direction (its up from CameraUpFor) and
// pixels == tile size, the weights put 1 on that frame, the virtual plane is
// the identity and every sample lands on a texel centre, so the view
// reproduces the baked tile (bit for bit up to float rounding).
#ifndef IMPOSTOR_COMMON_RUNTIME_REFERENCE_RENDERER_H_
#define IMPOSTOR_COMMON_RUNTIME_REFERENCE_RENDERER_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "common/atlas/atlas_layout.h"
#include "common/atlas/frame_camera.h"
#include "common/runtime/depth_reconstruction.h"
#include "common/runtime/frame_blend.h"

namespace impostor {

struct ImpostorAtlas {            // a baked atlas in memory
  LayoutKind layout = LayoutKind::kOctahedral;
  // Octahedral, hemi-octahedral, azimuth-elevation: frames per axis (N).
  // Ring-top and billboard: the atlas grid side (the request's derived
  // `frames`); their frames are counted by ring_views.
  int frames = 0;
  // Ring-top: horizontal views K (the manifest's views.size() - 1).
  // Billboard: 8 or left 0. Others: 0.
  int ring_views = 0;
  int resolution = 0;
  BoundingSphere sphere;                 // from the manifest
  // AtlasCameras(AtlasViewLayout(atlas), resolution): FrameCount of them,
  // index order.
  std::vector<FrameCamera> cameras;
  int width = 0, height = 0;             // atlas pixels
  std::vector<uint8_t> albedo_alpha;     // RGBA8, as AtlasImages
  std::vector<uint16_t> normal_depth;    // RGBA16, as AtlasImages
  std::vector<uint8_t> orm;              // RGBA8 or empty
};

struct ViewImages {               // one rendered view, same encodings as AtlasImages
  int width = 0, height = 0;
  std::vector<uint8_t> albedo_alpha;
  std::vector<uint16_t> normal_depth;
  std::vector<uint8_t> orm;
};

struct ReferenceRenderOptions {
  BlendMode blend = BlendMode::kTriangle3;
  bool parallax = false;  // plain only: march each frame's depth (no agreement)
  // kDepth: depth_reconstruction.h (every frame samples the common surface
  // point, frames that did not see it drop out); `parallax` is then implied.
  Reconstruction reconstruction = Reconstruction::kPlain;
};

// The shared mapping's description of the atlas's layout.
ViewLayout AtlasViewLayout(const ImpostorAtlas& atlas);

// Whether the atlas can be drawn: its layout has frames, its maps have
// width x height texels, and it has one camera per frame, each tile inside.
bool AtlasIsConsistent(const ImpostorAtlas& atlas);

// Empty-texel encodings (atlas_renderer.h, the bake's clear values).
inline constexpr uint16_t kEmptyNormal16 = 32768;  // 0.5 in UNORM16
inline constexpr uint16_t kEmptyDepth16 = 65535;   // 1.0

// A view with no pixel covered: albedo and alpha 0, the empty normal and
// depth encodings, orm 0 (none without has_orm).
ViewImages EmptyViewImages(int pixels, bool has_orm);

// Stores one covered pixel (index y * width + x) in the bake's encodings:
// linear `albedo` as sRGB bytes with alpha 255, unit `normal` as
// n * 0.5 + 0.5 and view `depth` (0 near .. 1 far) in UNORM16, `orm` (may be
// null; ignored when the view has none) in UNORM8. Every renderer of impostor
// views stores its pixels so (RenderImpostorView, the device's runtime views
// in worker/gpu), so their images compare byte for byte.
void StoreShadedPixel(size_t pixel, glm::vec3 albedo, glm::vec3 normal, float depth, const glm::vec3* orm,
                      ViewImages* view);

// Renders the impostor as a game would for an orthographic camera `camera` framed by
// atlas.sphere exactly like a bake camera (FrameViewProjection), into pixels x pixels.
// `camera.tile` is ignored. Returns empty images (width 0) if the atlas is
// inconsistent (sizes or camera count do not match) or pixels <= 0.
ViewImages RenderImpostorView(const ImpostorAtlas& atlas, const FrameCamera& camera, int pixels,
                              const ReferenceRenderOptions& options);

// A view camera for any direction (unit, sphere centre -> camera), built the
// way AtlasCameras builds bake cameras: up = CameraUpFor(direction),
// right = cross(up, direction). index/frame/tile are left at defaults.
FrameCamera ViewCameraFor(glm::vec3 direction);

}  // namespace impostor

#endif  // IMPOSTOR_COMMON_RUNTIME_REFERENCE_RENDERER_H_
