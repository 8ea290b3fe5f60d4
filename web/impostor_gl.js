// Draws a baked impostor with WebGL2 using shaders/impostor_runtime.glsl
// itself (served by the server at /runtime/impostor_runtime.glsl): GLSL ES
// 3.00 compiles it unchanged after a #version line and precision
// qualifiers, so the browser runs the very math the C++ reference renderer
// and the Vulkan check shader are tested against. The card and the ray set-up
// follow shaders/impostor_runtime_check.{vert,frag}.
//
// Textures: albedo_alpha is uploaded as SRGB8_ALPHA8 (reads are linear, as
// the runtime expects); normal_depth and orm as RGBA8 (the browser decodes
// 16-bit PNGs to 8 bits: normals and parallax depth are slightly coarser
// than in an engine). KTX2 maps are decoded to the same RGBA8 first
// (ktx2_rgba.js); texture-array strips are laid out as the atlas first
// (texture_array.js).
import { decodeKtx2Rgba, isKtx2 } from './ktx2_rgba.js';
import { decodeLayerStrip, isTextureArray } from './texture_array.js';

const LAYOUT_KIND = {
  LAYOUT_OCTAHEDRAL: 0, LAYOUT_UNSPECIFIED: 0, LAYOUT_HEMI_OCTAHEDRAL: 1, LAYOUT_AZIMUTH_ELEVATION: 2,
  LAYOUT_RING_TOP: 3, LAYOUT_BILLBOARD: 4,
};

const PRELUDE = '#version 300 es\nprecision highp float;\nprecision highp int;\nprecision highp sampler2D;\n';

const VERTEX = `
uniform mat4 u_view_projection;  // object space -> clip
uniform vec3 u_eye;              // eye, radius units from the centre
uniform vec4 u_sphere;           // centre xyz, radius w (object space)
uniform int u_ortho;             // 1: the card fills the viewport (a bake-like orthographic view)
out vec3 v_ray_origin;
out vec3 v_ray_dir;
void main() {
  vec2 corners[6] = vec2[6](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
  vec3 view_dir = normalize(u_eye);
  ImpostorFrameCamera card = impostorCameraForDirection(view_dir);
  vec2 c = corners[gl_VertexID];
  vec3 p = c.x * card.right + c.y * card.up + view_dir;
  v_ray_origin = p;
  // Orthographic: parallel rays along the view, as impostor_runtime_view.comp.
  v_ray_dir = u_ortho != 0 ? -view_dir : p - u_eye;
  gl_Position = u_ortho != 0 ? vec4(c, 0.0, 1.0) : u_view_projection * vec4(u_sphere.xyz + p * u_sphere.w, 1.0);
}`;

const FRAGMENT = `
uniform vec3 u_eye;
uniform sampler2D u_albedo;
uniform sampler2D u_normal_depth;
uniform sampler2D u_orm;
uniform ivec4 u_layout;  // kind, frames, ring_views, tile_size
uniform ivec4 u_mode;    // blend mode, reconstruction (IMPOSTOR_RECONSTRUCT_*), has_orm, debug view
in vec3 v_ray_origin;
in vec3 v_ray_dir;
out vec4 o_color;
vec3 srgbEncode(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
vec3 indexColour(int i) {
  uint h = uint(i) * 2654435761u;
  return vec3(float((h >> 16) & 255u), float((h >> 8) & 255u), float(h & 255u)) / 255.0;
}
void main() {
  vec3 view_dir = normalize(u_eye);
  ImpostorLayout atlas = ImpostorLayout(u_layout.x, u_layout.y, u_layout.z);
  ImpostorBlend b = impostorBlendFramesLayout(atlas, view_dir, u_mode.x);
  ImpostorSurface s = impostorReconstructLayout(u_albedo, u_normal_depth, u_orm, u_mode.z != 0, atlas, u_layout.w, b,
                                                v_ray_origin, v_ray_dir, u_mode.y);
  if (s.alpha < 0.5) discard;
  vec3 c = srgbEncode(s.albedo);
  if (u_mode.w == 1) c = indexColour(b.index[0]);
  if (u_mode.w == 2) c = vec3(b.weight[0], b.count > 1 ? b.weight[1] : 0.0, b.count > 2 ? b.weight[2] : 0.0);
  if (u_mode.w == 3) c = s.normal * 0.5 + 0.5;
  o_color = vec4(c, 1.0);
}`;

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
    throw new Error(`impostor shader: ${gl.getShaderInfoLog(shader)}`);
  }
  return shader;
}

async function loadTexture(gl, url, srgb, manifest) {
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
  gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
  gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
  const internal = srgb ? gl.SRGB8_ALPHA8 : gl.RGBA8;
  if (isKtx2(url) || isTextureArray(manifest)) {
    const { width, height, data } = isKtx2(url) ? await decodeKtx2Rgba(url) : await decodeLayerStrip(url, manifest);
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.texImage2D(gl.TEXTURE_2D, 0, internal, width, height, 0, gl.RGBA, gl.UNSIGNED_BYTE, data);
  } else {
    const response = await fetch(url);
    if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
    const image = await createImageBitmap(await response.blob(), { premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.texImage2D(gl.TEXTURE_2D, 0, internal, gl.RGBA, gl.UNSIGNED_BYTE, image);
  }
  // texelFetch only (the runtime filters by hand): no mipmaps needed.
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  return tex;
}

// Returns {draw(viewProjection: Float32Array(16) column-major, eye: [x,y,z] in object space), options}.
export async function createImpostorRenderer(canvas, manifest, fileUrl) {
  const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true, premultipliedAlpha: false });
  if (!gl) throw new Error('WebGL2 is not available');
  const runtime = await (await fetch('/runtime/impostor_runtime.glsl')).text();
  const program = gl.createProgram();
  gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, PRELUDE + runtime + VERTEX));
  gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, PRELUDE + runtime + FRAGMENT));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`impostor program: ${gl.getProgramInfoLog(program)}`);
  const mapFile = (semantic) => manifest.maps.find((m) => m.semantic === semantic);
  const albedo = mapFile('albedo_alpha');
  const normalDepth = mapFile('normal_depth');
  const orm = mapFile('orm');
  if (!albedo || !normalDepth) throw new Error('this result has no albedo_alpha/normal_depth maps to draw');
  const textures = await Promise.all([loadTexture(gl, fileUrl(albedo.file), true, manifest),
    loadTexture(gl, fileUrl(normalDepth.file), false, manifest),
    orm ? loadTexture(gl, fileUrl(orm.file), false, manifest) : Promise.resolve(null)]);
  const kind = LAYOUT_KIND[manifest.layout] ?? 0;
  const ringViews = kind === 3 ? manifest.views.length - 1 : kind === 4 ? 8 : 0;
  const u = (name) => gl.getUniformLocation(program, name);
  const options = { blend: manifest.quality && manifest.quality.blend === 'bilinear4' ? 1 : 0, parallax: false, depth: false, debug: 0 };
  const centre = manifest.bounding_sphere.center;
  const radius = manifest.bounding_sphere.radius;
  return {
    options,
    layout: { kind, frames: manifest.frames, ringViews },  // as the shader gets it (u_layout)
    // The orthographic view the CPU reference renderer draws
    // (RenderImpostorView): direction `dir` (unit, centre -> camera), the
    // card framing the bounding sphere, rays parallel (eye far away).
    drawOrthographic(dir) {
      const far = 1e5;
      this.draw(new Float32Array(16), centre.map((c, i) => c + dir[i] * radius * far), true);
    },
    draw(viewProjection, eye, ortho = false) {
      gl.viewport(0, 0, canvas.width, canvas.height);
      gl.clearColor(0, 0, 0, 0);
      gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
      gl.useProgram(program);
      gl.uniformMatrix4fv(u('u_view_projection'), false, viewProjection);
      gl.uniform3f(u('u_eye'), (eye[0] - centre[0]) / radius, (eye[1] - centre[1]) / radius, (eye[2] - centre[2]) / radius);
      gl.uniform4f(u('u_sphere'), centre[0], centre[1], centre[2], radius);
      gl.uniform1i(u('u_ortho'), ortho ? 1 : 0);
      gl.uniform4i(u('u_layout'), kind, manifest.frames, ringViews, manifest.tile_size);
      // depth (docs/runtime.md) wins over parallax; neither = plain.
      gl.uniform4i(u('u_mode'), options.blend, options.depth ? 2 : options.parallax ? 1 : 0, textures[2] ? 1 : 0, options.debug);
      ['u_albedo', 'u_normal_depth', 'u_orm'].forEach((name, i) => {
        gl.activeTexture(gl.TEXTURE0 + i);
        gl.bindTexture(gl.TEXTURE_2D, textures[i] || textures[0]);
        gl.uniform1i(u(name), i);
      });
      gl.drawArrays(gl.TRIANGLES, 0, 6);
    },
  };
}
