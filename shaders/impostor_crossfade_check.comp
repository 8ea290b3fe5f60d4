#version 450
// Evaluates impostor_crossfade.glsl's dither for a batch of (pixel, seed, t)
// cases, so tests can compare it with the C++ SDK's CrossFadeThreshold /
// CrossFadeDrawsImpostor / CrossFadeDrawsMesh bit for bit
// (tests/runtime/glsl_crossfade_test.cc).
#extension GL_GOOGLE_include_directive : require
#include "impostor_crossfade.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
  int count;
} push;

// Per case: (pixel x, pixel y, seed, t as float bits).
layout(std430, set = 0, binding = 0) readonly buffer Cases { ivec4 cases[]; };
// Per case: (threshold as float bits, draws impostor, draws mesh, 0).
layout(std430, set = 0, binding = 1) writeonly buffer Decisions { uvec4 decisions[]; };

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(push.count)) return;
  ivec4 c = cases[i];
  ivec2 pixel = c.xy;
  uint seed = uint(c.z);
  float t = intBitsToFloat(c.w);
  decisions[i] = uvec4(floatBitsToUint(impostorCrossFadeThreshold(seed, pixel)),
                       impostorCrossFadeDrawsImpostor(t, seed, pixel) ? 1u : 0u,
                       impostorCrossFadeDrawsMesh(t, seed, pixel) ? 1u : 0u, 0u);
}
