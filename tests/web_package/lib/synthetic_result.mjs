// A baked result directory for tests, rendered analytically instead of by
// the Vulkan baker: a box of half extents (0.6, 1.0, 0.4) centred at
// (0, 1, 0), each face its own flat colour, in an octahedral or
// hemi-octahedral atlas, with the files and manifest.json of
// common/manifest_format.md (albedo_alpha.png RGBA8 sRGB, normal_depth.png
// RGBA16, orm.png RGBA8, contact_sheet.png; frame cameras as
// common/atlas_layout.cc and common/frame_camera.cc, 4 x 4 supersamples per
// texel for coverage). BOX and FACE_COLOURS let tests predict what an
// impostor of it must show.
//
// CLI: node synthetic_result.mjs OUT_DIR [--layout octahedral|hemi-octahedral]
//        [--frames N] [--resolution PX]
import { createHash } from 'node:crypto';
import { mkdirSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { BOX, FACE_COLOURS } from './box_model.mjs';
import { encodePng } from './png.mjs';

export { BOX, FACE_COLOURS };

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const normalize = (a) => {
  const l = Math.hypot(a[0], a[1], a[2]);
  return [a[0] / l, a[1] / l, a[2] / l];
};

// common/atlas_layout.cc: frame (col, row) of the (hemi-)octahedral grid.
export function frameDirection(layout, frames, col, row) {
  const inv = frames > 1 ? 1 / (frames - 1) : 0;
  const u = col * inv * 2 - 1, v = row * inv * 2 - 1;
  if (layout === 'hemi-octahedral') {
    const x = (u + v) / 2, z = (u - v) / 2;
    return normalize([x, 1 - Math.abs(x) - Math.abs(z), z]);
  }
  let d = [u, 1 - Math.abs(u) - Math.abs(v), v];
  if (d[1] < 0) {
    const sx = u < 0 ? -1 : 1, sz = v < 0 ? -1 : 1;
    d = [(1 - Math.abs(v)) * sx, d[1], (1 - Math.abs(u)) * sz];
  }
  return normalize(d);
}

// common/frame_camera.cc: up toward tile row 0, right = cross(up, direction).
export function frameCamera(direction) {
  let up = [0, 1, 0];
  const k = dot(up, direction);
  up = [up[0] - k * direction[0], up[1] - k * direction[1], up[2] - k * direction[2]];
  if (Math.hypot(...up) < 1.7e-4) up = direction[1] > 0 ? [0, 0, -1] : [0, 0, 1];
  up = normalize(up);
  return { direction, up, right: normalize(cross(up, direction)) };
}

// The box's hit along origin + t * dir (scene units): {t, normal, face} or null.
export function hitBox(origin, dir) {
  let tNear = -Infinity, tFar = Infinity, axis = -1, sign = 0;
  for (let i = 0; i < 3; ++i) {
    const lo = BOX.center[i] - BOX.half[i], hi = BOX.center[i] + BOX.half[i];
    if (Math.abs(dir[i]) < 1e-12) {
      if (origin[i] < lo || origin[i] > hi) return null;
      continue;
    }
    let t0 = (lo - origin[i]) / dir[i], t1 = (hi - origin[i]) / dir[i];
    let s = -1;
    if (t0 > t1) {
      [t0, t1] = [t1, t0];
      s = 1;
    }
    if (t0 > tNear) {
      tNear = t0;
      axis = i;
      sign = s;
    }
    tFar = Math.min(tFar, t1);
  }
  if (tNear > tFar || tFar < 0 || axis < 0) return null;
  const normal = [0, 0, 0];
  normal[axis] = sign;
  return { t: tNear, normal, face: `${sign > 0 ? '+' : '-'}${'xyz'[axis]}` };
}

export function boundingSphere() {
  return { center: [...BOX.center], radius: Math.hypot(...BOX.half) };
}

function tileSizeFor(resolution, frames) {
  const raw = Math.floor(resolution / frames);
  const levels = Math.max(0, Math.floor(Math.log2(raw / 16)));
  return Math.floor(raw / 2 ** levels) * 2 ** levels;
}

const sha256 = (bytes) => createHash('sha256').update(bytes).digest('hex');

// Writes the result into `dir`; returns its manifest (as written).
export function writeSyntheticResult(dir, { layout = 'octahedral', frames = 8, resolution = 512, samples = 4 } = {}) {
  mkdirSync(dir, { recursive: true });
  const tile = tileSizeFor(resolution, frames);
  const { center, radius } = boundingSphere();
  const albedo = new Uint8Array(resolution * resolution * 4);
  const normalDepth = new Uint16Array(resolution * resolution * 4);
  const orm = new Uint8Array(resolution * resolution * 4);
  const views = [];
  for (let row = 0; row < frames; ++row) {
    for (let col = 0; col < frames; ++col) {
      const index = row * frames + col;
      const cam = frameCamera(frameDirection(layout, frames, col, row));
      const toward = cam.direction.map((v) => -v);
      views.push({ index, direction: cam.direction, up: cam.up, tile: [col * tile, row * tile, tile, tile], same_view_as: index });
      for (let py = 0; py < tile; ++py) {
        for (let px = 0; px < tile; ++px) {
          let covered = 0;
          const col3 = [0, 0, 0], n3 = [0, 0, 0];
          let depth = 0;
          for (let sy = 0; sy < samples; ++sy) {
            for (let sx = 0; sx < samples; ++sx) {
              const s = ((px + (sx + 0.5) / samples) / tile) * 2 - 1;
              const t = 1 - ((py + (sy + 0.5) / samples) / tile) * 2;
              const o = [0, 1, 2].map((i) => center[i] + radius * (s * cam.right[i] + t * cam.up[i] + 2 * cam.direction[i]));
              const hit = hitBox(o, toward);
              if (!hit) continue;
              ++covered;
              const p = o.map((v, i) => v + hit.t * toward[i]);
              const c = FACE_COLOURS[hit.face];
              for (let i = 0; i < 3; ++i) {
                col3[i] += c[i];
                n3[i] += hit.normal[i];
              }
              depth += (1 - dot(p.map((v, i) => v - center[i]), cam.direction) / radius) / 2;
            }
          }
          const at = ((row * tile + py) * resolution + col * tile + px) * 4;
          const alpha = Math.round((255 * covered) / (samples * samples));
          if (covered === 0) {
            normalDepth.set([32768, 32768, 32768, 65535], at);
            continue;
          }
          const n = normalize(n3);
          for (let i = 0; i < 3; ++i) {
            albedo[at + i] = Math.round(col3[i] / covered);
            normalDepth[at + i] = Math.round((n[i] * 0.5 + 0.5) * 65535);
          }
          albedo[at + 3] = alpha;
          normalDepth[at + 3] = Math.round(Math.min(1, Math.max(0, depth / covered)) * 65535);
          orm.set([255, 128, 0, alpha], at);
        }
      }
    }
  }
  const files = [
    ['albedo_alpha', 'albedo_alpha.png', encodePng(resolution, resolution, albedo), 'png_rgba8', ['r', 'g', 'b', 'coverage']],
    ['normal_depth', 'normal_depth.png', encodePng(resolution, resolution, normalDepth, 16), 'png_rgba16', ['normal_x', 'normal_y', 'normal_z', 'depth']],
    ['orm', 'orm.png', encodePng(resolution, resolution, orm), 'png_rgba8', ['occlusion', 'roughness', 'metalness', 'coverage']],
    ['contact_sheet', 'contact_sheet.png', encodePng(4, 4, new Uint8Array(64).fill(128)), 'png_rgb8', ['r', 'g', 'b', '']],
  ];
  const maps = files.map(([semantic, file, bytes, format, channels]) => {
    writeFileSync(join(dir, file), bytes);
    const side = semantic === 'contact_sheet' ? 4 : resolution;
    return { semantic, file, digest: { hash: sha256(bytes), size_bytes: bytes.length }, width: side, height: side, format, channels };
  });
  const half = BOX.half;
  const manifest = {
    format_version: 2,
    product: 'atlas',
    cache_key: sha256(`synthetic box ${layout} ${frames} ${resolution} ${samples}`),
    baker_version: 'synthetic-box-1',
    layout,
    frames,
    resolution,
    tile_size: tile,
    bounding_sphere: { center, radius },
    bounding_box: { min: center.map((c, i) => c - half[i]), max: center.map((c, i) => c + half[i]) },
    maps,
    views,
    mesh: { triangles: 12, materials: 1, textures: 0 },
    device: 'synthetic (tests/web_package/lib/synthetic_result.mjs)',
  };
  writeFileSync(join(dir, 'manifest.json'), JSON.stringify(manifest, null, 2) + '\n');
  return manifest;
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  const args = process.argv.slice(2);
  const opt = (name, fallback) => {
    const i = args.indexOf(`--${name}`);
    return i >= 0 ? args[i + 1] : fallback;
  };
  if (!args[0] || args[0].startsWith('--')) {
    console.error('usage: node synthetic_result.mjs OUT_DIR [--layout L] [--frames N] [--resolution PX]');
    process.exit(2);
  }
  const m = writeSyntheticResult(args[0], {
    layout: opt('layout', 'octahedral'), frames: Number(opt('frames', 8)), resolution: Number(opt('resolution', 512)),
  });
  console.log(`${args[0]}: ${m.layout} ${m.frames}x${m.frames}, ${m.resolution} px, cache key ${m.cache_key}`);
}
