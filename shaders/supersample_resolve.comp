// Device-side supersample resolve of the bake's atlas maps: the same box
// filter as worker/output/supersample.cc (which stays the reference), run
// over the factor x factor blocks of the supersampled render targets and
// written tightly packed into the host-visible readback buffers, so only the
// final-size maps cross to the host.
//
// Semantics (supersample.h): coverage A = covered samples / factor^2;
// albedo and emissive = mean of the covered samples in linear light;
// normal = renormalised mean of the covered normals; depth, ORM = mean of
// the covered samples; blocks no sample covers keep the empty encodings.
// Inputs are read as raw UNORM values (albedo's sRGB image through a UNORM
// view) and converted back to integers, so the depth and ORM means and the
// coverage are exact; albedo, emissive and normals differ from the CPU
// reference only by float vs double rounding (at most one level).
#version 450

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D albedo_in;        // RGBA8, sRGB bytes
layout(set = 0, binding = 1) uniform sampler2D normal_depth_in;  // RGBA16 UNORM
layout(set = 0, binding = 2) uniform sampler2D orm_in;           // RGBA8 UNORM
layout(set = 0, binding = 3) uniform sampler2D emissive_in;      // RGBA8, sRGB bytes
layout(std430, set = 0, binding = 4) writeonly buffer AlbedoOut { uint albedo_out[]; };
layout(std430, set = 0, binding = 5) writeonly buffer NormalDepthOut { uint normal_depth_out[]; };
layout(std430, set = 0, binding = 6) writeonly buffer OrmOut { uint orm_out[]; };
layout(std430, set = 0, binding = 7) writeonly buffer EmissiveOut { uint emissive_out[]; };

layout(push_constant) uniform Push {
  int factor;
  int out_width;
  int out_height;
  int emissive;  // 0: bindings 3 and 7 are placeholders, never read or written
} pc;

float SrgbToLinear(float c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }

uint LinearToSrgb8(float l) {
  l = clamp(l, 0.0, 1.0);
  const float c = l <= 0.0031308 ? l * 12.92 : 1.055 * pow(l, 1.0 / 2.4) - 0.055;
  return uint(floor(c * 255.0 + 0.5));
}

uint Round(float v, float max_value) { return uint(clamp(floor(v + 0.5), 0.0, max_value)); }

uint Pack8(uvec4 v) { return v.x | (v.y << 8) | (v.z << 16) | (v.w << 24); }

void main() {
  const ivec2 o = ivec2(gl_GlobalInvocationID.xy);
  if (o.x >= pc.out_width || o.y >= pc.out_height) return;
  const uint out_index = uint(o.y) * uint(pc.out_width) + uint(o.x);
  uint covered = 0u;
  vec3 rgb = vec3(0.0), nrm = vec3(0.0), emi = vec3(0.0);
  uvec3 orm_sum = uvec3(0u);
  uint depth_sum = 0u;
  for (int sy = 0; sy < pc.factor; ++sy) {
    for (int sx = 0; sx < pc.factor; ++sx) {
      const ivec2 p = o * pc.factor + ivec2(sx, sy);
      const vec4 a = texelFetch(albedo_in, p, 0);
      if (a.a == 0.0) continue;
      ++covered;
      // Back to the stored bytes, then decoded as the CPU reference does.
      const vec3 bytes = floor(a.rgb * 255.0 + 0.5) / 255.0;
      rgb += vec3(SrgbToLinear(bytes.r), SrgbToLinear(bytes.g), SrgbToLinear(bytes.b));
      const uvec4 nd = uvec4(floor(texelFetch(normal_depth_in, p, 0) * 65535.0 + 0.5));
      nrm += vec3(nd.xyz) / 65535.0 * 2.0 - 1.0;
      depth_sum += nd.w;
      orm_sum += uvec3(floor(texelFetch(orm_in, p, 0).rgb * 255.0 + 0.5));
      if (pc.emissive != 0) {
        const vec3 e = floor(texelFetch(emissive_in, p, 0).rgb * 255.0 + 0.5) / 255.0;
        emi += vec3(SrgbToLinear(e.r), SrgbToLinear(e.g), SrgbToLinear(e.b));
      }
    }
  }
  if (covered == 0u) {
    albedo_out[out_index] = 0u;
    orm_out[out_index] = 0u;
    if (pc.emissive != 0) emissive_out[out_index] = 0u;
    normal_depth_out[out_index * 2u] = 32768u | (32768u << 16);
    normal_depth_out[out_index * 2u + 1u] = 32768u | (65535u << 16);
    return;
  }
  const float n = float(covered);
  const uint coverage = Round(255.0 * n / float(pc.factor * pc.factor), 255.0);
  const vec3 mean = rgb / n;
  albedo_out[out_index] = Pack8(uvec4(LinearToSrgb8(mean.r), LinearToSrgb8(mean.g), LinearToSrgb8(mean.b), coverage));
  const vec3 o_mean = vec3(orm_sum) / n;
  orm_out[out_index] =
      Pack8(uvec4(Round(o_mean.r, 255.0), Round(o_mean.g, 255.0), Round(o_mean.b, 255.0), coverage));
  if (pc.emissive != 0) {
    const vec3 e_mean = emi / n;
    emissive_out[out_index] =
        Pack8(uvec4(LinearToSrgb8(e_mean.r), LinearToSrgb8(e_mean.g), LinearToSrgb8(e_mean.b), coverage));
  }
  const float len = length(nrm);
  const vec3 unit = len > 1e-9 ? nrm / len : vec3(0.0, 0.0, 1.0);
  const uvec3 nq = uvec3(Round((unit.x * 0.5 + 0.5) * 65535.0, 65535.0), Round((unit.y * 0.5 + 0.5) * 65535.0, 65535.0),
                         Round((unit.z * 0.5 + 0.5) * 65535.0, 65535.0));
  const uint depth = Round(float(depth_sum) / n, 65535.0);
  normal_depth_out[out_index * 2u] = nq.x | (nq.y << 16);
  normal_depth_out[out_index * 2u + 1u] = nq.z | (depth << 16);
}
