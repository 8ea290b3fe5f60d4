#version 450
// examples/impostor_scene: the ground, lit like everything else. Alpha 0
// marks "ground, not an object" for the example's tests.
#extension GL_GOOGLE_include_directive : require
#include "impostor_material_light.glsl"

layout(push_constant) uniform Push {
  mat4 world_to_clip;
  vec4 ground;
  vec4 albedo;
} push;
layout(location = 0) in vec3 in_world;
layout(location = 0) out vec4 out_colour;

void main() { out_colour = vec4(impostorLambert(push.albedo.rgb, vec3(0.0, 1.0, 0.0), 1.0, in_world), 0.0); }
