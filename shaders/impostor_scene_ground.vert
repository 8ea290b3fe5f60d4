#version 450
// examples/impostor_scene: the ground, a square in the plane y = height.
layout(push_constant) uniform Push {
  mat4 world_to_clip;
  vec4 ground;  // x, z of the centre, y = height, w = half side
  vec4 albedo;  // linear
} push;
layout(location = 0) out vec3 out_world;

void main() {
  const vec2 corners[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
  vec2 c = corners[gl_VertexIndex] * push.ground.w;
  out_world = vec3(push.ground.x + c.x, push.ground.y, push.ground.z + c.y);
  gl_Position = push.world_to_clip * vec4(out_world, 1.0);
}
