#version 450
// Compile check and usage example for impostor_runtime.glsl: a camera-facing
// card over the bounding sphere (2 triangles, no vertex buffer) that hands
// the fragment stage its object-space view ray, in radius units from the
// sphere centre.
#extension GL_GOOGLE_include_directive : require
#include "impostor_runtime.glsl"

layout(push_constant) uniform ImpostorPush {
  mat4 view_projection;   // object space -> clip
  vec4 eye_object;        // xyz: eye in radius units from the centre
  ivec4 params;           // layout, frames, tile_size, blend mode
  ivec4 flags;            // x: parallax, y: has_orm
  vec4 sphere;            // xyz centre, w radius (object space)
} push;

layout(location = 0) out vec3 out_ray_origin;
layout(location = 1) out vec3 out_ray_dir;

void main() {
  const vec2 corners[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
  vec3 view_dir = normalize(push.eye_object.xyz);
  ImpostorFrameCamera card = impostorCameraForDirection(view_dir);
  vec2 c = corners[gl_VertexIndex];
  // The card sits on the sphere's front so it is never clipped by it.
  vec3 p = c.x * card.right + c.y * card.up + view_dir;
  out_ray_origin = p;
  out_ray_dir = p - push.eye_object.xyz;
  gl_Position = push.view_projection * vec4(push.sphere.xyz + p * push.sphere.w, 1.0);
}
