// Reference runtime for impostors of every layout, for engines to copy.
//
// The same math, line for line, as the C++ in common/runtime/ (frame_blend,
// virtual_plane, reference_renderer) and the SDK header
// client/include/impostor/runtime.h, with the same conventions and the same
// tie-breaking; tests/runtime checks this file against the C++ on the GPU.
// Conventions (common/manifest/manifest_format.md): object space, +Y up; a view
// direction points from the bounding sphere's centre TOWARD the camera;
// frame (col, row) is the grid vertex uv = (col, row) / (frames - 1) of the
// (hemi-)octahedral square; its tile starts at (col, row) * tile_size pixels
// from the atlas's top-left corner; positions below are relative to the
// sphere centre in units of its radius ((p - centre) / radius).
// The other layouts (common/atlas/atlas_layout.h): azimuth-elevation (N x N,
// column c at azimuth c * 2 pi / N, row r at elevation 90 - (r + 0.5) * 180
// / N degrees), ring-top (K ring views at elevation 0, then one from above)
// and billboard (ring-top with K = 8); frame i's tile is (i % side, i /
// side) of the layout's side x side grid. An ImpostorLayout names a layout
// (kind, frames, ring_views: the manifest's layout, frames and views - 1 for
// ring-top); the *Layout functions take it, the older (layout_kind, frames)
// ones stay for the layouts frames describes fully (all but ring-top).
//
// Textures (as baked): albedo_alpha (sRGB, bind as an SRGB format so reads
// are linear; A = coverage), normal_depth (UNORM16: normal * 0.5 + 0.5,
// A = depth 0 nearest .. 1 farthest), orm (UNORM8, optional). Sampling uses
// texelFetch and filters by hand, alpha-weighted and clamped to the frame's
// own tile, so neighbouring tiles never bleed in (no mipmaps here).
//
// Use (per fragment; the blend can move to the vertex shader, it depends
// only on the view direction):
//   ImpostorLayout atlas = ImpostorLayout(layout_kind, frames, ring_views);
//   ImpostorBlend b = impostorBlendFramesLayout(atlas, view_dir, mode);
//   ImpostorSurface s = impostorShadeLayout(albedo_tex, normal_depth_tex,
//       orm_tex, has_orm, atlas, tile_size, b, ray_origin, ray_dir, parallax);
// or, choosing the reconstruction (IMPOSTOR_RECONSTRUCT_DEPTH removes the
// ghosting between frames; docs/runtime.md lists the cost of each mode):
//   ImpostorSurface s = impostorReconstructLayout(albedo_tex, normal_depth_tex,
//       orm_tex, has_orm, atlas, tile_size, b, ray_origin, ray_dir, mode);
// (`layout` is a GLSL keyword, hence `atlas`.)
//   if (s.alpha < 0.5) discard;
// where ray_origin/ray_dir are the fragment's view ray in object space
// (radius units, relative to the centre) and view_dir = normalize(eye - c).
#ifndef IMPOSTOR_RUNTIME_GLSL
#define IMPOSTOR_RUNTIME_GLSL

const int IMPOSTOR_LAYOUT_OCTAHEDRAL = 0;
const int IMPOSTOR_LAYOUT_HEMI_OCTAHEDRAL = 1;
const int IMPOSTOR_LAYOUT_AZIMUTH_ELEVATION = 2;
const int IMPOSTOR_LAYOUT_RING_TOP = 3;
const int IMPOSTOR_LAYOUT_BILLBOARD = 4;
const int IMPOSTOR_BILLBOARD_RING_VIEWS = 8;
const float IMPOSTOR_PI = 3.14159265358979323846;
const float IMPOSTOR_TWO_PI = 6.28318530717958647692;
const int IMPOSTOR_BLEND_TRIANGLE3 = 0;
const int IMPOSTOR_BLEND_BILINEAR4 = 1;
const int IMPOSTOR_PARALLAX_STEPS = 16;       // kParallaxSteps
const int IMPOSTOR_PARALLAX_REFINEMENTS = 4;  // kParallaxRefinements
const int IMPOSTOR_PARALLAX_CROSSING_STEPS = 4;  // kParallaxCrossingSteps
// Reconstruction modes (common/runtime/depth_reconstruction.h): plain flat
// virtual planes, plain with the parallax march, depth (common surface point,
// disocclusion weights).
const int IMPOSTOR_RECONSTRUCT_PLAIN = 0;
const int IMPOSTOR_RECONSTRUCT_PARALLAX = 1;
const int IMPOSTOR_RECONSTRUCT_DEPTH = 2;
const float IMPOSTOR_DEPTH_AGREEMENT = 0.05;  // kDepthAgreement, radius units
const float IMPOSTOR_EXTRUSION_DEPTH = 2.0 * IMPOSTOR_DEPTH_AGREEMENT;  // kExtrusionDepth
const float IMPOSTOR_EXTRUSION_CONFIRM = 0.75;                         // kExtrusionConfirm
const float IMPOSTOR_EXTRUSION_CONFIRM_RAMP = 0.25;                    // kExtrusionConfirmRamp

// ---- direction <-> layout square (common/atlas/atlas_layout.cc) ----

float impostorSignNotZero(float v) { return v < 0.0 ? -1.0 : 1.0; }

vec3 impostorOctahedralToDirection(vec2 oct) {
  vec3 d = vec3(oct.x, 1.0 - abs(oct.x) - abs(oct.y), oct.y);
  if (d.y < 0.0) {
    float x = (1.0 - abs(oct.y)) * impostorSignNotZero(oct.x);
    float z = (1.0 - abs(oct.x)) * impostorSignNotZero(oct.y);
    d.x = x;
    d.z = z;
  }
  return normalize(d);
}

vec2 impostorDirectionToOctahedral(vec3 d) {
  d /= (abs(d.x) + abs(d.y) + abs(d.z));
  if (d.y >= 0.0) return vec2(d.x, d.z);
  return vec2((1.0 - abs(d.z)) * impostorSignNotZero(d.x), (1.0 - abs(d.x)) * impostorSignNotZero(d.z));
}

vec3 impostorHemiOctahedralToDirection(vec2 oct) {
  float x = (oct.x + oct.y) * 0.5;
  float z = (oct.x - oct.y) * 0.5;
  return normalize(vec3(x, 1.0 - abs(x) - abs(z), z));
}

vec2 impostorDirectionToHemiOctahedral(vec3 d) {
  d.y = max(d.y, 0.0);
  float sum = abs(d.x) + d.y + abs(d.z);
  if (sum == 0.0) return vec2(0.0);
  d /= sum;
  return vec2(d.x + d.z, d.x - d.z);
}

vec3 impostorLayoutToDirection(int layout_kind, vec2 oct) {
  return layout_kind == IMPOSTOR_LAYOUT_OCTAHEDRAL ? impostorOctahedralToDirection(oct)
                                              : impostorHemiOctahedralToDirection(oct);
}

vec2 impostorDirectionToLayout(int layout_kind, vec3 d) {
  return layout_kind == IMPOSTOR_LAYOUT_OCTAHEDRAL ? impostorDirectionToOctahedral(d)
                                              : impostorDirectionToHemiOctahedral(d);
}

vec2 impostorDirectionToGrid(int layout_kind, int frames, vec3 d) {
  vec2 oct = impostorDirectionToLayout(layout_kind, d);
  float scale = float(frames - 1);
  return clamp((oct * 0.5 + 0.5) * scale, vec2(0.0), vec2(scale));
}

vec3 impostorFrameDirection(int layout_kind, int frames, ivec2 frame) {
  float inv = frames > 1 ? 1.0 / float(frames - 1) : 0.0;
  vec2 uv = vec2(float(frame.x) * inv, float(frame.y) * inv);
  return impostorLayoutToDirection(layout_kind, uv * 2.0 - 1.0);
}

int impostorFrameIndex(int frames, ivec2 f) { return f.y * frames + f.x; }

// The lowest-numbered frame showing the same view (the octahedron's fold).
ivec2 impostorCanonicalFrame(int layout_kind, int frames, ivec2 frame) {
  if (layout_kind != IMPOSTOR_LAYOUT_OCTAHEDRAL || frames < 2) return frame;
  int last = frames - 1;
  bool on_border = frame.x == 0 || frame.y == 0 || frame.x == last || frame.y == last;
  if (!on_border) return frame;
  bool corner = (frame.x == 0 || frame.x == last) && (frame.y == 0 || frame.y == last);
  if (corner) return ivec2(0, 0);
  ivec2 mirror = frame;
  if (frame.x == 0 || frame.x == last) mirror.y = last - frame.y;
  else mirror.x = last - frame.x;
  return impostorFrameIndex(frames, mirror) < impostorFrameIndex(frames, frame) ? mirror : frame;
}

// ---- frame blend (common/runtime/frame_blend.cc) ----

struct ImpostorBlend {
  int count;          // 1..4
  ivec2 frame[4];     // canonical frames: their tiles (col, row)
  int index[4];       // frame indices (the manifest's views)
  float weight[4];    // > 0, sum 1
};

void impostorBlendAdd(int layout_kind, int frames, ivec2 frame, float weight, inout ImpostorBlend b) {
  if (weight <= 0.0) return;
  ivec2 canonical = impostorCanonicalFrame(layout_kind, frames, frame);
  for (int i = 0; i < 4; ++i) {
    if (i < b.count && b.frame[i] == canonical) {
      b.weight[i] += weight;
      return;
    }
  }
  b.frame[b.count] = canonical;
  b.index[b.count] = impostorFrameIndex(frames, canonical);
  b.weight[b.count] = weight;
  b.count += 1;
}

ImpostorBlend impostorEmptyBlend() {
  ImpostorBlend b;
  b.count = 0;
  for (int i = 0; i < 4; ++i) {
    b.frame[i] = ivec2(0);
    b.index[i] = 0;
    b.weight[i] = 0.0;
  }
  return b;
}

void impostorBlendNormalize(inout ImpostorBlend b) {
  float total = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (i < b.count) total += b.weight[i];
  }
  for (int i = 0; i < 4; ++i) {
    if (i < b.count) b.weight[i] /= total;
  }
}

ImpostorBlend impostorBlendFramesGrid(int layout_kind, int frames, vec3 view_dir, int mode) {
  ImpostorBlend b = impostorEmptyBlend();
  if (frames <= 1) {
    b.count = 1;
    b.weight[0] = 1.0;
    return b;
  }
  // A zero or non-finite direction is taken as straight up (as in the C++).
  float length2 = dot(view_dir, view_dir);
  if (!(length2 > 0.0) || isinf(length2) || isnan(length2)) view_dir = vec3(0.0, 1.0, 0.0);
  vec2 grid = impostorDirectionToGrid(layout_kind, frames, view_dir);
  // The last grid line belongs to the last quad (fx, fy reach 1 there).
  int x0 = clamp(int(floor(grid.x)), 0, frames - 2);
  int y0 = clamp(int(floor(grid.y)), 0, frames - 2);
  float fx = clamp(grid.x - float(x0), 0.0, 1.0);
  float fy = clamp(grid.y - float(y0), 0.0, 1.0);
  ivec2 c0 = ivec2(x0, y0);
  if (mode == IMPOSTOR_BLEND_TRIANGLE3) {
    // Brucks: A = 1 - max on the current frame, B = |fx - fy| on the right
    // (fx > fy) or lower frame, C = min on the lower-right frame.
    impostorBlendAdd(layout_kind, frames, c0, 1.0 - max(fx, fy), b);
    if (fx > fy) impostorBlendAdd(layout_kind, frames, c0 + ivec2(1, 0), fx - fy, b);
    else impostorBlendAdd(layout_kind, frames, c0 + ivec2(0, 1), fy - fx, b);
    impostorBlendAdd(layout_kind, frames, c0 + ivec2(1, 1), min(fx, fy), b);
  } else {
    impostorBlendAdd(layout_kind, frames, c0, (1.0 - fx) * (1.0 - fy), b);
    impostorBlendAdd(layout_kind, frames, c0 + ivec2(1, 0), fx * (1.0 - fy), b);
    impostorBlendAdd(layout_kind, frames, c0 + ivec2(0, 1), (1.0 - fx) * fy, b);
    impostorBlendAdd(layout_kind, frames, c0 + ivec2(1, 1), fx * fy, b);
  }
  impostorBlendNormalize(b);
  return b;
}

// ---- every layout by frame index (common/atlas/atlas_layout.cc) ----

struct ImpostorLayout {
  int kind;        // IMPOSTOR_LAYOUT_*
  int frames;      // frames per axis (grid layouts) or the atlas grid side
  int ring_views;  // ring-top: K; billboard: 8 (or 0); others 0
};

bool impostorIsRing(ImpostorLayout atlas) {
  return atlas.kind == IMPOSTOR_LAYOUT_RING_TOP || atlas.kind == IMPOSTOR_LAYOUT_BILLBOARD;
}

int impostorRingViews(ImpostorLayout atlas) {
  return atlas.kind == IMPOSTOR_LAYOUT_BILLBOARD ? IMPOSTOR_BILLBOARD_RING_VIEWS : atlas.ring_views;
}

// Tiles per atlas side (GridSide).
int impostorGridSide(ImpostorLayout atlas) {
  if (!impostorIsRing(atlas)) return atlas.frames;
  int count = impostorRingViews(atlas) + 1;
  int side = 1;
  while (side * side < count) ++side;
  return side;
}

// Tile (col, row) of frame `index` (FrameTile).
ivec2 impostorFrameTile(ImpostorLayout atlas, int index) {
  int side = impostorGridSide(atlas);
  return ivec2(index % side, index / side);
}

vec3 impostorAzimuthElevationToDirection(float az, float el) {
  return vec3(sin(az) * cos(el), sin(el), cos(az) * cos(el));
}

// Direction of frame `index` (FrameDirectionAt).
vec3 impostorFrameDirectionAt(ImpostorLayout atlas, int index) {
  if (atlas.kind == IMPOSTOR_LAYOUT_AZIMUTH_ELEVATION) {
    int n = atlas.frames;
    float az = float(index % n) * IMPOSTOR_TWO_PI / float(n);
    float el = 0.5 * IMPOSTOR_PI - (float(index / n) + 0.5) * IMPOSTOR_PI / float(n);
    return impostorAzimuthElevationToDirection(az, el);
  }
  if (impostorIsRing(atlas)) {
    int k = impostorRingViews(atlas);
    if (index >= k) return vec3(0.0, 1.0, 0.0);
    return impostorAzimuthElevationToDirection(float(index) * IMPOSTOR_TWO_PI / float(k), 0.0);
  }
  return impostorFrameDirection(atlas.kind, atlas.frames, ivec2(index % atlas.frames, index / atlas.frames));
}

// ---- frame blend of the other layouts (frame_blend.cc) ----

// atan2 in plain arithmetic, as frame_blend.cc's Atan2: the built-in atan
// may be off by up to 4096 ULP on a Vulkan device, more than the weights
// may differ between the C++ and this shader. Octant reduction, then
// atan(a) = pi/4 + atan((a - 1) / (a + 1)) for a > tan(pi/8), then the
// Taylor series to r^17 (< 3e-9 rad).
float impostorAtan2(float y, float x) {
  float ax = abs(x), ay = abs(y);
  float hi = max(ax, ay), lo = min(ax, ay);
  if (!(hi > 0.0)) return 0.0;
  float a = lo / hi;
  bool reduced = a > 0.41421356;
  float r = reduced ? (a - 1.0) / (a + 1.0) : a;
  float r2 = r * r;
  float p = 1.0 / 17.0;
  p = p * r2 + -1.0 / 15.0;
  p = p * r2 + 1.0 / 13.0;
  p = p * r2 + -1.0 / 11.0;
  p = p * r2 + 1.0 / 9.0;
  p = p * r2 + -1.0 / 7.0;
  p = p * r2 + 1.0 / 5.0;
  p = p * r2 + -1.0 / 3.0;
  p = p * r2 + 1.0;
  float angle = (reduced ? 0.25 * IMPOSTOR_PI : 0.0) + r * p;
  if (ay > ax) angle = 0.5 * IMPOSTOR_PI - angle;
  if (x < 0.0) angle = IMPOSTOR_PI - angle;
  return y < 0.0 ? -angle : angle;
}

// Azimuth [0, 2 pi) and elevation (atan2 form, exact near the poles; the
// azimuth is 0 on the Y axis, where atan(0, 0) would be undefined).
vec2 impostorBlendAngles(vec3 d) {
  float horizontal = sqrt(d.x * d.x + d.z * d.z);
  float az = horizontal > 0.0 ? impostorAtan2(d.x, d.z) : 0.0;
  if (az < 0.0) az += IMPOSTOR_TWO_PI;
  if (az >= IMPOSTOR_TWO_PI) az = 0.0;
  return vec2(az, impostorAtan2(d.y, horizontal));
}

void impostorBlendAddIndex(ImpostorLayout atlas, int index, float weight, inout ImpostorBlend b) {
  if (weight <= 0.0) return;
  for (int i = 0; i < 4; ++i) {
    if (i < b.count && b.index[i] == index) {
      b.weight[i] += weight;
      return;
    }
  }
  b.frame[b.count] = impostorFrameTile(atlas, index);
  b.index[b.count] = index;
  b.weight[b.count] = weight;
  b.count += 1;
}

// The two frames of a ring of `count` bracketing azimuth `az`: x = c0,
// y = c1 = (c0 + 1) % count (exact small integers as floats), z = the
// fraction toward c1.
vec3 impostorAzimuthBracket(float az, int count) {
  float u = az * float(count) / IMPOSTOR_TWO_PI;
  int c0 = clamp(int(floor(u)), 0, count - 1);
  return vec3(float(c0), float((c0 + 1) % count), clamp(u - float(c0), 0.0, 1.0));
}

ImpostorBlend impostorBlendAzimuthElevation(ImpostorLayout atlas, vec3 d, int mode) {
  ImpostorBlend b = impostorEmptyBlend();
  int n = atlas.frames;
  vec2 ae = impostorBlendAngles(d);
  vec3 col = impostorAzimuthBracket(ae.x, n);
  int c0 = int(col.x), c1 = int(col.y);
  float v = (0.5 * IMPOSTOR_PI - ae.y) * float(n) / IMPOSTOR_PI - 0.5;
  int r0 = clamp(int(floor(v)), 0, n - 2);
  float fx = col.z;
  float fy = clamp(v - float(r0), 0.0, 1.0);
  // Pole caps: beyond the first / last row the pole's frame takes over.
  float top = clamp(-2.0 * v, 0.0, 1.0);
  float bottom = clamp(2.0 * (v - float(n - 1)), 0.0, 1.0);
  float cell = 1.0 - top - bottom;
  int i00 = r0 * n + c0, i10 = r0 * n + c1, i01 = (r0 + 1) * n + c0, i11 = (r0 + 1) * n + c1;
  if (mode == IMPOSTOR_BLEND_TRIANGLE3) {
    impostorBlendAddIndex(atlas, i00, cell * (1.0 - max(fx, fy)), b);
    if (fx > fy) impostorBlendAddIndex(atlas, i10, cell * (fx - fy), b);
    else impostorBlendAddIndex(atlas, i01, cell * (fy - fx), b);
    impostorBlendAddIndex(atlas, i11, cell * min(fx, fy), b);
  } else {
    impostorBlendAddIndex(atlas, i00, cell * (1.0 - fx) * (1.0 - fy), b);
    impostorBlendAddIndex(atlas, i10, cell * fx * (1.0 - fy), b);
    impostorBlendAddIndex(atlas, i01, cell * (1.0 - fx) * fy, b);
    impostorBlendAddIndex(atlas, i11, cell * fx * fy, b);
  }
  impostorBlendAddIndex(atlas, 0, top, b);
  impostorBlendAddIndex(atlas, (n - 1) * n, bottom, b);
  return b;
}

ImpostorBlend impostorBlendRingTop(ImpostorLayout atlas, int ring_views, vec3 d) {
  ImpostorBlend b = impostorEmptyBlend();
  vec2 ae = impostorBlendAngles(d);
  vec3 ring = impostorAzimuthBracket(ae.x, ring_views);
  float t = clamp(ae.y / (0.5 * IMPOSTOR_PI), 0.0, 1.0);
  impostorBlendAddIndex(atlas, int(ring.x), (1.0 - t) * (1.0 - ring.z), b);
  impostorBlendAddIndex(atlas, int(ring.y), (1.0 - t) * ring.z, b);
  impostorBlendAddIndex(atlas, ring_views, t, b);
  return b;
}

// The frames to blend for any layout (BlendFrames(const ViewLayout&, ...)).
ImpostorBlend impostorBlendFramesLayout(ImpostorLayout atlas, vec3 view_dir, int mode) {
  bool ring = impostorIsRing(atlas);
  if (!ring && atlas.kind != IMPOSTOR_LAYOUT_AZIMUTH_ELEVATION) {
    return impostorBlendFramesGrid(atlas.kind, atlas.frames, view_dir, mode);
  }
  int ring_views = impostorRingViews(atlas);
  if (ring ? ring_views < 1 : atlas.frames <= 1) {
    ImpostorBlend single = impostorEmptyBlend();
    single.count = 1;
    single.weight[0] = 1.0;
    return single;
  }
  float length2 = dot(view_dir, view_dir);
  if (!(length2 > 0.0) || isinf(length2) || isnan(length2)) view_dir = vec3(0.0, 1.0, 0.0);
  // if/else, not ?: : WebGL (the dashboard's viewer) forbids ?: on structs.
  ImpostorBlend b;
  if (ring) {
    b = impostorBlendRingTop(atlas, ring_views, view_dir);
  } else {
    b = impostorBlendAzimuthElevation(atlas, view_dir, mode);
  }
  impostorBlendNormalize(b);
  return b;
}

ImpostorLayout impostorLayoutFor(int layout_kind, int frames) {
  return ImpostorLayout(layout_kind, frames, layout_kind == IMPOSTOR_LAYOUT_BILLBOARD ? IMPOSTOR_BILLBOARD_RING_VIEWS : 0);
}

// The (layout_kind, frames) form: every layout but ring-top.
ImpostorBlend impostorBlendFrames(int layout_kind, int frames, vec3 view_dir, int mode) {
  return impostorBlendFramesLayout(impostorLayoutFor(layout_kind, frames), view_dir, mode);
}

// ---- bake cameras (common/atlas/frame_camera.cc) ----

vec3 impostorCameraUp(vec3 d) {
  const vec3 world_up = vec3(0.0, 1.0, 0.0);
  vec3 up = world_up - dot(world_up, d) * d;
  if (length(up) < 1.7e-4) return d.y > 0.0 ? vec3(0.0, 0.0, -1.0) : vec3(0.0, 0.0, 1.0);
  return normalize(up);
}

struct ImpostorFrameCamera {
  vec3 direction;  // centre -> camera
  vec3 up;         // toward tile row 0
  vec3 right;
};

ImpostorFrameCamera impostorCameraForDirection(vec3 direction) {
  ImpostorFrameCamera c;
  c.direction = normalize(direction);
  c.up = impostorCameraUp(c.direction);
  c.right = normalize(cross(c.up, c.direction));
  return c;
}

ImpostorFrameCamera impostorFrameCamera(int layout_kind, int frames, ivec2 frame) {
  return impostorCameraForDirection(impostorFrameDirection(layout_kind, frames, frame));
}

// The camera of frame `index` of any layout.
ImpostorFrameCamera impostorFrameCameraAt(ImpostorLayout atlas, int index) {
  return impostorCameraForDirection(impostorFrameDirectionAt(atlas, index));
}

// ---- virtual planes (common/runtime/virtual_plane.cc) ----

// xy = frame coordinates (s, t) in [-1, 1] over the tile, z = 1 if valid.
vec3 impostorIntersectFramePlane(ImpostorFrameCamera frame, vec3 origin, vec3 ray, float height) {
  float len = length(ray);
  if (!(len > 0.0)) return vec3(0.0);
  vec3 toward_eye = -ray / len;
  float facing = dot(toward_eye, frame.direction);
  if (!(facing >= 1e-4)) return vec3(0.0);
  float k = (dot(origin, frame.direction) - height) / facing;
  vec3 q = origin - k * toward_eye;
  return vec3(dot(q, frame.right), dot(q, frame.up), 1.0);
}

// ---- tile sampling (common/runtime/reference_renderer.cc) ----

struct ImpostorSample {
  float alpha;    // bilinear coverage
  vec3 albedo;    // linear, alpha-weighted mean of covered texels
  vec3 normal;    // [-1, 1], not renormalised
  float depth;    // the frame's depth 0..1
  vec3 orm;
};

// Bilinear over the 2x2 texel centres around st, clamped to the tile
// (tile = x, y, width, height in pixels); empty outside the tile's square.
ImpostorSample impostorSampleTile(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex,
                                  bool has_orm, ivec4 tile, vec2 st) {
  ImpostorSample o;
  o.alpha = 0.0;
  o.albedo = vec3(0.0);
  o.normal = vec3(0.0);
  o.depth = 1.0;
  o.orm = vec3(0.0);
  if (!(abs(st.x) <= 1.0 && abs(st.y) <= 1.0)) return o;
  vec2 pixel = vec2(float(tile.x) + (st.x + 1.0) * 0.5 * float(tile.z),
                    float(tile.y) + (1.0 - st.y) * 0.5 * float(tile.w));
  float fx = pixel.x - float(tile.x) - 0.5;
  float fy = pixel.y - float(tile.y) - 0.5;
  float flx = floor(fx);
  float fly = floor(fy);
  int ix = int(flx);
  int iy = int(fly);
  float ax = fx - flx;
  float ay = fy - fly;
  float bilinear[4] = float[4]((1.0 - ax) * (1.0 - ay), ax * (1.0 - ay), (1.0 - ax) * ay, ax * ay);
  float covered = 0.0;
  float depth = 0.0;
  for (int k = 0; k < 4; ++k) {
    if (bilinear[k] <= 0.0) continue;
    ivec2 texel = ivec2(tile.x + clamp(ix + (k & 1), 0, tile.z - 1), tile.y + clamp(iy + (k >> 1), 0, tile.w - 1));
    vec4 c = texelFetch(albedo_tex, texel, 0);
    float w = bilinear[k] * c.a;
    if (w <= 0.0) continue;
    covered += w;
    vec4 nd = texelFetch(normal_depth_tex, texel, 0);
    depth += w * nd.a;
    o.normal += w * (nd.rgb * 2.0 - 1.0);
    o.albedo += w * c.rgb;
    if (has_orm) o.orm += w * texelFetch(orm_tex, texel, 0).rgb;
  }
  o.alpha = covered;
  if (covered > 0.0) {
    o.depth = depth / covered;
    o.normal /= covered;
    o.albedo /= covered;
    o.orm /= covered;
  }
  return o;
}

// Parallax: marches the ray through the frame's depth (see virtual_plane.h);
// depth mode samples silhouette crossings finer (refine_crossings).
// Returns the sample point (xy), validity (z) and the point's height along
// the frame direction (w, radius units).
vec4 impostorMarchFrameHeightField(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex,
                                   ivec4 tile, ImpostorFrameCamera frame, vec3 origin, vec3 ray,
                                   bool refine_crossings) {
  float above = 1.0;
  bool was_covered = false;
  for (int i = 0; i <= IMPOSTOR_PARALLAX_STEPS; ++i) {
    float h = 1.0 - 2.0 * float(i) / float(IMPOSTOR_PARALLAX_STEPS);
    vec3 hit = impostorIntersectFramePlane(frame, origin, ray, h);
    if (hit.z == 0.0) return vec4(hit, 0.0);
    ImpostorSample s = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, false, tile, hit.xy);
    bool covered = s.alpha >= 0.5;
    bool is_below = covered && h <= 1.0 - 2.0 * s.depth;
    if (refine_crossings && !is_below && i > 0 && covered != was_covered) {
      // A silhouette crossing since the last step: sampled finer there, a
      // grazing ray's sliver of the solid can be thinner than a step.
      float top = above;
      for (int k = 1; k < IMPOSTOR_PARALLAX_CROSSING_STEPS; ++k) {
        float hk = top - (top - h) * float(k) / float(IMPOSTOR_PARALLAX_CROSSING_STEPS);
        vec3 at = impostorIntersectFramePlane(frame, origin, ray, hk);
        ImpostorSample m = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, false, tile, at.xy);
        if (at.z != 0.0 && m.alpha >= 0.5 && hk <= 1.0 - 2.0 * m.depth) {
          hit = at;
          h = hk;
          is_below = true;
          break;
        }
        above = hk;
      }
    }
    was_covered = covered;
    if (!is_below) {
      above = h;
      continue;
    }
    float below = h;
    for (int j = 0; j < IMPOSTOR_PARALLAX_REFINEMENTS && i > 0; ++j) {
      float mid = 0.5 * (above + below);
      vec3 at = impostorIntersectFramePlane(frame, origin, ray, mid);
      ImpostorSample m = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, false, tile, at.xy);
      if (at.z != 0.0 && m.alpha >= 0.5 && mid <= 1.0 - 2.0 * m.depth) {
        below = mid;
        hit = at;
      } else {
        above = mid;
      }
    }
    return vec4(hit, below);
  }
  return vec4(0.0);
}

// The same, point and validity only.
vec3 impostorIntersectFrameHeightField(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex,
                                       ivec4 tile, ImpostorFrameCamera frame, vec3 origin, vec3 ray) {
  return impostorMarchFrameHeightField(albedo_tex, normal_depth_tex, orm_tex, tile, frame, origin, ray, false).xyz;
}

// Depth mode's agreement weight (DepthAgreement): 1 while the frame's surface
// height at the point is within half the tolerance of the point's own
// height, 0 beyond the tolerance (the frame did not see the point).
float impostorDepthAgreement(float surface_height, float point_height) {
  float diff = abs(surface_height - point_height);
  return clamp((IMPOSTOR_DEPTH_AGREEMENT - diff) / (0.5 * IMPOSTOR_DEPTH_AGREEMENT), 0.0, 1.0);
}

// ---- the blended surface (RenderImpostorView, per pixel) ----

struct ImpostorSurface {
  float alpha;    // blended coverage; covered iff >= 0.5
  vec3 albedo;    // linear (write to an sRGB target to encode)
  vec3 normal;    // object space, unit (zero where empty)
  vec3 position;  // blended surface point, radius units from the centre
  vec3 orm;
  vec4 weights;   // per blend entry: its share of the shading (sums to 1 where covered)
};

// Running sums of one pixel's blend (PixelBlend in the C++).
struct ImpostorAccum {
  float alpha;    // coverage, sum of weight * alpha
  float covered;  // sum of the shading weights
  vec3 albedo, normal, orm, position;
  vec4 weights;
};

ImpostorAccum impostorEmptyAccum() {
  return ImpostorAccum(0.0, 0.0, vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0), vec4(0.0));
}

void impostorAccumAdd(inout ImpostorAccum a, int entry, float w, ImpostorSample s, ImpostorFrameCamera frame,
                      vec2 st) {
  if (w <= 0.0) return;
  a.covered += w;
  a.albedo += w * s.albedo;
  a.normal += w * s.normal;
  a.orm += w * s.orm;
  a.position += w * (st.x * frame.right + st.y * frame.up + (1.0 - 2.0 * s.depth) * frame.direction);
  a.weights[entry] += w;
}

ImpostorSurface impostorAccumSurface(ImpostorAccum a) {
  ImpostorSurface out_surface;
  out_surface.alpha = a.alpha;
  float inv = a.covered > 0.0 ? 1.0 / a.covered : 0.0;
  out_surface.albedo = a.albedo * inv;
  out_surface.orm = a.orm * inv;
  out_surface.position = a.position * inv;
  out_surface.weights = a.weights * inv;
  float len = length(a.normal);
  out_surface.normal = len > 1e-12 ? a.normal / len : vec3(0.0);
  return out_surface;
}

ImpostorFrameCamera impostorBlendCamera(ImpostorLayout atlas, ImpostorBlend blend, int i) {
  return impostorFrameCameraAt(atlas, blend.index[i]);
}

// How far a march hit deep in its frame's extrusion counts, 0..1
// (ExtrusionConfirmation of OthersInsideShare): by the share of the other
// blended frames' weight that sees `point` inside their silhouettes.
float impostorExtrusionConfirmation(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex,
                                    ImpostorLayout atlas, int tile_size, ImpostorBlend blend, int own, vec3 point) {
  float others = 0.0;
  float inside = 0.0;
  for (int j = 0; j < min(blend.count, 4); ++j) {
    if (j == own || !(blend.weight[j] > 0.0)) continue;
    ImpostorFrameCamera frame = impostorBlendCamera(atlas, blend, j);
    ivec4 tile = ivec4(blend.frame[j] * tile_size, tile_size, tile_size);
    ImpostorSample s = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, false, tile,
                                          vec2(dot(point, frame.right), dot(point, frame.up)));
    others += blend.weight[j];
    inside += blend.weight[j] * s.alpha;
  }
  float share = others > 0.0 ? inside / others : 1.0;
  return clamp((share - (IMPOSTOR_EXTRUSION_CONFIRM - IMPOSTOR_EXTRUSION_CONFIRM_RAMP)) / IMPOSTOR_EXTRUSION_CONFIRM_RAMP,
               0.0, 1.0);
}

// Depth mode (common/runtime/depth_reconstruction.h, ReconstructDepth):
// every frame's march hit is a candidate surface point on the ray; each
// blended frame votes for a candidate by weight * coverage * agreement; the
// deepest candidate with at least half the best support is the common point
// P, which every frame samples, weighted by its vote (0 where it did not see
// P). The returned weights say which frames shaded the pixel.
ImpostorSurface impostorShadeDepthLayout(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex,
                                         bool has_orm, ImpostorLayout atlas, int tile_size, ImpostorBlend blend,
                                         vec3 ray_origin, vec3 ray_dir) {
  ImpostorAccum acc = impostorEmptyAccum();
  vec3 ray_unit = normalize(ray_dir);
  vec4 hits[4] = vec4[4](vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));
  float hit_alpha[4] = float[4](0.0, 0.0, 0.0, 0.0);
  float lambda[4] = float[4](0.0, 0.0, 0.0, 0.0);
  int n = min(blend.count, 4);
  for (int i = 0; i < n; ++i) {
    if (!(blend.weight[i] > 0.0)) continue;
    ImpostorFrameCamera frame = impostorBlendCamera(atlas, blend, i);
    ivec4 tile = ivec4(blend.frame[i] * tile_size, tile_size, tile_size);
    vec4 hit = impostorMarchFrameHeightField(albedo_tex, normal_depth_tex, orm_tex, tile, frame, ray_origin,
                                             ray_dir, true);
    if (hit.z == 0.0) continue;
    ImpostorSample s = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, false, tile, hit.xy);
    if (!(s.alpha > 0.0)) continue;
    float confirmed = 1.0;
    if ((1.0 - 2.0 * s.depth) - hit.w > IMPOSTOR_EXTRUSION_DEPTH) {
      confirmed = impostorExtrusionConfirmation(albedo_tex, normal_depth_tex, orm_tex, atlas, tile_size, blend, i,
                                                hit.x * frame.right + hit.y * frame.up + hit.w * frame.direction);
    }
    if (!(confirmed > 0.0)) continue;
    hits[i] = hit;
    hit_alpha[i] = s.alpha;
    acc.alpha += blend.weight[i] * s.alpha * confirmed;
    lambda[i] = dot(hit.x * frame.right + hit.y * frame.up + hit.w * frame.direction - ray_origin, ray_unit);
  }
  if (acc.alpha < 0.5) return impostorAccumSurface(acc);
  // Votes of every frame j for every candidate c.
  float support[4] = float[4](0.0, 0.0, 0.0, 0.0);
  float most = 0.0;
  for (int c = 0; c < n; ++c) {
    if (hits[c].z == 0.0) continue;
    ImpostorFrameCamera fc = impostorBlendCamera(atlas, blend, c);
    vec3 point = hits[c].x * fc.right + hits[c].y * fc.up + hits[c].w * fc.direction;
    for (int j = 0; j < n; ++j) {
      if (!(blend.weight[j] > 0.0)) continue;
      ImpostorFrameCamera frame = impostorBlendCamera(atlas, blend, j);
      ivec4 tile = ivec4(blend.frame[j] * tile_size, tile_size, tile_size);
      vec2 st = j == c ? hits[c].xy : vec2(dot(point, frame.right), dot(point, frame.up));
      float height = j == c ? hits[c].w : dot(point, frame.direction);
      ImpostorSample s = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, false, tile, st);
      if (!(s.alpha > 0.0)) continue;
      support[c] += blend.weight[j] * s.alpha * impostorDepthAgreement(1.0 - 2.0 * s.depth, height);
    }
    most = max(most, support[c]);
  }
  int best = -1;
  for (int c = 0; c < n; ++c) {
    if (hits[c].z == 0.0 || !(support[c] >= 0.5 * most)) continue;
    if (best < 0 || lambda[best] < lambda[c]) best = c;
  }
  if (best >= 0 && support[best] > 0.0) {
    ImpostorFrameCamera fb = impostorBlendCamera(atlas, blend, best);
    vec3 point = hits[best].x * fb.right + hits[best].y * fb.up + hits[best].w * fb.direction;
    for (int j = 0; j < n; ++j) {
      if (!(blend.weight[j] > 0.0)) continue;
      ImpostorFrameCamera frame = impostorBlendCamera(atlas, blend, j);
      ivec4 tile = ivec4(blend.frame[j] * tile_size, tile_size, tile_size);
      vec2 st = j == best ? hits[best].xy : vec2(dot(point, frame.right), dot(point, frame.up));
      float height = j == best ? hits[best].w : dot(point, frame.direction);
      ImpostorSample s = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, has_orm, tile, st);
      if (!(s.alpha > 0.0)) continue;
      float g = impostorDepthAgreement(1.0 - 2.0 * s.depth, height);
      impostorAccumAdd(acc, j, blend.weight[j] * s.alpha * g, s, frame, st);
    }
    return impostorAccumSurface(acc);
  }
  // No frame saw any candidate: each frame at its own hit (parallax).
  for (int j = 0; j < n; ++j) {
    if (hits[j].z == 0.0) continue;
    ImpostorFrameCamera frame = impostorBlendCamera(atlas, blend, j);
    ivec4 tile = ivec4(blend.frame[j] * tile_size, tile_size, tile_size);
    ImpostorSample s = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, has_orm, tile, hits[j].xy);
    impostorAccumAdd(acc, j, blend.weight[j] * hit_alpha[j], s, frame, hits[j].xy);
  }
  return impostorAccumSurface(acc);
}

// Any mode: IMPOSTOR_RECONSTRUCT_PLAIN, _PARALLAX or _DEPTH. The returned
// surface carries coverage (alpha), the shaded values, the surface point
// (position; impostorViewDepth gives its depth) and each blend entry's
// share of the shading (weights), e.g. for a pixel depth offset.
ImpostorSurface impostorReconstructLayout(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex,
                                          bool has_orm, ImpostorLayout atlas, int tile_size, ImpostorBlend blend,
                                          vec3 ray_origin, vec3 ray_dir, int mode) {
  if (mode == IMPOSTOR_RECONSTRUCT_DEPTH) {
    return impostorShadeDepthLayout(albedo_tex, normal_depth_tex, orm_tex, has_orm, atlas, tile_size, blend,
                                    ray_origin, ray_dir);
  }
  ImpostorAccum acc = impostorEmptyAccum();
  for (int i = 0; i < 4; ++i) {
    if (i >= blend.count) break;
    ImpostorFrameCamera frame = impostorBlendCamera(atlas, blend, i);
    ivec4 tile = ivec4(blend.frame[i] * tile_size, tile_size, tile_size);
    vec3 plane = mode == IMPOSTOR_RECONSTRUCT_PARALLAX
                     ? impostorIntersectFrameHeightField(albedo_tex, normal_depth_tex, orm_tex, tile, frame,
                                                         ray_origin, ray_dir)
                     : impostorIntersectFramePlane(frame, ray_origin, ray_dir, 0.0);
    if (plane.z == 0.0) continue;
    ImpostorSample s = impostorSampleTile(albedo_tex, normal_depth_tex, orm_tex, has_orm, tile, plane.xy);
    float w = blend.weight[i] * s.alpha;
    acc.alpha += w;
    impostorAccumAdd(acc, i, w, s, frame, plane.xy);
  }
  return impostorAccumSurface(acc);
}

ImpostorSurface impostorShadeLayout(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex,
                                    bool has_orm, ImpostorLayout atlas, int tile_size, ImpostorBlend blend,
                                    vec3 ray_origin, vec3 ray_dir, bool parallax) {
  return impostorReconstructLayout(albedo_tex, normal_depth_tex, orm_tex, has_orm, atlas, tile_size, blend,
                                   ray_origin, ray_dir,
                                   parallax ? IMPOSTOR_RECONSTRUCT_PARALLAX : IMPOSTOR_RECONSTRUCT_PLAIN);
}

// The (layout_kind, frames) form: every layout but ring-top.
ImpostorSurface impostorShade(sampler2D albedo_tex, sampler2D normal_depth_tex, sampler2D orm_tex, bool has_orm,
                              int layout_kind, int frames, int tile_size, ImpostorBlend blend, vec3 ray_origin,
                              vec3 ray_dir, bool parallax) {
  return impostorShadeLayout(albedo_tex, normal_depth_tex, orm_tex, has_orm, impostorLayoutFor(layout_kind, frames),
                             tile_size, blend, ray_origin, ray_dir, parallax);
}

// Depth of a surface point for an orthographic camera framed like a bake
// camera (frame_camera.h): 0 at the near side of the sphere, 1 at the far.
float impostorViewDepth(vec3 position, vec3 view_dir) { return (1.0 - dot(position, view_dir)) * 0.5; }

#endif  // IMPOSTOR_RUNTIME_GLSL
