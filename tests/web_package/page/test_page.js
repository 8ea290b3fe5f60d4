// The browser test's page: loads an asset from a published release with
// impostor-three and draws, from fixed cameras, the reference object (the
// synthetic box as three.js geometry, or a glTF given by ?reference=URL) and
// its impostor (ImpostorMesh), then a forest of ?count= instances as
// references and as one InstancedImpostorMesh, then 10,000 instances for the
// draw-call count. window.impostorTest resolves to the outcome:
//   {ok, error, key, layout, files: [{name, sha256, verified, source, url}],
//    views: [{camera, mesh, impostor}], forest: {mesh, impostor, calls},
//    bigForest: {count, calls, ms}, loadMs, blankAfterError}
// where mesh / impostor name an image in window.impostorImages (RGBA8
// base64, rows bottom first), fetched one by one (one reply of them all
// would be megabytes).
// A glTF reference is drawn unlit (its base colour), as the atlas holds it.
// Query: mirrors=URL,URL channel= name= count= size= cameras=AZ,EL;AZ,EL
//        cache=NAME (the Cache Storage cache) reference=box|URL
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { ImpostorLoader, ImpostorMesh, InstancedImpostorMesh } from 'impostor-three';
import { BOX, FACE_COLOURS } from '/lib/box_model.mjs';

const q = new URLSearchParams(location.search);
const SIZE = Number(q.get('size') || 256);
const COUNT = Number(q.get('count') || 16);
const BIG_COUNT = 10000;
// Eight cameras between the baked frames, around and above and below (above
// only, mirrored, for an upper-hemisphere layout).
const CAMERAS = (q.get('cameras') || '35,20;80,-25;125,40;170,5;210,-15;255,30;300,65;345,-50').split(';')
  .map((s) => s.split(',').map(Number));

function base64(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

window.impostorImages = {};
function keep(name, rgba) {
  window.impostorImages[name] = base64(rgba);
  return name;
}

function readPixels(renderer) {
  const gl = renderer.getContext();
  const out = new Uint8Array(SIZE * SIZE * 4);
  gl.readPixels(0, 0, SIZE, SIZE, gl.RGBA, gl.UNSIGNED_BYTE, out);
  return out;
}

// The baked albedo, unlit, with the baker's coverage rules (OPAQUE covered,
// MASK at its cutoff, BLEND at 0.5: common/manifest_format.md).
function unlit(m) {
  return new THREE.MeshBasicMaterial({
    map: m.map || null, color: m.color ? m.color.clone() : new THREE.Color(1, 1, 1), vertexColors: m.vertexColors,
    alphaTest: m.alphaTest > 0 ? m.alphaTest : m.transparent ? 0.5 : 0, side: m.side,
  });
}

async function referenceObject() {
  const ref = q.get('reference') || 'box';
  if (ref !== 'box') {
    const scene = (await new GLTFLoader().loadAsync(ref)).scene;
    scene.traverse((o) => {
      if (o.isMesh) o.material = Array.isArray(o.material) ? o.material.map(unlit) : unlit(o.material);
    });
    return scene;
  }
  const geometry = new THREE.BoxGeometry(2 * BOX.half[0], 2 * BOX.half[1], 2 * BOX.half[2]);
  geometry.translate(...BOX.center);
  const materials = ['+x', '-x', '+y', '-y', '+z', '-z'].map((f) => new THREE.MeshBasicMaterial({
    color: new THREE.Color().setRGB(...FACE_COLOURS[f].map((v) => v / 255), THREE.SRGBColorSpace),
  }));
  return new THREE.Mesh(geometry, materials);
}

// The camera at azimuth/elevation degrees, `distance` from `target`.
function place(camera, target, az, el, distance) {
  const a = THREE.MathUtils.degToRad(az), e = THREE.MathUtils.degToRad(el);
  camera.position.copy(target).add(new THREE.Vector3(Math.sin(a) * Math.cos(e), Math.sin(e), Math.cos(a) * Math.cos(e))
    .multiplyScalar(distance));
  camera.lookAt(target);
  camera.updateMatrixWorld();
}

// Instance i of a forest: a grid, each turned and scaled differently.
function forestMatrix(i, count, spacing) {
  const side = Math.ceil(Math.sqrt(count));
  const x = (i % side) - (side - 1) / 2, z = Math.floor(i / side) - (side - 1) / 2;
  const s = 0.8 + 0.4 * ((i * 7) % 5) / 4;
  return new THREE.Matrix4().compose(new THREE.Vector3(x * spacing, 0, z * spacing),
    new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(0, 1, 0), THREE.MathUtils.degToRad(i * 37)),
    new THREE.Vector3(s, s, s));
}

// What the page is doing, for a driver whose wait ran out.
const stage = (name) => { window.impostorTestStage = name; };

async function run() {
  stage('start');
  const out = { ok: false, error: '', files: [], views: [], blankAfterError: null };
  const canvas = document.getElementById('view');
  canvas.width = canvas.height = SIZE;
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: true, premultipliedAlpha: false,
    preserveDrawingBuffer: true });
  renderer.setClearColor(0x000000, 0);
  renderer.clear();
  let asset;
  const t0 = performance.now();
  try {
    const loader = new ImpostorLoader().setMirrors(q.get('mirrors').split(',')).setChannel(q.get('channel'));
    if (q.get('cache')) loader.setCacheName(q.get('cache'));
    stage('load');
    asset = await loader.loadAsync(q.get('name'));
  } catch (e) {
    out.error = String(e && e.message ? e.message : e);
    // Nothing was drawn: the canvas is still the clear colour.
    out.blankAfterError = readPixels(renderer).every((v) => v === 0);
    return out;
  }
  out.loadMs = performance.now() - t0;
  out.key = asset.key;
  out.layout = asset.layoutName;
  out.files = asset.files;
  const centre = asset.boundingSphere.center, radius = asset.boundingSphere.radius;

  const camera = new THREE.PerspectiveCamera(30, 1, radius * 0.05, radius * 400);
  const meshScene = new THREE.Scene();
  const reference = await referenceObject();
  meshScene.add(reference);
  const impostorScene = new THREE.Scene();
  const impostor = new ImpostorMesh(asset, { output: 'albedo' });
  impostorScene.add(impostor);
  const draw = (scene) => {
    renderer.clear();
    renderer.render(scene, camera);
    return readPixels(renderer);
  };
  stage('views');
  for (const [az, el0] of CAMERAS) {
    const el = asset.layoutName === 'hemi-octahedral' ? Math.abs(el0) : el0;
    place(camera, centre, az, el, 4 * radius);
    const name = `view_${az}_${el}`;
    out.views.push({ camera: [az, el], mesh: keep(`${name}_mesh`, draw(meshScene)), impostor: keep(`${name}_impostor`, draw(impostorScene)) });
  }

  stage('forest');
  // The forest: references one by one, impostors as one instanced draw.
  const spacing = 2.5 * radius;
  const forestMeshes = new THREE.Scene();
  const forest = new InstancedImpostorMesh(asset, COUNT, { output: 'albedo' });
  for (let i = 0; i < COUNT; ++i) {
    const m = forestMatrix(i, COUNT, spacing);
    forest.setMatrixAt(i, m);
    const r = reference.clone();
    r.applyMatrix4(m);
    forestMeshes.add(r);
  }
  forest.computeBoundingSphere();
  const forestScene = new THREE.Scene();
  forestScene.add(forest);
  const extent = Math.ceil(Math.sqrt(COUNT)) * spacing;
  place(camera, centre, 20, 35, 1.6 * extent + 4 * radius);
  const forestImpostors = draw(forestScene);
  out.forest = { mesh: keep('forest_mesh', draw(forestMeshes)), impostor: keep('forest_impostor', forestImpostors) };
  renderer.render(forestScene, camera);
  out.forest.calls = renderer.info.render.calls;

  stage('10,000 instances');
  // 10,000 instances: the draw calls one frame takes, and its time, in a
  // 64 x 64 corner (the call count does not depend on the size; SwiftShader's
  // fragment work does).
  renderer.setViewport(0, 0, 64, 64);
  const big = new InstancedImpostorMesh(asset, BIG_COUNT, { output: 'albedo' });
  for (let i = 0; i < BIG_COUNT; ++i) big.setMatrixAt(i, forestMatrix(i, BIG_COUNT, spacing));
  big.computeBoundingSphere();
  const bigScene = new THREE.Scene();
  bigScene.add(big);
  const bigExtent = Math.ceil(Math.sqrt(BIG_COUNT)) * spacing;
  place(camera, centre, 20, 35, 1.6 * bigExtent);
  const times = [];
  let calls = 0;
  for (let k = 0; k < 3; ++k) {
    const s = performance.now();
    renderer.render(bigScene, camera);
    calls = renderer.info.render.calls;
    readPixels(renderer);  // waits for the frame
    times.push(performance.now() - s);
  }
  renderer.setViewport(0, 0, SIZE, SIZE);
  times.sort((a, b) => a - b);
  out.bigForest = { count: BIG_COUNT, calls, ms: times[1], pixels: 64 * 64 };
  out.ok = true;
  stage('done');
  return out;
}

window.impostorTest = run().catch((e) => ({ ok: false, error: `page: ${e && e.stack ? e.stack : e}`, files: [], views: [] }));
