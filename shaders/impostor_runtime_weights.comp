#version 450
// Evaluates impostor_runtime.glsl's frame blend and virtual-plane projection
// for a batch of view directions, so tests can compare them with the C++
// (tests/runtime/glsl_runtime_test.cc).
#extension GL_GOOGLE_include_directive : require
#include "impostor_runtime.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
  int layout_kind;
  int frames;
  int mode;
  int count;
  int ring_views;
} push;

layout(std430, set = 0, binding = 0) readonly buffer Directions { vec4 directions[]; };
// Per direction and blend slot: (frame index, weight, s, t), where (s, t) is
// where the view pixel at view coordinates (0.3, -0.2) of an orthographic
// camera along the direction samples that frame (0, 0 if invalid); unused
// slots are (-1, 0, 0, 0).
layout(std430, set = 0, binding = 1) writeonly buffer Weights { vec4 weights[]; };

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(push.count)) return;
  ImpostorLayout atlas = ImpostorLayout(push.layout_kind, push.frames, push.ring_views);
  ImpostorBlend b = impostorBlendFramesLayout(atlas, directions[i].xyz, push.mode);
  ImpostorFrameCamera view = impostorCameraForDirection(directions[i].xyz);
  vec3 origin = 0.3 * view.right + -0.2 * view.up + view.direction;
  for (int k = 0; k < 4; ++k) {
    bool used = k < b.count;
    vec3 st = vec3(0.0);
    if (used) {
      st = impostorIntersectFramePlane(impostorFrameCameraAt(atlas, b.index[k]), origin, -view.direction, 0.0);
    }
    weights[i * 4u + uint(k)] = vec4(used ? float(b.index[k]) : -1.0,
                                     used ? b.weight[k] : 0.0, st.xy);
  }
}
