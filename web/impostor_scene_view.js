// ?scene=AZ,EL,DIST&size=N on the result page: the mesh or its impostor
// (the impostor-three package's ImpostorMesh: the reference material, lit,
// pixel depth offset, its own shadow caster) in one three.js scene with a
// ground plane 0.3 radii below the centre that receives their shadow from
// one directional light, camera AZ/EL degrees at DIST radii. Toggles:
// object, lit, depth offset, ground, shadows. &reconstruction=depth (the
// default) | parallax | plain.
// Test hook: window.impostorScene.render({object: 'mesh'|'impostor'|'none',
// ground, depthOffset, lit, shadows, shadowAlphaTest, mask}) -> PNG data URL
// (mask 1: objects white, rest black; 2: the impostor's world normal * 0.5 +
// 0.5; 3: its occlusion/roughness/metalness; 4: the lit ground alone, the
// object drawing nothing but its shadow). .light: the light's uniforms.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DEFAULT_LIGHT_DIRECTION, ImpostorMesh } from 'impostor-three';
import { loadResultAsset } from './impostor_view.js';

// The reference light (impostor_material_light.glsl's, as the example
// scene's): the sun's direction, white, ambient 0.25.
const DEFAULT_LIGHT = { towardLight: DEFAULT_LIGHT_DIRECTION.clone(), colour: [1, 1, 1], ambient: 0.25 };

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
  renderer.shadowMap.enabled = true;
  renderer.shadowMap.type = THREE.PCFShadowMap;
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x000000);
  // Black under the masks (tests compare silhouettes), lit grey otherwise.
  const groundMask = new THREE.MeshBasicMaterial({ color: 0x000000, side: THREE.DoubleSide });
  const groundLit = new THREE.MeshLambertMaterial({ color: 0xffffff, side: THREE.DoubleSide });
  const ground = new THREE.Mesh(new THREE.PlaneGeometry(radius * 200, radius * 200), groundLit);
  ground.rotation.x = -Math.PI / 2;
  ground.position.set(centre.x, centre.y - 0.3 * radius, centre.z);
  ground.receiveShadow = true;
  scene.add(ground);
  // The mesh lit like the impostor: a directional light along the same
  // direction plus ambient (three.js's Lambert), or flat white as a mask.
  const mesh = (await new GLTFLoader().loadAsync(meshUrl)).scene;
  const white = new THREE.MeshBasicMaterial({ color: 0xffffff, side: THREE.DoubleSide });
  // Draws nothing in the camera's view; the shadow pass still draws the object.
  const hidden = new THREE.MeshBasicMaterial({ colorWrite: false, depthWrite: false, shadowSide: THREE.DoubleSide });
  const meshMaterials = new Map();
  mesh.traverse((o) => {
    if (o.isMesh) {
      meshMaterials.set(o, o.material);
      o.castShadow = true;
      // The nearest surface to the light casts, whichever way it faces, as
      // the impostor's caster records it (three's default records back
      // faces: a mesh the ground cuts would then cast nothing over its
      // own footprint).
      for (const material of [o.material].flat()) material.shadowSide = THREE.DoubleSide;
    }
  });
  scene.add(mesh);
  // The sun, with an orthographic shadow camera around the bounding sphere
  // and the part of the ground its shadow can reach.
  const sun = new THREE.DirectionalLight(0xffffff, 1.0);
  sun.position.copy(centre).addScaledVector(DEFAULT_LIGHT.towardLight, 4 * radius);
  sun.target.position.copy(centre);
  sun.castShadow = true;
  sun.shadow.mapSize.set(2048, 2048);
  Object.assign(sun.shadow.camera, { left: -2.5 * radius, right: 2.5 * radius, top: 2.5 * radius,
    bottom: -2.5 * radius, near: 0.5 * radius, far: 10 * radius });
  sun.shadow.camera.updateProjectionMatrix();
  sun.shadow.bias = -0.0005;
  scene.add(sun, sun.target, new THREE.AmbientLight(0xffffff, DEFAULT_LIGHT.ambient));
  const reconstruction = new URLSearchParams(location.search).get('reconstruction') || 'depth';
  const card = new ImpostorMesh(await loadResultAsset(m, fileUrl), {
    reconstruction, lightDirection: DEFAULT_LIGHT.towardLight, lightColor: new THREE.Color(...DEFAULT_LIGHT.colour),
    ambient: DEFAULT_LIGHT.ambient,
  });
  card.castShadow = true;
  scene.add(card);
  const material = card.material;

  const state = { object: 'impostor', ground: true, depthOffset: true, lit: true, shadows: true,
    shadowAlphaTest: true, mask: 0 };
  const render = (overrides = {}) => {
    Object.assign(state, overrides);
    mesh.visible = state.object === 'mesh';
    card.visible = state.object === 'impostor';
    ground.visible = state.ground;
    ground.material = state.mask === 0 || state.mask === 4 ? groundLit : groundMask;
    sun.castShadow = state.shadows;
    const mask = state.mask === 4 ? 0 : state.mask;
    material.output = mask === 1 ? 'coverage' : mask === 2 ? 'normal' : mask === 3 ? 'orm' : state.lit ? 'lit' : 'albedo';
    material.depthOffset = state.depthOffset;
    material.depthMaterial.coverageTest = state.shadowAlphaTest;
    material.colorWrite = material.depthWrite = state.mask !== 4;
    mesh.traverse((o) => {
      if (o.isMesh) o.material = state.mask === 1 ? white : state.mask === 4 ? hidden : meshMaterials.get(o);
    });
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
  for (const o of ['impostor', 'mesh', 'none']) select.append(new Option(o, o));
  select.addEventListener('change', () => render({ object: select.value }));
  controls.append(select);
  toggle('lit', 'lit');
  toggle('depthOffset', 'depth offset');
  toggle('ground', 'ground');
  toggle('shadows', 'shadows');
  canvas.parentElement.prepend(controls);

  render();
  window.impostorScene = { render, frames: m.frames,
    light: { toward: DEFAULT_LIGHT.towardLight.toArray(), colour: DEFAULT_LIGHT.colour, ambient: DEFAULT_LIGHT.ambient } };
  document.body.dataset.viewerReady = '1';
}
