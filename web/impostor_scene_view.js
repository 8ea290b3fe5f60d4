// ?scene=AZ,EL,DIST&size=N on the result page: the mesh or its impostor
// (impostor_material_three.js: lit, pixel depth offset) in one three.js
// scene with a ground plane 0.3 radii below the centre, camera AZ/EL degrees
// at DIST radii. Toggles: object, lit, depth offset, ground.
// Test hook: window.impostorScene.render({object: 'mesh'|'impostor', ground,
// depthOffset, lit, mask}) -> PNG data URL (mask 1: objects white, rest black;
// mask 2: the impostor's world normal * 0.5 + 0.5; 3: its occlusion/roughness/metalness). .light: the light's uniforms.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { createImpostorMaterialMesh, DEFAULT_LIGHT } from './impostor_material_three.js';

export async function showScene(result, fileUrl, meshUrl, spec, size) {
  const m = result.manifest;
  const [az, elev, dist] = spec.split(',').map(Number);
  // Bad input: a message naming the parameter and its limits, no NaN camera.
  if (![az, elev].every(Number.isFinite) || !(dist === undefined || (Number.isFinite(dist) && dist > 1))) {
    throw new Error(`scene=${spec}: want AZIMUTH_DEG,ELEVATION_DEG[,DISTANCE_RADII > 1]`);
  }
  if (!Number.isInteger(size) || size < 16 || size > 4096) throw new Error(`size=${size}: want an integer in 16..4096`);
  const centre = new THREE.Vector3(...m.bounding_sphere.center);
  const radius = m.bounding_sphere.radius;
  const canvas = document.getElementById('impostor');
  canvas.width = canvas.height = size;
  canvas.style.width = canvas.style.height = `${size}px`;
  const a = THREE.MathUtils.degToRad(az), e = THREE.MathUtils.degToRad(elev);
  const camera = new THREE.PerspectiveCamera(30, 1, radius * 0.05, radius * 100);
  camera.position.copy(centre).add(new THREE.Vector3(Math.sin(a) * Math.cos(e), Math.sin(e), Math.cos(a) * Math.cos(e))
    .multiplyScalar((dist || 4) * radius));
  camera.lookAt(centre);
  camera.updateMatrixWorld();

  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x000000);
  const ground = new THREE.Mesh(new THREE.PlaneGeometry(radius * 200, radius * 200),
    new THREE.MeshBasicMaterial({ color: 0x000000, side: THREE.DoubleSide }));
  ground.rotation.x = -Math.PI / 2;
  ground.position.set(centre.x, centre.y - 0.3 * radius, centre.z);
  scene.add(ground);
  // The mesh lit like the impostor: a directional light along the same
  // direction plus ambient (three.js's Lambert), or flat white as a mask.
  const mesh = (await new GLTFLoader().loadAsync(meshUrl)).scene;
  const white = new THREE.MeshBasicMaterial({ color: 0xffffff, side: THREE.DoubleSide });
  const meshMaterials = new Map();
  mesh.traverse((o) => { if (o.isMesh) meshMaterials.set(o, o.material); });
  scene.add(mesh);
  const sun = new THREE.DirectionalLight(0xffffff, 1.0);
  sun.position.copy(DEFAULT_LIGHT.towardLight);
  scene.add(sun, new THREE.AmbientLight(0xffffff, DEFAULT_LIGHT.ambient));
  const card = await createImpostorMaterialMesh(m, fileUrl);
  scene.add(card);
  const options = card.userData.options;

  const state = { object: 'impostor', ground: true, depthOffset: true, lit: true, mask: 0 };
  const render = (overrides = {}) => {
    Object.assign(state, overrides);
    mesh.visible = state.object === 'mesh';
    card.visible = state.object === 'impostor';
    ground.visible = state.ground;
    options.lit = state.lit;
    options.depthOffset = state.depthOffset;
    options.mask = state.mask;
    mesh.traverse((o) => { if (o.isMesh) o.material = state.mask === 1 ? white : meshMaterials.get(o); });
    renderer.render(scene, camera);
    return canvas.toDataURL('image/png');
  };

  // The viewer's toggles, next to the canvas.
  const controls = document.createElement('div');
  controls.id = 'scene-controls';
  const toggle = (key, label) => {
    const input = document.createElement('input');
    input.type = 'checkbox';
    input.id = `scene-${key}`;
    input.checked = state[key];
    input.addEventListener('change', () => render({ [key]: input.checked }));
    const l = document.createElement('label');
    l.append(input, ` ${label} `);
    controls.append(l);
  };
  const select = document.createElement('select');
  select.id = 'scene-object';
  for (const o of ['impostor', 'mesh']) select.append(new Option(o, o));
  select.addEventListener('change', () => render({ object: select.value }));
  controls.append(select);
  toggle('lit', 'lit');
  toggle('depthOffset', 'depth offset');
  toggle('ground', 'ground');
  canvas.parentElement.prepend(controls);

  render();
  window.impostorScene = { render, frames: m.frames,
    light: { toward: DEFAULT_LIGHT.towardLight.toArray(), colour: DEFAULT_LIGHT.colour, ambient: DEFAULT_LIGHT.ambient } };
  document.body.dataset.viewerReady = '1';
}
