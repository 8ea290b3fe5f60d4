// Asks shaders/impostor_runtime.glsl itself (as the impostor-three package
// embeds it, the runtime the viewer draws with) which frames it blends for a
// view direction: impostorBlendFramesLayout runs in a 4 x 1 fragment pass
// into an integer render target (pixel i = entry i: frame index, weight
// bits, tile column and row) read back with readPixels. No second copy of
// the math in JavaScript, so the atlas panel marks exactly the frames the
// impostor draws (and tests compare them with the C++ BlendFrames).
import { impostorRuntimeGlsl } from 'impostor-three';

const PRELUDE = '#version 300 es\nprecision highp float;\nprecision highp int;\nprecision highp sampler2D;\n';
const VERTEX = `${PRELUDE}
void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}`;
const FRAGMENT = `
uniform vec3 u_view_dir;  // centre -> camera, any length
uniform ivec4 u_layout;   // kind, frames, ring_views, blend mode
out ivec4 o_entry;
void main() {
  ImpostorLayout atlas = ImpostorLayout(u_layout.x, u_layout.y, u_layout.z);
  ImpostorBlend b = impostorBlendFramesLayout(atlas, normalize(u_view_dir), u_layout.w);
  int i = int(gl_FragCoord.x);
  if (i >= b.count) {
    o_entry = ivec4(-1);
    return;
  }
  o_entry = ivec4(b.index[i], floatBitsToInt(b.weight[i]), b.frame[i].x, b.frame[i].y);
}`;

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(`blend probe shader: ${gl.getShaderInfoLog(shader)}`);
  return shader;
}

// layout = {kind, frames, ringViews} as the viewer's material passes to the shader (impostor_view.js).
// Returns probe(viewDir: [x, y, z], blendMode: 0 | 1) -> [{index, weight, tile: [col, row]}] in the shader's order.
export async function createBlendProbe(layout) {
  const canvas = document.createElement('canvas');
  canvas.width = 4;
  canvas.height = 1;
  const gl = canvas.getContext('webgl2');
  if (!gl) throw new Error('WebGL2 is not available');
  const runtime = impostorRuntimeGlsl;
  const program = gl.createProgram();
  gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, VERTEX));
  gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, PRELUDE + runtime + FRAGMENT));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`blend probe: ${gl.getProgramInfoLog(program)}`);
  const target = gl.createRenderbuffer();
  gl.bindRenderbuffer(gl.RENDERBUFFER, target);
  gl.renderbufferStorage(gl.RENDERBUFFER, gl.RGBA32I, 4, 1);
  const fbo = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
  gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.RENDERBUFFER, target);
  const pixels = new Int32Array(16);
  const bits = new Int32Array(1);
  const asFloat = new Float32Array(bits.buffer);
  return (viewDir, blendMode) => {
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.viewport(0, 0, 4, 1);
    gl.useProgram(program);
    gl.uniform3f(gl.getUniformLocation(program, 'u_view_dir'), viewDir[0], viewDir[1], viewDir[2]);
    gl.uniform4i(gl.getUniformLocation(program, 'u_layout'), layout.kind, layout.frames, layout.ringViews, blendMode);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.readPixels(0, 0, 4, 1, gl.RGBA_INTEGER, gl.INT, pixels);
    const entries = [];
    for (let i = 0; i < 4 && pixels[i * 4] >= 0; ++i) {
      bits[0] = pixels[i * 4 + 1];
      entries.push({ index: pixels[i * 4], weight: asFloat[0], tile: [pixels[i * 4 + 2], pixels[i * 4 + 3]] });
    }
    return entries;
  };
}
