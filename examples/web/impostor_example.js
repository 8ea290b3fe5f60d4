// impostor-three's example page: loads one asset by name from a published
// release (every file verified against the catalog's SHA-256, kept in Cache
// Storage), draws it from fixed cameras as the mesh it was baked from and as
// an ImpostorMesh, then a forest of `count` instances twice: as meshes and
// as one InstancedImpostorMesh (one draw call), timing frames of each.
//
// Query:
//   mirror=URL (repeatable) or mirrors=URL,URL  release roots (holding v1/), tried in order
//   channel=NAME (nightly)  name=ASSET           what to load
//   count=N (100)            forest instances
//   mesh=URL                 the glTF the asset was baked from (without it only impostors are drawn)
//   forestMesh=instanced|objects|none (instanced)  the mesh forest: one InstancedMesh per
//                            primitive (what a game would do), one object per tree, or none
//   reconstruction=depth|parallax|plain, depthOffset=0|1   the impostor material's
//                            (defaults: what the asset's quality pass measured, and on)
//   size=PX (512)            canvas side; cameras=AZ,EL;AZ,EL (degrees, 4 radii away);
//   views=0                  skip the fixed cameras; frames=N (5) timed frames per forest
//   cache=NAME               the Cache Storage cache (impostor-three's default otherwise)
//   fade=T                   also draw the first camera's impostor mid cross-fade: one
//                            InstancedImpostorMesh instance with crossFade, fade T, seed 5
//   images=1                 keep every frame read back in window.impostorExampleImages
//                            (RGBA8 base64, rows bottom first) for a test to fetch one by one
//
// Both are drawn unlit: the mesh with its base colour (with the baker's
// coverage rules: OPAQUE covered, MASK at its cutoff, BLEND at 0.5), the
// impostor with output 'albedo', so the two can be compared pixel for pixel.
//
// Outcome: window.impostorExample, a promise resolving to
//   {ok, error, name, channel, key, layout, loadMs,
//    files: [{name, semantic, sha256, verified, source ('network' | 'cache'), url}],
//    views: [{camera: [az, el], mesh, impostor}],        (image names, with images=1)
//    fade: {t, seed, image, whole} | null,   (the faded view and the whole one it is part of)
//    forest: {count, size, impostor: {calls, ms, frameMs: [...], image},
//             mesh: {mode, calls, ms, frameMs, image} | null, speedup},
//    blankAfterError}
// where ms is the median frame (render and wait for it: a 1-pixel readback),
// and blankAfterError says, after a refused load, that nothing was drawn.
// window.impostorExampleStage names what the page is doing.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { ImpostorLoader, ImpostorMesh, InstancedImpostorMesh } from 'impostor-three';

const q = new URLSearchParams(location.search);
const SIZE = Number(q.get('size') || 512);
const COUNT = Number(q.get('count') || 100);
const FRAMES = Math.max(1, Number(q.get('frames') || 5));
const FOREST_MESH = q.get('forestMesh') || 'instanced';
const KEEP_IMAGES = q.get('images') === '1';
// Between the baked frames of the usual grids, around, above and below
// (above only, mirrored, for an upper-hemisphere layout).
const CAMERAS = q.get('views') === '0' ? []
  : (q.get('cameras') || '35,20;80,-25;125,40;170,5;210,-15;255,30;300,65;345,-50').split(';')
    .map((s) => s.split(',').map(Number));
// The impostor material: unlit albedo, to compare with the unlit mesh.
const MATERIAL = { output: 'albedo', ...(q.get('reconstruction') ? { reconstruction: q.get('reconstruction') } : {}),
  ...(q.get('depthOffset') ? { depthOffset: q.get('depthOffset') !== '0' } : {}) };
const MIRRORS = [...q.getAll('mirror'), ...(q.get('mirrors') || '').split(',')].map((s) => s.trim()).filter(Boolean);

const stage = (name) => { window.impostorExampleStage = name; };
const report = (text) => { document.getElementById('report').textContent = text; };

function base64(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

window.impostorExampleImages = {};

// The frame just drawn: kept for a test (images=1) and shown as a thumbnail.
function keep(renderer, name) {
  const canvas = renderer.domElement;
  const img = document.createElement('img');
  img.src = canvas.toDataURL();
  img.title = name;
  document.getElementById('views').append(img);
  if (!KEEP_IMAGES) return null;
  window.impostorExampleImages[name] = base64(readPixels(renderer, SIZE));
  return name;
}

function readPixels(renderer, side) {
  const gl = renderer.getContext();
  const out = new Uint8Array(side * side * 4);
  gl.readPixels(0, 0, side, side, gl.RGBA, gl.UNSIGNED_BYTE, out);
  return out;
}

function unlit(m) {
  return new THREE.MeshBasicMaterial({
    map: m.map || null, color: m.color ? m.color.clone() : new THREE.Color(1, 1, 1), vertexColors: m.vertexColors,
    alphaTest: m.alphaTest > 0 ? m.alphaTest : m.transparent ? 0.5 : 0, side: m.side,
  });
}

async function loadMesh(url) {
  const scene = (await new GLTFLoader().loadAsync(url)).scene;
  scene.traverse((o) => {
    if (o.isMesh) o.material = Array.isArray(o.material) ? o.material.map(unlit) : unlit(o.material);
  });
  scene.updateMatrixWorld(true);
  return scene;
}

// The camera at azimuth / elevation degrees, `distance` from `target`.
function place(camera, target, az, el, distance) {
  const a = THREE.MathUtils.degToRad(az), e = THREE.MathUtils.degToRad(el);
  camera.position.copy(target).add(new THREE.Vector3(Math.sin(a) * Math.cos(e), Math.sin(e), Math.cos(a) * Math.cos(e))
    .multiplyScalar(distance));
  camera.lookAt(target);
  camera.updateMatrixWorld();
}

// Instance i of a forest: a square grid `spacing` apart, each tree turned
// about +Y and scaled a little.
function forestMatrix(i, count, spacing) {
  const side = Math.ceil(Math.sqrt(count));
  const x = (i % side) - (side - 1) / 2, z = Math.floor(i / side) - (side - 1) / 2;
  const s = 0.8 + 0.4 * ((i * 7) % 5) / 4;
  return new THREE.Matrix4().compose(new THREE.Vector3(x * spacing, 0, z * spacing),
    new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(0, 1, 0), THREE.MathUtils.degToRad(i * 37)),
    new THREE.Vector3(s, s, s));
}

// The mesh forest: per primitive of `mesh`, one InstancedMesh of `count`
// (instanced), or a clone of the whole mesh per tree (objects).
function meshForest(mesh, count, spacing, mode) {
  const group = new THREE.Group();
  const matrices = Array.from({ length: count }, (_, i) => forestMatrix(i, count, spacing));
  if (mode === 'objects') {
    for (const m of matrices) {
      const tree = mesh.clone();
      tree.applyMatrix4(m);
      group.add(tree);
    }
    return group;
  }
  mesh.traverse((o) => {
    if (!o.isMesh) return;
    const inst = new THREE.InstancedMesh(o.geometry, o.material, count);
    const local = o.matrixWorld;  // relative to the glTF scene's root
    matrices.forEach((m, i) => inst.setMatrixAt(i, new THREE.Matrix4().multiplyMatrices(m, local)));
    inst.computeBoundingSphere();
    group.add(inst);
  });
  return group;
}

// Draws `scene` once (shaders compiled, maps uploaded), then FRAMES timed
// frames; {calls, ms (median), frameMs}.
function timeFrames(renderer, scene, camera) {
  renderer.render(scene, camera);
  readPixels(renderer, 1);
  const frameMs = [];
  let calls = 0;
  for (let k = 0; k < FRAMES; ++k) {
    const t = performance.now();
    renderer.render(scene, camera);
    calls = renderer.info.render.calls;
    readPixels(renderer, 1);  // waits for the frame
    frameMs.push(performance.now() - t);
  }
  const sorted = [...frameMs].sort((a, b) => a - b);
  return { calls, ms: sorted[sorted.length >> 1], frameMs };
}

async function run() {
  stage('start');
  const out = { ok: false, error: '', name: q.get('name'), channel: q.get('channel') || 'nightly', files: [], views: [],
    fade: null, forest: null, blankAfterError: null };
  const canvas = document.getElementById('view');
  canvas.width = canvas.height = SIZE;
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: true, premultipliedAlpha: false,
    preserveDrawingBuffer: true });
  renderer.setClearColor(0x000000, 0);
  renderer.clear();
  let asset;
  const t0 = performance.now();
  try {
    if (!out.name) throw new Error('no ?name= (the asset to load)');
    if (!MIRRORS.length) throw new Error('no ?mirror= (a release root)');
    const loader = new ImpostorLoader().setMirrors(MIRRORS).setChannel(out.channel);
    if (q.get('cache')) loader.setCacheName(q.get('cache'));
    stage('load');
    asset = await loader.loadAsync(out.name);
  } catch (e) {
    out.error = String(e && e.message ? e.message : e);
    // Nothing was drawn: the canvas is still the clear colour.
    out.blankAfterError = readPixels(renderer, SIZE).every((v) => v === 0);
    report(`refused: ${out.error}`);
    return out;
  }
  out.loadMs = performance.now() - t0;
  out.key = asset.key;
  out.layout = asset.layoutName;
  out.files = asset.files;
  const centre = asset.boundingSphere.center, radius = asset.boundingSphere.radius;
  const mesh = q.get('mesh') ? await loadMesh(q.get('mesh')) : null;

  const camera = new THREE.PerspectiveCamera(30, 1, radius * 0.05, radius * 400);
  const meshScene = new THREE.Scene();
  if (mesh) meshScene.add(mesh);
  const impostorScene = new THREE.Scene();
  impostorScene.add(new ImpostorMesh(asset, MATERIAL));
  const draw = (scene, name) => {
    renderer.clear();
    renderer.render(scene, camera);
    return keep(renderer, name);
  };
  stage('views');
  for (const [az, el0] of CAMERAS) {
    const el = asset.layoutName === 'hemi-octahedral' ? Math.abs(el0) : el0;
    place(camera, centre, az, el, 4 * radius);
    const name = `view_${az}_${el}`;
    out.views.push({ camera: [az, el], mesh: mesh ? draw(meshScene, `${name}_mesh`) : null,
      impostor: draw(impostorScene, `${name}_impostor`) });
  }

  if (q.get('fade') && CAMERAS.length) {
    // The cross-fade at the LOD switch: the impostor's share of the first view.
    stage('fade');
    const [az, el0] = CAMERAS[0];
    place(camera, centre, az, asset.layoutName === 'hemi-octahedral' ? Math.abs(el0) : el0, 4 * radius);
    const fading = new InstancedImpostorMesh(asset, 1, { ...MATERIAL, crossFade: true });
    fading.setMatrixAt(0, new THREE.Matrix4());
    const t = Number(q.get('fade'));
    fading.setFadeAt(0, t, 5);
    const fadeScene = new THREE.Scene();
    fadeScene.add(fading);
    out.fade = { t, seed: 5, image: draw(fadeScene, 'fade_impostor'), whole: out.views[0].impostor };
  }

  stage('forest');
  const spacing = 2.5 * radius;
  const forest = new InstancedImpostorMesh(asset, COUNT, MATERIAL);
  for (let i = 0; i < COUNT; ++i) forest.setMatrixAt(i, forestMatrix(i, COUNT, spacing));
  forest.computeBoundingSphere();
  const forestScene = new THREE.Scene();
  forestScene.add(forest);
  const extent = Math.ceil(Math.sqrt(COUNT)) * spacing;
  const distance = 1.6 * extent + 4 * radius;
  camera.far = distance + 2 * extent + 4 * radius;
  camera.updateProjectionMatrix();
  place(camera, centre, 20, 35, distance);
  out.forest = { count: COUNT, size: SIZE, impostor: timeFrames(renderer, forestScene, camera), mesh: null };
  out.forest.impostor.image = keep(renderer, 'forest_impostor');
  if (mesh && FOREST_MESH !== 'none') {
    stage('mesh forest');
    const meshForestScene = new THREE.Scene();
    meshForestScene.add(meshForest(mesh, COUNT, spacing, FOREST_MESH));
    out.forest.mesh = { mode: FOREST_MESH, ...timeFrames(renderer, meshForestScene, camera) };
    out.forest.mesh.image = keep(renderer, 'forest_mesh');
    out.forest.speedup = out.forest.mesh.ms / out.forest.impostor.ms;
    // The impostors again, last on the canvas.
    renderer.render(forestScene, camera);
  }
  out.ok = true;
  stage('done');
  const f = out.forest;
  report([`${out.name} (${out.key}, ${out.layout}) from ${out.channel}, loaded in ${out.loadMs.toFixed(0)} ms`,
    ...out.files.map((x) => `  ${x.name} sha256 ${x.sha256} ${x.verified ? 'verified' : 'NOT VERIFIED'} (${x.source})`),
    `forest of ${f.count}: impostors ${f.impostor.ms.toFixed(1)} ms a frame in ${f.impostor.calls} draw call(s)`
      + (f.mesh ? `; meshes (${f.mesh.mode}) ${f.mesh.ms.toFixed(1)} ms in ${f.mesh.calls}: ${f.speedup.toFixed(1)}x` : ''),
  ].join('\n'));
  return out;
}

window.impostorExample = run().catch((e) => {
  report(`page: ${e && e.stack ? e.stack : e}`);
  return { ok: false, error: `page: ${e && e.stack ? e.stack : e}`, files: [], views: [] };
});
