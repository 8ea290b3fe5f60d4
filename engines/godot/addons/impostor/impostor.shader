// The reference impostor material for Godot 3.2 (GLES3): a port of
// shaders/impostor_runtime.glsl (frame blend of every layout, bake cameras,
// virtual planes, tile sampling, the plain / parallax / depth-aware
// reconstructions) and shaders/impostor_material.glsl (world normal, the
// surface point and its pixel depth offset, the shadow caster), drawn on a
// camera-facing card as shaders/impostor_runtime_check.vert draws it.
//
// The math is the reference's, line for line. What Godot 3's shading
// language forced to change is the form only:
//   - no structs and no array parameters: ImpostorBlend is (count, index
//     ivec4, weight vec4) and a frame's tile is impostorFrameTile(index) (the
//     reference keeps the canonical tile beside the index; the two agree on
//     every layout); ImpostorFrameCamera is a mat3 (columns: direction, up,
//     right); ImpostorSample, ImpostorAccum and ImpostorSurface are out /
//     inout parameters; an ImpostorLayout is an ivec3 (kind, frames,
//     ring_views);
//   - no int varyings: the vertex stage's blend reaches the fragment stage
//     as flat floats;
//   - texels are read one by one as the reference's texelFetch reads them
//     (no filtering, no mips), but through textureLod at the texel's centre
//     (impostorTexel): Godot 3 stores RGBA8 textures in an sRGB format and
//     turns decoding off through sampler state, which texelFetch bypasses
//     on some drivers (Mesa decodes every texel). albedo_alpha's RGB is
//     decoded from sRGB per texel here, as the reference's sRGB-format
//     fetch does, so no engine texture flag can change the colours;
//     normal_depth arrives with 8 bits per channel (Godot 3's PNG loader
//     strips 16-bit PNGs to their high byte): depth steps of 2/255 radius,
//     well inside the depth mode's 0.05 radius agreement.
//
// Spaces: object space is the manifest's (the glTF scene's, +Y up), which
// is Godot's (+Y up, right-handed): no axis change. MODELVIEW_MATRIX (which
// includes a MultiMesh instance's transform) places it and must be a
// similarity. Rays live in "sphere space": (p - centre) / radius.
// In the shadow pass Godot draws with the light's camera, so the card faces
// the light and, for a directional light (orthographic), the rays run
// parallel along it: impostorShadowCaster of impostor_material.glsl.
// The render_mode line is the addon's to edit: impostor_materials.gd makes
// the unshaded variant from it.
shader_type spatial;
render_mode skip_vertex_transform, cull_disabled;

uniform sampler2D impostor_albedo;        // albedo_alpha: sRGB RGB, A = coverage
uniform sampler2D impostor_normal_depth;  // normal * 0.5 + 0.5, A = depth 0 nearest .. 1 farthest
uniform sampler2D impostor_orm;           // occlusion, roughness, metalness (when has_orm)
uniform vec4 impostor_sphere = vec4(0.0, 0.0, 0.0, 1.0);  // object space: centre xyz, radius w
uniform ivec4 impostor_layout;  // kind, frames, ring_views, tile_size
uniform ivec4 impostor_mode;    // blend, reconstruction, has_orm, unused
uniform bool impostor_depth_offset = true;  // DEPTH = the reconstructed surface point's
// Cross-fade at the LOD switch (shaders/impostor_crossfade.glsl): 0 off (the
// default), 1 from impostor_fade / impostor_fade_offset (one node), 2 per
// MultiMesh instance from INSTANCE_CUSTOM.r (t) and .g (offset). The offset
// is the seed's, 0..15, worked out by impostor_forest.gd's
// cross_fade_offset(seed) (Godot 3's shading language has no uint).
uniform int impostor_cross_fade = 0;
uniform float impostor_fade = 1.0;     // t: 0 the mesh only, 1 the impostor only
uniform float impostor_fade_offset = 0.0;

varying vec3 v_ray_origin;  // sphere space
varying vec3 v_ray_dir;
varying flat vec4 v_frames;   // blend entries' frame indices
varying flat vec4 v_weights;  // their weights (0 past the count)
varying flat float v_count;
varying flat mat4 v_object_to_view;
varying vec3 v_card_view;  // the card's view-space point as this stage left it
varying flat vec2 v_fade;  // cross-fade t, offset

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
const int IMPOSTOR_PARALLAX_STEPS = 16;
const int IMPOSTOR_PARALLAX_REFINEMENTS = 4;
const int IMPOSTOR_PARALLAX_CROSSING_STEPS = 4;
const int IMPOSTOR_RECONSTRUCT_PLAIN = 0;
const int IMPOSTOR_RECONSTRUCT_PARALLAX = 1;
const int IMPOSTOR_RECONSTRUCT_DEPTH = 2;
const float IMPOSTOR_DEPTH_AGREEMENT = 0.05;
const float IMPOSTOR_EXTRUSION_DEPTH = 0.1;  // 2 * IMPOSTOR_DEPTH_AGREEMENT
const float IMPOSTOR_EXTRUSION_CONFIRM = 0.75;
const float IMPOSTOR_EXTRUSION_CONFIRM_RAMP = 0.25;

// Godot 3.2 indexes vectors by constants only (local arrays by any int):
// a blend's vec4 / ivec4 entries are read and written through these.
float impostorGet(vec4 v, int i) { return i == 0 ? v.x : (i == 1 ? v.y : (i == 2 ? v.z : v.w)); }
int impostorGetInt(ivec4 v, int i) { return i == 0 ? v.x : (i == 1 ? v.y : (i == 2 ? v.z : v.w)); }

vec4 impostorSet(vec4 v, int i, float x) {
  vec4 r = v;
  if (i == 0) {
    r.x = x;
  } else if (i == 1) {
    r.y = x;
  } else if (i == 2) {
    r.z = x;
  } else {
    r.w = x;
  }
  return r;
}

ivec4 impostorSetInt(ivec4 v, int i, int x) {
  ivec4 r = v;
  if (i == 0) {
    r.x = x;
  } else if (i == 1) {
    r.y = x;
  } else if (i == 2) {
    r.z = x;
  } else {
    r.w = x;
  }
  return r;
}

// ---- direction <-> layout square (common/atlas_layout.cc) ----

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

vec3 impostorLayoutToDirection(int kind, vec2 oct) {
  return kind == IMPOSTOR_LAYOUT_OCTAHEDRAL ? impostorOctahedralToDirection(oct)
                                            : impostorHemiOctahedralToDirection(oct);
}

vec2 impostorDirectionToLayout(int kind, vec3 d) {
  return kind == IMPOSTOR_LAYOUT_OCTAHEDRAL ? impostorDirectionToOctahedral(d)
                                            : impostorDirectionToHemiOctahedral(d);
}

vec2 impostorDirectionToGrid(int kind, int frames, vec3 d) {
  vec2 oct = impostorDirectionToLayout(kind, d);
  float scale = float(frames - 1);
  return clamp((oct * 0.5 + 0.5) * scale, vec2(0.0), vec2(scale));
}

vec3 impostorFrameDirection(int kind, int frames, ivec2 frame) {
  float inv = frames > 1 ? 1.0 / float(frames - 1) : 0.0;
  vec2 uv = vec2(float(frame.x) * inv, float(frame.y) * inv);
  return impostorLayoutToDirection(kind, uv * 2.0 - 1.0);
}

int impostorFrameIndex(int frames, ivec2 f) { return f.y * frames + f.x; }

// The lowest-numbered frame showing the same view (the octahedron's fold).
ivec2 impostorCanonicalFrame(int kind, int frames, ivec2 frame) {
  if (kind != IMPOSTOR_LAYOUT_OCTAHEDRAL || frames < 2) return frame;
  int last = frames - 1;
  bool on_border = frame.x == 0 || frame.y == 0 || frame.x == last || frame.y == last;
  if (!on_border) return frame;
  bool corner = (frame.x == 0 || frame.x == last) && (frame.y == 0 || frame.y == last);
  if (corner) return ivec2(0, 0);
  ivec2 mirror = frame;
  if (frame.x == 0 || frame.x == last) {
    mirror.y = last - frame.y;
  } else {
    mirror.x = last - frame.x;
  }
  return impostorFrameIndex(frames, mirror) < impostorFrameIndex(frames, frame) ? mirror : frame;
}

// ---- frame blend (common/runtime/frame_blend.cc) ----
// A blend: `count` entries (1..4), frame `index` and `weight` of each.

void impostorBlendAdd(int kind, int frames, ivec2 frame, float w, inout int count, inout ivec4 index,
                      inout vec4 weight) {
  if (w <= 0.0) return;
  int canonical = impostorFrameIndex(frames, impostorCanonicalFrame(kind, frames, frame));
  for (int i = 0; i < 4; ++i) {
    if (i < count && impostorGetInt(index, i) == canonical) {
      weight = impostorSet(weight, i, impostorGet(weight, i) + w);
      return;
    }
  }
  index = impostorSetInt(index, count, canonical);
  weight = impostorSet(weight, count, w);
  count += 1;
}

void impostorBlendNormalize(int count, inout vec4 weight) {
  float total = 0.0;
  for (int i = 0; i < 4; ++i) {
    if (i < count) total += impostorGet(weight, i);
  }
  for (int i = 0; i < 4; ++i) {
    if (i < count) weight = impostorSet(weight, i, impostorGet(weight, i) / total);
  }
}

void impostorBlendFramesGrid(int kind, int frames, vec3 view_dir, int mode, out int count, out ivec4 index,
                             out vec4 weight) {
  count = 0;
  index = ivec4(0);
  weight = vec4(0.0);
  if (frames <= 1) {
    count = 1;
    weight.x = 1.0;
    return;
  }
  // A zero or non-finite direction is taken as straight up (as in the C++).
  float length2 = dot(view_dir, view_dir);
  if (!(length2 > 0.0) || isinf(length2) || isnan(length2)) view_dir = vec3(0.0, 1.0, 0.0);
  vec2 grid = impostorDirectionToGrid(kind, frames, view_dir);
  // The last grid line belongs to the last quad (fx, fy reach 1 there).
  int x0 = clamp(int(floor(grid.x)), 0, frames - 2);
  int y0 = clamp(int(floor(grid.y)), 0, frames - 2);
  float fx = clamp(grid.x - float(x0), 0.0, 1.0);
  float fy = clamp(grid.y - float(y0), 0.0, 1.0);
  ivec2 c0 = ivec2(x0, y0);
  if (mode == IMPOSTOR_BLEND_TRIANGLE3) {
    // Brucks: A = 1 - max on the current frame, B = |fx - fy| on the right
    // (fx > fy) or lower frame, C = min on the lower-right frame.
    impostorBlendAdd(kind, frames, c0, 1.0 - max(fx, fy), count, index, weight);
    if (fx > fy) {
      impostorBlendAdd(kind, frames, c0 + ivec2(1, 0), fx - fy, count, index, weight);
    } else {
      impostorBlendAdd(kind, frames, c0 + ivec2(0, 1), fy - fx, count, index, weight);
    }
    impostorBlendAdd(kind, frames, c0 + ivec2(1, 1), min(fx, fy), count, index, weight);
  } else {
    impostorBlendAdd(kind, frames, c0, (1.0 - fx) * (1.0 - fy), count, index, weight);
    impostorBlendAdd(kind, frames, c0 + ivec2(1, 0), fx * (1.0 - fy), count, index, weight);
    impostorBlendAdd(kind, frames, c0 + ivec2(0, 1), (1.0 - fx) * fy, count, index, weight);
    impostorBlendAdd(kind, frames, c0 + ivec2(1, 1), fx * fy, count, index, weight);
  }
  impostorBlendNormalize(count, weight);
}

// ---- every layout by frame index (common/atlas_layout.cc) ----
// atlas = (kind, frames, ring_views).

bool impostorIsRing(ivec3 atlas) {
  return atlas.x == IMPOSTOR_LAYOUT_RING_TOP || atlas.x == IMPOSTOR_LAYOUT_BILLBOARD;
}

int impostorRingViews(ivec3 atlas) {
  return atlas.x == IMPOSTOR_LAYOUT_BILLBOARD ? IMPOSTOR_BILLBOARD_RING_VIEWS : atlas.z;
}

// Tiles per atlas side (GridSide).
int impostorGridSide(ivec3 atlas) {
  if (!impostorIsRing(atlas)) return atlas.y;
  int count = impostorRingViews(atlas) + 1;
  int side = 1;
  for (int i = 0; i < 64; ++i) {
    if (side * side >= count) break;
    side += 1;
  }
  return side;
}

// Tile (col, row) of frame `index` (FrameTile).
ivec2 impostorFrameTile(ivec3 atlas, int index) {
  int side = impostorGridSide(atlas);
  return ivec2(index % side, index / side);
}

vec3 impostorAzimuthElevationToDirection(float az, float el) {
  return vec3(sin(az) * cos(el), sin(el), cos(az) * cos(el));
}

// Direction of frame `index` (FrameDirectionAt).
vec3 impostorFrameDirectionAt(ivec3 atlas, int index) {
  if (atlas.x == IMPOSTOR_LAYOUT_AZIMUTH_ELEVATION) {
    int n = atlas.y;
    float az = float(index % n) * IMPOSTOR_TWO_PI / float(n);
    float el = 0.5 * IMPOSTOR_PI - (float(index / n) + 0.5) * IMPOSTOR_PI / float(n);
    return impostorAzimuthElevationToDirection(az, el);
  }
  if (impostorIsRing(atlas)) {
    int k = impostorRingViews(atlas);
    if (index >= k) return vec3(0.0, 1.0, 0.0);
    return impostorAzimuthElevationToDirection(float(index) * IMPOSTOR_TWO_PI / float(k), 0.0);
  }
  return impostorFrameDirection(atlas.x, atlas.y, ivec2(index % atlas.y, index / atlas.y));
}

// ---- frame blend of the other layouts (frame_blend.cc) ----

// atan2 in plain arithmetic, as frame_blend.cc's Atan2 (the built-in may
// differ between drivers by more than the weights may).
float impostorAtan2(float y, float x) {
  float ax = abs(x);
  float ay = abs(y);
  float hi = max(ax, ay);
  float lo = min(ax, ay);
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

// Azimuth [0, 2 pi) and elevation.
vec2 impostorBlendAngles(vec3 d) {
  float horizontal = sqrt(d.x * d.x + d.z * d.z);
  float az = horizontal > 0.0 ? impostorAtan2(d.x, d.z) : 0.0;
  if (az < 0.0) az += IMPOSTOR_TWO_PI;
  if (az >= IMPOSTOR_TWO_PI) az = 0.0;
  return vec2(az, impostorAtan2(d.y, horizontal));
}

void impostorBlendAddIndex(int frame_index, float w, inout int count, inout ivec4 index, inout vec4 weight) {
  if (w <= 0.0) return;
  for (int i = 0; i < 4; ++i) {
    if (i < count && impostorGetInt(index, i) == frame_index) {
      weight = impostorSet(weight, i, impostorGet(weight, i) + w);
      return;
    }
  }
  index = impostorSetInt(index, count, frame_index);
  weight = impostorSet(weight, count, w);
  count += 1;
}

// The two frames of a ring of `count` bracketing azimuth `az`: x = c0,
// y = (c0 + 1) % count, z = the fraction toward y.
vec3 impostorAzimuthBracket(float az, int ring_count) {
  float u = az * float(ring_count) / IMPOSTOR_TWO_PI;
  int c0 = clamp(int(floor(u)), 0, ring_count - 1);
  return vec3(float(c0), float((c0 + 1) % ring_count), clamp(u - float(c0), 0.0, 1.0));
}

void impostorBlendAzimuthElevation(ivec3 atlas, vec3 d, int mode, inout int count, inout ivec4 index,
                                   inout vec4 weight) {
  int n = atlas.y;
  vec2 ae = impostorBlendAngles(d);
  vec3 col = impostorAzimuthBracket(ae.x, n);
  int c0 = int(col.x);
  int c1 = int(col.y);
  float v = (0.5 * IMPOSTOR_PI - ae.y) * float(n) / IMPOSTOR_PI - 0.5;
  int r0 = clamp(int(floor(v)), 0, n - 2);
  float fx = col.z;
  float fy = clamp(v - float(r0), 0.0, 1.0);
  // Pole caps: beyond the first / last row the pole's frame takes over.
  float top = clamp(-2.0 * v, 0.0, 1.0);
  float bottom = clamp(2.0 * (v - float(n - 1)), 0.0, 1.0);
  float cell = 1.0 - top - bottom;
  int i00 = r0 * n + c0;
  int i10 = r0 * n + c1;
  int i01 = (r0 + 1) * n + c0;
  int i11 = (r0 + 1) * n + c1;
  if (mode == IMPOSTOR_BLEND_TRIANGLE3) {
    impostorBlendAddIndex(i00, cell * (1.0 - max(fx, fy)), count, index, weight);
    if (fx > fy) {
      impostorBlendAddIndex(i10, cell * (fx - fy), count, index, weight);
    } else {
      impostorBlendAddIndex(i01, cell * (fy - fx), count, index, weight);
    }
    impostorBlendAddIndex(i11, cell * min(fx, fy), count, index, weight);
  } else {
    impostorBlendAddIndex(i00, cell * (1.0 - fx) * (1.0 - fy), count, index, weight);
    impostorBlendAddIndex(i10, cell * fx * (1.0 - fy), count, index, weight);
    impostorBlendAddIndex(i01, cell * (1.0 - fx) * fy, count, index, weight);
    impostorBlendAddIndex(i11, cell * fx * fy, count, index, weight);
  }
  impostorBlendAddIndex(0, top, count, index, weight);
  impostorBlendAddIndex((n - 1) * n, bottom, count, index, weight);
}

void impostorBlendRingTop(int ring_views, vec3 d, inout int count, inout ivec4 index, inout vec4 weight) {
  vec2 ae = impostorBlendAngles(d);
  vec3 ring = impostorAzimuthBracket(ae.x, ring_views);
  float t = clamp(ae.y / (0.5 * IMPOSTOR_PI), 0.0, 1.0);
  impostorBlendAddIndex(int(ring.x), (1.0 - t) * (1.0 - ring.z), count, index, weight);
  impostorBlendAddIndex(int(ring.y), (1.0 - t) * ring.z, count, index, weight);
  impostorBlendAddIndex(ring_views, t, count, index, weight);
}

// The frames to blend for any layout (BlendFrames(const ViewLayout&, ...)).
void impostorBlendFramesLayout(ivec3 atlas, vec3 view_dir, int mode, out int count, out ivec4 index,
                               out vec4 weight) {
  bool ring = impostorIsRing(atlas);
  if (!ring && atlas.x != IMPOSTOR_LAYOUT_AZIMUTH_ELEVATION) {
    impostorBlendFramesGrid(atlas.x, atlas.y, view_dir, mode, count, index, weight);
    return;
  }
  count = 0;
  index = ivec4(0);
  weight = vec4(0.0);
  int ring_views = impostorRingViews(atlas);
  if (ring ? ring_views < 1 : atlas.y <= 1) {
    count = 1;
    weight.x = 1.0;
    return;
  }
  float length2 = dot(view_dir, view_dir);
  if (!(length2 > 0.0) || isinf(length2) || isnan(length2)) view_dir = vec3(0.0, 1.0, 0.0);
  if (ring) {
    impostorBlendRingTop(ring_views, view_dir, count, index, weight);
  } else {
    impostorBlendAzimuthElevation(atlas, view_dir, mode, count, index, weight);
  }
  impostorBlendNormalize(count, weight);
}

// ---- bake cameras (common/frame_camera.cc) ----
// A frame camera is a mat3: [0] direction (centre -> camera), [1] up (toward
// tile row 0), [2] right.

vec3 impostorCameraUp(vec3 d) {
  vec3 world_up = vec3(0.0, 1.0, 0.0);
  vec3 up = world_up - dot(world_up, d) * d;
  if (length(up) < 1.7e-4) return d.y > 0.0 ? vec3(0.0, 0.0, -1.0) : vec3(0.0, 0.0, 1.0);
  return normalize(up);
}

mat3 impostorCameraForDirection(vec3 direction) {
  vec3 d = normalize(direction);
  vec3 up = impostorCameraUp(d);
  return mat3(d, up, normalize(cross(up, d)));
}

// The camera of frame `index` of any layout.
mat3 impostorFrameCameraAt(ivec3 atlas, int index) {
  return impostorCameraForDirection(impostorFrameDirectionAt(atlas, index));
}

// ---- virtual planes (common/runtime/virtual_plane.cc) ----

// xy = frame coordinates (s, t) in [-1, 1] over the tile, z = 1 if valid.
vec3 impostorIntersectFramePlane(mat3 frame, vec3 origin, vec3 ray, float height) {
  float len = length(ray);
  if (!(len > 0.0)) return vec3(0.0);
  vec3 toward_eye = -ray / len;
  float facing = dot(toward_eye, frame[0]);
  if (!(facing >= 1e-4)) return vec3(0.0);
  float k = (dot(origin, frame[0]) - height) / facing;
  vec3 q = origin - k * toward_eye;
  return vec3(dot(q, frame[2]), dot(q, frame[1]), 1.0);
}

// ---- tile sampling (common/runtime/reference_renderer.cc) ----

// texelFetch(tex, texel, 0) of the reference (see the header for why not
// texelFetch itself); the textures have no mips and nearest filtering.
vec4 impostorTexel(sampler2D tex, ivec2 texel) {
  return textureLod(tex, (vec2(texel) + vec2(0.5)) / vec2(textureSize(tex, 0)), 0.0);
}

vec3 impostorSrgbToLinear(vec3 c) {
  vec3 lo = c / 12.92;
  vec3 hi = pow((c + vec3(0.055)) / 1.055, vec3(2.4));
  return mix(hi, lo, vec3(lessThanEqual(c, vec3(0.04045))));
}

// Bilinear over the 2x2 texel centres around st, clamped to the tile
// (tile = x, y, width, height in pixels); empty outside the tile's square.
// Out: alpha (bilinear coverage), albedo (linear, alpha-weighted mean of the
// covered texels), normal ([-1, 1], not renormalised), depth (0..1), orm.
void impostorSampleTile(bool has_orm, ivec4 tile, vec2 st, out float alpha, out vec3 albedo, out vec3 normal,
                        out float depth, out vec3 orm) {
  alpha = 0.0;
  albedo = vec3(0.0);
  normal = vec3(0.0);
  depth = 1.0;
  orm = vec3(0.0);
  if (!(abs(st.x) <= 1.0 && abs(st.y) <= 1.0)) return;
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
  float depth_sum = 0.0;
  for (int k = 0; k < 4; ++k) {
    if (bilinear[k] <= 0.0) continue;
    ivec2 texel = ivec2(tile.x + clamp(ix + (k & 1), 0, tile.z - 1), tile.y + clamp(iy + (k >> 1), 0, tile.w - 1));
    vec4 c = impostorTexel(impostor_albedo, texel);
    float w = bilinear[k] * c.a;
    if (w <= 0.0) continue;
    covered += w;
    vec4 nd = impostorTexel(impostor_normal_depth, texel);
    depth_sum += w * nd.a;
    normal += w * (nd.rgb * 2.0 - 1.0);
    albedo += w * impostorSrgbToLinear(c.rgb);
    if (has_orm) orm += w * impostorTexel(impostor_orm, texel).rgb;
  }
  alpha = covered;
  if (covered > 0.0) {
    depth = depth_sum / covered;
    normal /= covered;
    albedo /= covered;
    orm /= covered;
  }
}

// Coverage and depth only (the marches' samples).
void impostorSampleTileShape(ivec4 tile, vec2 st, out float alpha, out float depth) {
  vec3 albedo;
  vec3 normal;
  vec3 orm;
  impostorSampleTile(false, tile, st, alpha, albedo, normal, depth, orm);
}

// Parallax: marches the ray through the frame's depth (see virtual_plane.h);
// depth mode samples silhouette crossings finer (refine_crossings).
// Returns the sample point (xy), validity (z) and the point's height along
// the frame direction (w, radius units).
vec4 impostorMarchFrameHeightField(ivec4 tile, mat3 frame, vec3 origin, vec3 ray, bool refine_crossings) {
  float above = 1.0;
  bool was_covered = false;
  for (int i = 0; i <= IMPOSTOR_PARALLAX_STEPS; ++i) {
    float h = 1.0 - 2.0 * float(i) / float(IMPOSTOR_PARALLAX_STEPS);
    vec3 hit = impostorIntersectFramePlane(frame, origin, ray, h);
    if (hit.z == 0.0) return vec4(hit, 0.0);
    float s_alpha;
    float s_depth;
    impostorSampleTileShape(tile, hit.xy, s_alpha, s_depth);
    bool covered = s_alpha >= 0.5;
    bool is_below = covered && h <= 1.0 - 2.0 * s_depth;
    if (refine_crossings && !is_below && i > 0 && covered != was_covered) {
      // A silhouette crossing since the last step: sampled finer there, a
      // grazing ray's sliver of the solid can be thinner than a step.
      float top = above;
      for (int k = 1; k < IMPOSTOR_PARALLAX_CROSSING_STEPS; ++k) {
        float hk = top - (top - h) * float(k) / float(IMPOSTOR_PARALLAX_CROSSING_STEPS);
        vec3 at = impostorIntersectFramePlane(frame, origin, ray, hk);
        float m_alpha;
        float m_depth;
        impostorSampleTileShape(tile, at.xy, m_alpha, m_depth);
        if (at.z != 0.0 && m_alpha >= 0.5 && hk <= 1.0 - 2.0 * m_depth) {
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
      float m_alpha;
      float m_depth;
      impostorSampleTileShape(tile, at.xy, m_alpha, m_depth);
      if (at.z != 0.0 && m_alpha >= 0.5 && mid <= 1.0 - 2.0 * m_depth) {
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

// Depth mode's agreement weight (DepthAgreement): 1 while the frame's surface
// height at the point is within half the tolerance of the point's own
// height, 0 beyond the tolerance (the frame did not see the point).
float impostorDepthAgreement(float surface_height, float point_height) {
  float diff = abs(surface_height - point_height);
  return clamp((IMPOSTOR_DEPTH_AGREEMENT - diff) / (0.5 * IMPOSTOR_DEPTH_AGREEMENT), 0.0, 1.0);
}

// ---- the blended surface (RenderImpostorView, per pixel) ----
// The running sums of one pixel's blend (PixelBlend): a_alpha (coverage),
// a_covered (shading weights), a_albedo, a_normal, a_orm, a_position,
// a_weights (per blend entry).

void impostorAccumAdd(inout float a_covered, inout vec3 a_albedo, inout vec3 a_normal, inout vec3 a_orm,
                      inout vec3 a_position, inout vec4 a_weights, int entry, float w, vec3 s_albedo,
                      vec3 s_normal, float s_depth, vec3 s_orm, mat3 frame, vec2 st) {
  if (w <= 0.0) return;
  a_covered += w;
  a_albedo += w * s_albedo;
  a_normal += w * s_normal;
  a_orm += w * s_orm;
  a_position += w * (st.x * frame[2] + st.y * frame[1] + (1.0 - 2.0 * s_depth) * frame[0]);
  a_weights = impostorSet(a_weights, entry, impostorGet(a_weights, entry) + w);
}

// The surface from the sums (ImpostorSurface): alpha (covered iff >= 0.5),
// albedo (linear), normal (object space, unit; zero where empty), position
// (radius units from the centre), orm, weights (each entry's share).
void impostorAccumSurface(float a_alpha, float a_covered, vec3 a_albedo, vec3 a_normal, vec3 a_orm,
                          vec3 a_position, vec4 a_weights, out float alpha, out vec3 albedo, out vec3 normal,
                          out vec3 position, out vec3 orm, out vec4 weights) {
  alpha = a_alpha;
  float inv = a_covered > 0.0 ? 1.0 / a_covered : 0.0;
  albedo = a_albedo * inv;
  orm = a_orm * inv;
  position = a_position * inv;
  weights = a_weights * inv;
  float len = length(a_normal);
  normal = len > 1e-12 ? a_normal / len : vec3(0.0);
}

ivec4 impostorEntryTile(ivec3 atlas, int tile_size, int frame_index) {
  return ivec4(impostorFrameTile(atlas, frame_index) * tile_size, tile_size, tile_size);
}

// How far a march hit deep in its frame's extrusion counts, 0..1
// (ExtrusionConfirmation of OthersInsideShare): by the share of the other
// blended frames' weight that sees `point` inside their silhouettes.
float impostorExtrusionConfirmation(ivec3 atlas, int tile_size, int count, ivec4 index, vec4 weight, int own,
                                    vec3 point) {
  float wts[4] = float[4](weight.x, weight.y, weight.z, weight.w);
  int idx[4] = int[4](index.x, index.y, index.z, index.w);
  float others = 0.0;
  float inside = 0.0;
  for (int j = 0; j < min(count, 4); ++j) {
    if (j == own || !(wts[j] > 0.0)) continue;
    mat3 frame = impostorFrameCameraAt(atlas, idx[j]);
    float s_alpha;
    float s_depth;
    impostorSampleTileShape(impostorEntryTile(atlas, tile_size, idx[j]),
                            vec2(dot(point, frame[2]), dot(point, frame[1])), s_alpha, s_depth);
    others += wts[j];
    inside += wts[j] * s_alpha;
  }
  float share = others > 0.0 ? inside / others : 1.0;
  return clamp((share - (IMPOSTOR_EXTRUSION_CONFIRM - IMPOSTOR_EXTRUSION_CONFIRM_RAMP)) /
                   IMPOSTOR_EXTRUSION_CONFIRM_RAMP, 0.0, 1.0);
}

// Depth mode (common/runtime/depth_reconstruction.h, ReconstructDepth):
// every frame's march hit is a candidate surface point on the ray; each
// blended frame votes for a candidate by weight * coverage * agreement; the
// deepest candidate with at least half the best support is the common point
// P, which every frame samples, weighted by its vote (0 where it did not see
// P).
void impostorShadeDepthLayout(bool has_orm, ivec3 atlas, int tile_size, int count, ivec4 index, vec4 weight,
                              vec3 ray_origin, vec3 ray_dir, out float alpha, out vec3 albedo, out vec3 normal,
                              out vec3 position, out vec3 orm, out vec4 shares) {
  float a_alpha = 0.0;
  float a_covered = 0.0;
  vec3 a_albedo = vec3(0.0);
  vec3 a_normal = vec3(0.0);
  vec3 a_orm = vec3(0.0);
  vec3 a_position = vec3(0.0);
  vec4 a_weights = vec4(0.0);
  vec3 ray_unit = normalize(ray_dir);
  vec4 hits[4] = vec4[4](vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));
  float hit_alpha[4] = float[4](0.0, 0.0, 0.0, 0.0);
  float lambda[4] = float[4](0.0, 0.0, 0.0, 0.0);
  float wts[4] = float[4](weight.x, weight.y, weight.z, weight.w);
  int idx[4] = int[4](index.x, index.y, index.z, index.w);
  int n = min(count, 4);
  float s_alpha;
  vec3 s_albedo;
  vec3 s_normal;
  float s_depth;
  vec3 s_orm;
  for (int i = 0; i < n; ++i) {
    if (!(wts[i] > 0.0)) continue;
    mat3 frame = impostorFrameCameraAt(atlas, idx[i]);
    ivec4 tile = impostorEntryTile(atlas, tile_size, idx[i]);
    vec4 hit = impostorMarchFrameHeightField(tile, frame, ray_origin, ray_dir, true);
    if (hit.z == 0.0) continue;
    impostorSampleTileShape(tile, hit.xy, s_alpha, s_depth);
    if (!(s_alpha > 0.0)) continue;
    float confirmed = 1.0;
    if ((1.0 - 2.0 * s_depth) - hit.w > IMPOSTOR_EXTRUSION_DEPTH) {
      confirmed = impostorExtrusionConfirmation(atlas, tile_size, count, index, weight, i,
                                                hit.x * frame[2] + hit.y * frame[1] + hit.w * frame[0]);
    }
    if (!(confirmed > 0.0)) continue;
    hits[i] = hit;
    hit_alpha[i] = s_alpha;
    a_alpha += wts[i] * s_alpha * confirmed;
    lambda[i] = dot(hit.x * frame[2] + hit.y * frame[1] + hit.w * frame[0] - ray_origin, ray_unit);
  }
  if (a_alpha < 0.5) {
    impostorAccumSurface(a_alpha, a_covered, a_albedo, a_normal, a_orm, a_position, a_weights, alpha, albedo,
                         normal, position, orm, shares);
    return;
  }
  // Votes of every frame j for every candidate c.
  float support[4] = float[4](0.0, 0.0, 0.0, 0.0);
  float most = 0.0;
  for (int c = 0; c < n; ++c) {
    if (hits[c].z == 0.0) continue;
    mat3 fc = impostorFrameCameraAt(atlas, idx[c]);
    vec3 point = hits[c].x * fc[2] + hits[c].y * fc[1] + hits[c].w * fc[0];
    for (int j = 0; j < n; ++j) {
      if (!(wts[j] > 0.0)) continue;
      mat3 frame = impostorFrameCameraAt(atlas, idx[j]);
      vec2 st = j == c ? hits[c].xy : vec2(dot(point, frame[2]), dot(point, frame[1]));
      float height = j == c ? hits[c].w : dot(point, frame[0]);
      impostorSampleTileShape(impostorEntryTile(atlas, tile_size, idx[j]), st, s_alpha, s_depth);
      if (!(s_alpha > 0.0)) continue;
      support[c] += wts[j] * s_alpha * impostorDepthAgreement(1.0 - 2.0 * s_depth, height);
    }
    most = max(most, support[c]);
  }
  int best = -1;
  for (int c = 0; c < n; ++c) {
    if (hits[c].z == 0.0 || !(support[c] >= 0.5 * most)) continue;
    if (best < 0 || lambda[best] < lambda[c]) best = c;
  }
  if (best >= 0 && support[best] > 0.0) {
    mat3 fb = impostorFrameCameraAt(atlas, idx[best]);
    vec3 point = hits[best].x * fb[2] + hits[best].y * fb[1] + hits[best].w * fb[0];
    for (int j = 0; j < n; ++j) {
      if (!(wts[j] > 0.0)) continue;
      mat3 frame = impostorFrameCameraAt(atlas, idx[j]);
      vec2 st = j == best ? hits[best].xy : vec2(dot(point, frame[2]), dot(point, frame[1]));
      float height = j == best ? hits[best].w : dot(point, frame[0]);
      impostorSampleTile(has_orm, impostorEntryTile(atlas, tile_size, idx[j]), st, s_alpha, s_albedo, s_normal,
                         s_depth, s_orm);
      if (!(s_alpha > 0.0)) continue;
      float g = impostorDepthAgreement(1.0 - 2.0 * s_depth, height);
      impostorAccumAdd(a_covered, a_albedo, a_normal, a_orm, a_position, a_weights, j, wts[j] * s_alpha * g,
                       s_albedo, s_normal, s_depth, s_orm, frame, st);
    }
  } else {
    // No frame saw any candidate: each frame at its own hit (parallax).
    for (int j = 0; j < n; ++j) {
      if (hits[j].z == 0.0) continue;
      mat3 frame = impostorFrameCameraAt(atlas, idx[j]);
      impostorSampleTile(has_orm, impostorEntryTile(atlas, tile_size, idx[j]), hits[j].xy, s_alpha, s_albedo,
                         s_normal, s_depth, s_orm);
      impostorAccumAdd(a_covered, a_albedo, a_normal, a_orm, a_position, a_weights, j, wts[j] * hit_alpha[j],
                       s_albedo, s_normal, s_depth, s_orm, frame, hits[j].xy);
    }
  }
  impostorAccumSurface(a_alpha, a_covered, a_albedo, a_normal, a_orm, a_position, a_weights, alpha, albedo,
                       normal, position, orm, shares);
}

// Any mode: IMPOSTOR_RECONSTRUCT_PLAIN, _PARALLAX or _DEPTH
// (impostorReconstructLayout).
void impostorReconstructLayout(bool has_orm, ivec3 atlas, int tile_size, int count, ivec4 index, vec4 weight,
                               vec3 ray_origin, vec3 ray_dir, int mode, out float alpha, out vec3 albedo,
                               out vec3 normal, out vec3 position, out vec3 orm, out vec4 shares) {
  if (mode == IMPOSTOR_RECONSTRUCT_DEPTH) {
    impostorShadeDepthLayout(has_orm, atlas, tile_size, count, index, weight, ray_origin, ray_dir, alpha, albedo,
                             normal, position, orm, shares);
    return;
  }
  float a_alpha = 0.0;
  float a_covered = 0.0;
  vec3 a_albedo = vec3(0.0);
  vec3 a_normal = vec3(0.0);
  vec3 a_orm = vec3(0.0);
  vec3 a_position = vec3(0.0);
  vec4 a_weights = vec4(0.0);
  float s_alpha;
  vec3 s_albedo;
  vec3 s_normal;
  float s_depth;
  vec3 s_orm;
  float wts[4] = float[4](weight.x, weight.y, weight.z, weight.w);
  int idx[4] = int[4](index.x, index.y, index.z, index.w);
  for (int i = 0; i < 4; ++i) {
    if (i >= count) break;
    mat3 frame = impostorFrameCameraAt(atlas, idx[i]);
    ivec4 tile = impostorEntryTile(atlas, tile_size, idx[i]);
    vec3 plane = mode == IMPOSTOR_RECONSTRUCT_PARALLAX
                     ? impostorMarchFrameHeightField(tile, frame, ray_origin, ray_dir, false).xyz
                     : impostorIntersectFramePlane(frame, ray_origin, ray_dir, 0.0);
    if (plane.z == 0.0) continue;
    impostorSampleTile(has_orm, tile, plane.xy, s_alpha, s_albedo, s_normal, s_depth, s_orm);
    float w = wts[i] * s_alpha;
    a_alpha += w;
    impostorAccumAdd(a_covered, a_albedo, a_normal, a_orm, a_position, a_weights, i, w, s_albedo, s_normal,
                     s_depth, s_orm, frame, plane.xy);
  }
  impostorAccumSurface(a_alpha, a_covered, a_albedo, a_normal, a_orm, a_position, a_weights, alpha, albedo,
                       normal, position, orm, shares);
}

// ---- the card and the material ----

// A camera-facing square of the sphere's diameter, one radius toward the
// camera (impostor_runtime_check.vert), whose fragments carry the view ray
// in sphere space; for an orthographic camera (a directional light's shadow
// camera too) the rays run parallel along the view. The blend depends only
// on the direction from the centre to the camera: picked here, per
// instance, and handed on flat.
// impostorCrossFadeThreshold of impostor_crossfade.glsl in floats (every
// value is a small integer or a sixteenth, exact): the 4 x 4 Bayer level of
// the pixel, 8 (x0 ^ y0) + 4 y0 + 2 (x1 ^ y1) + y1 from the coordinates'
// low bits, rotated by the seed's offset.
float impostorCrossFadeThreshold(float offset, vec2 frag_coord) {
  vec2 p = floor(frag_coord);
  vec2 b0 = mod(p, 2.0);
  vec2 b1 = mod(floor(p * 0.5), 2.0);
  float level = 8.0 * abs(b0.x - b0.y) + 4.0 * b0.y + 2.0 * abs(b1.x - b1.y) + b1.y;
  return (mod(level + offset, 16.0) + 0.5) / 16.0;
}

bool impostorCrossFadeDrawsImpostor(float t, float offset, vec2 frag_coord) {
  return impostorCrossFadeThreshold(offset, frag_coord) < t;
}

void vertex() {
  mat4 object_to_view = MODELVIEW_MATRIX;
  mat4 view_to_object = inverse(object_to_view);
  vec3 view_dir;    // object space, centre -> camera
  vec3 eye_sphere;  // the eye in sphere space (perspective)
  bool orthographic = PROJECTION_MATRIX[3][3] != 0.0;
  if (orthographic) {
    view_dir = normalize(mat3(view_to_object) * vec3(0.0, 0.0, 1.0));
    eye_sphere = view_dir;
  } else {
    vec3 eye_object = (view_to_object * vec4(0.0, 0.0, 0.0, 1.0)).xyz;
    eye_sphere = (eye_object - impostor_sphere.xyz) / impostor_sphere.w;
    view_dir = normalize(eye_sphere);
  }
  mat3 card = impostorCameraForDirection(view_dir);
  vec3 p = VERTEX.x * card[2] + VERTEX.y * card[1] + view_dir;
  v_ray_origin = p;
  v_ray_dir = orthographic ? -view_dir : p - eye_sphere;
  int count;
  ivec4 index;
  vec4 weight;
  impostorBlendFramesLayout(impostor_layout.xyz, view_dir, impostor_mode.x, count, index, weight);
  v_count = float(count);
  v_frames = vec4(index);
  v_weights = weight;
  v_object_to_view = object_to_view;
  v_fade = impostor_cross_fade == 2 ? INSTANCE_CUSTOM.rg : vec2(impostor_fade, impostor_fade_offset);
  VERTEX = (object_to_view * vec4(impostor_sphere.xyz + p * impostor_sphere.w, 1.0)).xyz;
  v_card_view = VERTEX;
  NORMAL = normalize(mat3(object_to_view) * view_dir);
}

// impostorMaterial(): reconstruct; coverage below one half is not there;
// the surface point centre + radius * position, its depth (the pixel depth
// offset), the normal through the object's rotation; ORM into Godot's PBR
// (occlusion 1, roughness 1, metalness 0 without an ORM map). The same code
// is the shadow caster: in Godot's depth pass only the discard and DEPTH
// count, so in the shadow pass the cross-fade splits the shadow map's
// pixels as it splits the screen's.
void fragment() {
  if (impostor_cross_fade != 0 && !impostorCrossFadeDrawsImpostor(v_fade.x, v_fade.y, FRAGCOORD.xy)) discard;
  bool has_orm = impostor_mode.z != 0;
  int count = int(v_count + 0.5);
  ivec4 index = ivec4(v_frames + vec4(0.5));
  float alpha;
  vec3 albedo;
  vec3 normal;
  vec3 position;
  vec3 orm;
  vec4 shares;
  impostorReconstructLayout(has_orm, impostor_layout.xyz, impostor_layout.w, count, index, v_weights, v_ray_origin,
                            v_ray_dir, impostor_mode.y, alpha, albedo, normal, position, orm, shares);
  if (alpha < 0.5) discard;
  vec4 view_point = v_object_to_view * vec4(impostor_sphere.xyz + impostor_sphere.w * position, 1.0);
  // What the engine did to the card's depth after vertex() (the shadow
  // pass's bias and normal bias) applies to the surface point too.
  view_point.z += VERTEX.z - v_card_view.z;
  if (impostor_depth_offset) {
    vec4 clip = PROJECTION_MATRIX * vec4(view_point.xyz, 1.0);
    DEPTH = clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0);
  } else {
    DEPTH = FRAGCOORD.z;
  }
  ALBEDO = albedo;
  NORMAL = normalize(mat3(v_object_to_view) * (normal + vec3(0.0, 0.0, 1e-12)));
  if (has_orm) {
    AO = orm.x;
    ROUGHNESS = orm.y;
    METALLIC = orm.z;
  } else {
    ROUGHNESS = 1.0;
    METALLIC = 0.0;
  }
}
