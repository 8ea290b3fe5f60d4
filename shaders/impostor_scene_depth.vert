#version 450
// examples/impostor_scene: the mesh in the light's depth-only pass (no
// fragment stage). Reads only the position of the worker's SceneVertex.
layout(location = 0) in vec3 in_position;
layout(push_constant) uniform Push {
  mat4 object_to_clip;
} push;

void main() { gl_Position = push.object_to_clip * vec4(in_position, 1.0); }
