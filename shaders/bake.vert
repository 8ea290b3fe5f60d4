#version 450
// Impostor bake, vertex stage. Positions are already in scene space (the
// loader applied node transforms), so the only transform is the frame's
// orthographic Vulkan clip matrix (FrameViewProjection). Normal and tangent
// stay in scene space: the normal map is encoded in scene space.

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec4 in_tangent;  // xyz, w = bitangent sign
layout(location = 3) in vec2 in_uv;   // TEXCOORD_0
layout(location = 4) in vec2 in_uv1;  // TEXCOORD_1
layout(location = 5) in vec4 in_color;  // COLOR_0 (1 when absent)

// Bytes 0..63 of the push-constant block; the fragment stage owns 64..111.
layout(push_constant) uniform FramePush {
  mat4 view_projection;
} frame;

layout(location = 0) out vec3 out_normal;
layout(location = 1) out vec4 out_tangent;
layout(location = 2) out vec4 out_uv01;  // xy TEXCOORD_0, zw TEXCOORD_1
layout(location = 3) out vec4 out_color;

void main() {
  gl_Position = frame.view_projection * vec4(in_position, 1.0);
  out_normal = in_normal;
  out_tangent = in_tangent;
  out_uv01 = vec4(in_uv, in_uv1);
  out_color = in_color;
}
