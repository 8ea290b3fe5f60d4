// One result: the 3D viewer (the original mesh with three.js beside the
// impostor drawn by the runtime shader, one orbit camera for both), the
// quality block with the worst view, every map and the manifest.
// The impostor is drawn by the impostor-three package (impostor_view.js),
// in the depth-aware reconstruction by default (what the quality pass
// measures).
// ?camera=AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_IN_RADII fixes the camera (tests);
// ?mask=1 draws the mesh as a white silhouette (tests); ?blend=0|1 picks the
// blend mode; ?reconstruction=depth|parallax|plain the reconstruction;
// ?compare=ab&split=F opens the A/B split (viewer_debug.js, with the atlas
// panel of the active frames).
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { getJson, el, replace, reportError, bytes } from './common.js';
import { layoutName, productName } from 'impostor-three';
import { createImpostorView } from './impostor_view.js';
import { attachDebugViews } from './viewer_debug.js';
import { showScene } from './impostor_scene_view.js';
import { isTextureArray } from './texture_array.js';
import { lodChainLevelNote, noViewerNote, productQuality } from './product_info.js';

const key = decodeURIComponent(location.pathname.split('/').pop());
const fileUrl = (name) => `/api/v1/results/${key}/files/${encodeURIComponent(name)}`;

function kv(pairs) {
  const dl = el('dl', { class: 'kv' });
  for (const [k, v] of pairs) dl.append(el('dt', {}, k), el('dd', {}, v instanceof Node ? v : String(v)));
  return dl;
}

// Files a product has besides its maps (cards.glb, surfels.bin/.ply).
function productFiles(m) {
  const files = [];
  if (m.cards && m.cards.file) files.push([m.cards.file, 'cards', m.cards.digest]);
  if (m.surfels && m.surfels.file) files.push([m.surfels.file, 'surfels', m.surfels.digest]);
  if (m.surfels && m.surfels.ply_file) files.push([m.surfels.ply_file, 'surfels (PLY)', m.surfels.ply_digest]);
  return files;
}

function showStatic(result) {
  const m = result.manifest;
  document.getElementById('title').textContent = key;
  const q = m.quality;
  const quality = q && q.views ? [
    ['blend', q.blend], ['held-out views', q.views],
    ['silhouette IoU (min / mean)', `${q.silhouette_iou_min.toFixed(4)} / ${q.silhouette_iou_mean.toFixed(4)}`],
    ['reconstruction', q.reconstruction || 'plain'],
    ['albedo PSNR dB where both cover (min / mean)', `${(q.albedo_psnr_shared_db_min ?? 0).toFixed(2)} / ${(q.albedo_psnr_shared_db_mean ?? 0).toFixed(2)}`],
    ['albedo SSIM where both cover (min / mean)', `${(q.albedo_ssim_shared_min ?? 0).toFixed(4)} / ${(q.albedo_ssim_shared_mean ?? 0).toFixed(4)}`],
    ['silhouette boundary error px (mean / max)', `${(q.boundary_error_px_mean ?? 0).toFixed(2)} / ${(q.boundary_error_px_max ?? 0).toFixed(2)}`],
    ['albedo PSNR dB over the union, over black (mean)', (q.albedo_psnr_union_db_mean ?? q.albedo_psnr_db_mean ?? 0).toFixed(2)],
    ['normal error deg (mean / max)', `${q.normal_error_deg_mean.toFixed(2)} / ${q.normal_error_deg_max.toFixed(2)}`],
    ['depth error (mean / max)', `${q.depth_error_mean.toFixed(4)} / ${q.depth_error_max.toFixed(4)}`],
    ['pop (one sample a pixel)', q.pop.toFixed(3)],
    ...(q.pop_antialiased ? [['pop antialiased (3 x 3, the figure targets use)', q.pop_antialiased.toFixed(3)]] : []),
    ...(q.sizes && q.sizes.length ? [['good for', q.good_up_to_pixels
      ? `up to ${q.good_up_to_pixels} px on screen (switch to the impostor below it)`
      : `no measured size (${q.sizes[0].pixels}..${q.sizes[q.sizes.length - 1].pixels} px)`]] : []),
    ['worst view', q.worst_view]] : productQuality(m) || [['quality pass', 'not run for this bake']];
  replace('quality', kv(quality));
  const maps = el('div', { class: 'maps' });
  for (const map of m.maps) {
    if (map.semantic.startsWith('quality_view')) continue;  // per-view files: views.json
    if (map.file.endsWith('.ktx2')) {  // no <img> for KTX2: a download link with its codec and mip levels
      maps.append(el('figure', {}, el('a', { href: fileUrl(map.file), 'data-testid': `map-${map.semantic}` }, map.file),
        el('figcaption', {}, `${map.semantic} ${map.width}×${map.height} ${map.codec || 'KTX2'}, ${map.levels || 1} levels (${bytes(map.digest.size_bytes)})`)));
      continue;
    }
    if (!map.file.endsWith('.png')) {  // meshes, point buffers: a download link
      maps.append(el('figure', {}, el('a', { href: fileUrl(map.file), 'data-testid': `map-${map.semantic}` }, map.file),
        el('figcaption', {}, `${map.semantic} (${bytes(map.digest.size_bytes)})`)));
      continue;
    }
    maps.append(el('figure', {}, el('img', { src: fileUrl(map.file), alt: map.semantic, 'data-testid': `map-${map.semantic}` }),
      el('figcaption', {}, `${map.semantic} ${map.width}×${map.height} ${map.format} (${bytes(map.digest.size_bytes)})`)));
  }
  const listed = new Set(m.maps.map((map) => map.file));
  for (const [file, what, digest] of productFiles(m)) {
    if (listed.has(file)) continue;
    maps.append(el('figure', {}, el('a', { href: fileUrl(file), 'data-testid': `file-${file}` }, file),
      el('figcaption', {}, digest ? `${what} (${bytes(digest.size_bytes)})` : what)));
  }
  replace('maps', maps);
  replace('manifest', kv([['product', productName(m.product)], ['layout', layoutName(m.layout)], ['frames', m.frames], ['resolution', m.resolution],
    ['tile size', m.tile_size], ['device', m.device], ['baker', m.baker_version], ['triangles', m.mesh.triangles],
    ['bake seconds', m.timings.total_seconds.toFixed(2)], ['pinned', result.pinned],
    ['source job', result.job_id ? el('a', { href: `/jobs/${result.job_id}` }, result.job_id) : '—'],
    ['manifest.json', el('a', { href: fileUrl('manifest.json') }, 'download')]]));
}

async function meshUrl(result) {
  const job = await getJson(`/api/v1/jobs/${encodeURIComponent(result.job_id)}`);
  return `/api/v1/jobs/${encodeURIComponent(result.job_id)}/mesh/${job.mesh.entry.path.split('/').map(encodeURIComponent).join('/')}`;
}

async function loadMesh(result) {
  const gltf = await new GLTFLoader().loadAsync(await meshUrl(result));
  return gltf.scene;
}

async function showViewer(result) {
  const m = result.manifest;
  const meshCanvas = document.getElementById('mesh');
  const impostorCanvas = document.getElementById('impostor');
  const centre = new THREE.Vector3(...m.bounding_sphere.center);
  const radius = m.bounding_sphere.radius;
  const camera = new THREE.PerspectiveCamera(30, 1, radius * 0.05, radius * 100);
  const fixed = new URLSearchParams(location.search).get('camera');
  const [az, elev, dist] = fixed ? fixed.split(',').map(Number) : [35, 20, 4];
  const a = THREE.MathUtils.degToRad(az), e = THREE.MathUtils.degToRad(elev);
  camera.position.copy(centre).add(new THREE.Vector3(Math.sin(a) * Math.cos(e), Math.sin(e), Math.cos(a) * Math.cos(e)).multiplyScalar(dist * radius));
  camera.lookAt(centre);

  const renderer = new THREE.WebGLRenderer({ canvas: meshCanvas, antialias: true, preserveDrawingBuffer: true });
  const scene = new THREE.Scene();
  scene.add(new THREE.HemisphereLight(0xffffff, 0x444444, 2.0));
  const sun = new THREE.DirectionalLight(0xffffff, 1.5);
  sun.position.set(1, 2, 1.5);
  scene.add(sun);
  document.body.dataset.viewerStage = 'mesh';
  scene.add(await loadMesh(result));
  // ?mask=1: the mesh flat white on black (tests compare its silhouette with
  // the impostor's coverage, e.g. to catch a mirrored impostor).
  if (new URLSearchParams(location.search).get('mask') === '1') {
    scene.overrideMaterial = new THREE.MeshBasicMaterial({ color: 0xffffff, side: THREE.DoubleSide });
  }
  document.body.dataset.viewerStage = 'impostor';
  const impostor = await createImpostorView(impostorCanvas, m, fileUrl);
  document.getElementById('frames').textContent = `${layoutName(m.layout)}, ${m.frames}×${m.frames} frames, tile ${m.tile_size} px`
    + (isTextureArray(m) ? `; texture array of ${m.views.length} layers, layer i = frame i` : '')
    + (lodChainLevelNote(m) ? `. ${lodChainLevelNote(m)}` : '');
  if (isTextureArray(m)) {
    document.getElementById('atlas-caption').textContent = 'albedo texture-array layers, each at its frame\'s atlas tile';
  }

  const blendParam = new URLSearchParams(location.search).get('blend');
  if (blendParam !== null) impostor.options.blend = Number(blendParam);
  impostor.options.reconstruction = new URLSearchParams(location.search).get('reconstruction') || 'depth';
  let debug = null;
  const draw = () => {
    camera.updateMatrixWorld();
    renderer.render(scene, camera);
    impostor.render(camera);
    if (debug) debug.afterDraw();
  };
  debug = await attachDebugViews({ manifest: m, fileUrl, impostor, camera, centre, radius, meshCanvas, impostorCanvas, redraw: draw });
  // One camera for every canvas (the A/B canvas registered its line drag first).
  for (const canvas of [meshCanvas, impostorCanvas, debug.abCanvas]) {
    const c = new OrbitControls(camera, canvas);
    // The constructor aimed the camera at the origin (its default target):
    // aim it at the model again, or a tree whose pivot is at its foot shows
    // in the top half of the view and jumps on the first drag.
    c.target.copy(centre);
    c.update();
    c.addEventListener('change', draw);
  }
  for (const [id, apply] of [['blend', (v) => { impostor.options.blend = Number(v); }],
    ['reconstruction', (v) => { impostor.options.reconstruction = v; }],
    ['debug', (v) => { impostor.options.debug = Number(v); }]]) {
    const select = document.getElementById(id);
    if (id === 'blend') select.value = String(impostor.options.blend);
    if (id === 'reconstruction') select.value = impostor.options.reconstruction;
    select.addEventListener('change', () => { apply(select.value); draw(); });
  }
  draw();
  document.body.dataset.viewerReady = '1';
}

// ?ortho=AZ,EL&size=N: only the impostor, orthographic along that direction
// into an N x N canvas, exposed as window.impostorPng (tests compare it with
// the CPU reference renderer). Here the reconstruction is plain unless
// &reconstruction= says otherwise: the tests' figures for this view were
// measured so.
async function showOrthographic(result, spec, size) {
  const [az, elev] = spec.split(',').map((v) => THREE.MathUtils.degToRad(Number(v)));
  const canvas = document.getElementById('impostor');
  canvas.width = canvas.height = size;
  canvas.style.width = canvas.style.height = `${size}px`;
  const impostor = await createImpostorView(canvas, result.manifest, fileUrl);
  const blend = new URLSearchParams(location.search).get('blend');
  if (blend !== null) impostor.options.blend = Number(blend);
  impostor.options.reconstruction = new URLSearchParams(location.search).get('reconstruction') || 'plain';
  impostor.renderOrthographic([Math.sin(az) * Math.cos(elev), Math.sin(elev), Math.cos(az) * Math.cos(elev)]);
  window.impostorPng = canvas.toDataURL('image/png');
  document.body.dataset.viewerReady = '1';
}

async function main() {
  document.body.dataset.viewerStage = 'start';
  const result = await getJson(`/api/v1/results/${key}`);
  showStatic(result);
  const query = new URLSearchParams(location.search);
  if (query.get('ortho')) {
    await showOrthographic(result, query.get('ortho'), Number(query.get('size') || 128));
  } else if (query.get('scene')) {
    // The reference material in a three.js scene (impostor_scene_view.js).
    await showScene(result, fileUrl, await meshUrl(result), query.get('scene'), Number(query.get('size') || 256));
  } else if (['PRODUCT_ATLAS', 'PRODUCT_UNSPECIFIED', 'PRODUCT_LOD_CHAIN'].includes(result.manifest.product)) {
    // A LOD chain's top-level atlas fields and maps are its impostor level's.
    await showViewer(result);
  } else {
    // The viewer draws atlases; say so instead of showing empty canvases.
    const section = document.getElementById('mesh').closest('section');
    section.replaceChildren(el('h2', {}, '3D'),
      el('p', { class: 'muted', 'data-testid': 'no-viewer' }, noViewerNote(result.manifest)));
    document.body.dataset.viewerReady = 'n/a';
  }
}
main().catch((e) => reportError(String(e && e.stack ? e.stack : e)));
