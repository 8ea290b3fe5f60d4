// File size and decode time of a bake's maps per texture format, as ratios
// to PNG (issue 22). Compares two result folders of the same request, one
// baked with --texture-format png and one with ktx2:
//
//   node bench/texture_format_bench.mjs PNG_DIR KTX2_DIR [--repeat N]
//
// "Decode" is what a game does before the GPU can sample the map: PNG ->
// RGBA pixels (zlib inflate + unfilter, all rows), KTX2 -> GPU blocks for
// every mip level with three.js's Basis Universal transcoder (the one
// KTX2Loader runs; web/node_modules/three, `cd web && npm ci`), to BC7 (desktop)
// and ASTC 4x4 (mobile). PNG gets no mip chain and no GPU compression here,
// so its real cost on a device is higher than measured. Timings are medians
// of --repeat runs (default 5) after one warm-up, on this machine's CPU.
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const repeatAt = args.indexOf('--repeat');
const repeat = repeatAt >= 0 ? Number(args.splice(repeatAt, 2)[1]) : 5;
if (args.length !== 2 || !(repeat >= 1)) {
  console.error('usage: node bench/texture_format_bench.mjs PNG_DIR KTX2_DIR [--repeat N]');
  process.exit(2);
}
const [pngDir, ktx2Dir] = args;

function loadTranscoder() {
  const dir = path.join(here, '..', 'web', 'node_modules', 'three', 'examples', 'jsm', 'libs', 'basis');
  const src = fs.readFileSync(path.join(dir, 'basis_transcoder.js'), 'utf8');
  // An emscripten UMD script: give it the CommonJS names it looks for.
  const factory = new Function('require', '__filename', '__dirname', `${src}\nreturn BASIS;`)(
    createRequire(import.meta.url), path.join(dir, 'basis_transcoder.js'), dir);
  return factory({ wasmBinary: fs.readFileSync(path.join(dir, 'basis_transcoder.wasm')) });
}

// Minimal PNG decoder: 8/16-bit RGBA, non-interlaced (what the baker writes).
function decodePng(bytes) {
  let at = 8, width = 0, height = 0, depth = 8, channels = 4;
  const idat = [];
  while (at < bytes.length) {
    const len = bytes.readUInt32BE(at), type = bytes.toString('ascii', at + 4, at + 8);
    const data = bytes.subarray(at + 8, at + 8 + len);
    if (type === 'IHDR') {
      width = data.readUInt32BE(0); height = data.readUInt32BE(4); depth = data[8];
      channels = { 6: 4, 2: 3, 0: 1, 4: 2 }[data[9]];
    } else if (type === 'IDAT') {
      idat.push(data);
    }
    at += 12 + len;
  }
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const bpp = channels * depth / 8, stride = width * bpp;
  const out = Buffer.alloc(stride * height);
  for (let y = 0; y < height; ++y) {
    const filter = raw[y * (stride + 1)];
    const src = y * (stride + 1) + 1, dst = y * stride, prev = dst - stride;
    for (let x = 0; x < stride; ++x) {
      const a = x >= bpp ? out[dst + x - bpp] : 0, b = y > 0 ? out[prev + x] : 0;
      const c = x >= bpp && y > 0 ? out[prev + x - bpp] : 0;
      let p = raw[src + x];
      if (filter === 1) p += a;
      else if (filter === 2) p += b;
      else if (filter === 3) p += (a + b) >> 1;
      else if (filter === 4) {
        const pa = Math.abs(b - c), pb = Math.abs(a - c), pc = Math.abs(a + b - 2 * c);
        p += pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      out[dst + x] = p & 255;
    }
  }
  return { width, height, pixels: out };
}

function median(times) {
  const s = [...times].sort((a, b) => a - b);
  return s[Math.floor(s.length / 2)];
}

function timeIt(fn) {
  fn();  // warm-up
  const times = [];
  for (let i = 0; i < repeat; ++i) {
    const t0 = process.hrtime.bigint();
    fn();
    times.push(Number(process.hrtime.bigint() - t0) / 1e6);
  }
  return median(times);
}

const M = await loadTranscoder();
M.initializeBasis();
const formats = { bc7: M.transcoder_texture_format.cTFBC7_RGBA.value, astc: M.transcoder_texture_format.cTFASTC_4x4_RGBA.value };

function transcodeAll(bytes, format) {
  const f = new M.KTX2File(new Uint8Array(bytes));
  if (!f.isValid() || !f.startTranscoding()) throw new Error('not a transcodable KTX2 file');
  let total = 0;
  for (let level = 0; level < f.getLevels(); ++level) {
    const dst = new Uint8Array(f.getImageTranscodedSizeInBytes(level, 0, 0, format));
    if (!f.transcodeImage(dst, level, 0, 0, format, 0, -1, -1)) throw new Error(`level ${level} failed`);
    total += dst.length;
  }
  f.close();
  f.delete();
  return total;
}

const rows = [];
let pngBytes = 0, ktx2Bytes = 0, pngMs = 0, bc7Ms = 0, astcMs = 0;
for (const map of ['albedo_alpha', 'normal_depth', 'orm']) {
  const png = fs.readFileSync(path.join(pngDir, `${map}.png`));
  const ktx2 = fs.readFileSync(path.join(ktx2Dir, `${map}.ktx2`));
  const tPng = timeIt(() => decodePng(png));
  const tBc7 = timeIt(() => transcodeAll(ktx2, formats.bc7));
  const tAstc = timeIt(() => transcodeAll(ktx2, formats.astc));
  rows.push({ map, png_bytes: png.length, ktx2_bytes: ktx2.length, size_ratio: +(ktx2.length / png.length).toFixed(3),
              png_decode_ms: +tPng.toFixed(1), ktx2_to_bc7_ms: +tBc7.toFixed(1), ktx2_to_astc_ms: +tAstc.toFixed(1),
              bc7_time_ratio: +(tBc7 / tPng).toFixed(3), astc_time_ratio: +(tAstc / tPng).toFixed(3) });
  pngBytes += png.length; ktx2Bytes += ktx2.length; pngMs += tPng; bc7Ms += tBc7; astcMs += tAstc;
}
// depth.ktx2 (depth alone, for the pixel depth offset) has no PNG
// counterpart: it counts on the KTX2 side only.
const depthFile = path.join(ktx2Dir, 'depth.ktx2');
if (fs.existsSync(depthFile)) {
  const depth = fs.readFileSync(depthFile);
  const tBc7 = timeIt(() => transcodeAll(depth, formats.bc7));
  const tAstc = timeIt(() => transcodeAll(depth, formats.astc));
  rows.push({ map: 'depth (ktx2 only)', png_bytes: 0, ktx2_bytes: depth.length, ktx2_to_bc7_ms: +tBc7.toFixed(1),
              ktx2_to_astc_ms: +tAstc.toFixed(1) });
  ktx2Bytes += depth.length; bc7Ms += tBc7; astcMs += tAstc;
}
console.table(rows);
console.log(JSON.stringify({ png_bytes: pngBytes, ktx2_bytes: ktx2Bytes, size_ratio: +(ktx2Bytes / pngBytes).toFixed(3),
  decode_ratio_bc7: +(bc7Ms / pngMs).toFixed(3), decode_ratio_astc: +(astcMs / pngMs).toFixed(3), repeat }));
