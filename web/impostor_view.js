// The result page's impostor, drawn by the impostor-three package (packages/
// impostor-three, served from node_modules like three): its ImpostorMaterial
// runs shaders/impostor_runtime.glsl itself, so the viewer draws the very
// math the C++ reference renderer and the engines are tested against. The
// result's maps come from the farm's JSON API (fileUrl), each checked
// against the manifest's SHA-256 where the page has WebCrypto (https or
// localhost), and become an ImpostorAsset (ImpostorLoader.parseAsync).
import * as THREE from 'three';
import { DRAWN_SEMANTICS, ImpostorLoader, ImpostorMesh } from 'impostor-three';

// The debug select's values (result.html), as the material's outputs.
const DEBUG_OUTPUTS = ['albedo', 'frame-index', 'blend-weights', 'normal'];
const BLENDS = ['triangle3', 'bilinear4'];

// The maps the material draws, fetched and (where WebCrypto is there)
// verified; resolves to an ImpostorAsset.
export async function loadResultAsset(manifest, fileUrl) {
  const files = new Map();
  await Promise.all((manifest.maps || []).filter((m) => DRAWN_SEMANTICS.includes(m.semantic)).map(async (m) => {
    const url = fileUrl(m.file);
    const response = await fetch(url);
    if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
    files.set(m.file, new Uint8Array(await response.arrayBuffer()));
  }));
  return new ImpostorLoader().parseAsync(manifest, files, manifest.cache_key);
}

// Returns {asset, options: {blend: 0 | 1, reconstruction, debug: 0..3},
// layout: {kind, frames, ringViews} (as the shader gets it), render(camera),
// renderOrthographic(dir)}. `options` is read at every render.
export async function createImpostorView(canvas, manifest, fileUrl) {
  const asset = await loadResultAsset(manifest, fileUrl);
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: true, premultipliedAlpha: false,
    preserveDrawingBuffer: true });
  renderer.setClearColor(0x000000, 0);
  const scene = new THREE.Scene();
  const impostor = new ImpostorMesh(asset, { output: 'albedo' });
  scene.add(impostor);
  const options = { blend: BLENDS.indexOf(asset.blend), reconstruction: 'depth', debug: 0 };
  const { center, radius } = asset.boundingSphere;
  const ortho = new THREE.OrthographicCamera(-radius, radius, radius, -radius, 0.5 * radius, 4 * radius);
  const render = (camera) => {
    const m = impostor.material;
    m.blend = BLENDS[options.blend] || 'triangle3';
    m.reconstruction = options.reconstruction;
    m.output = DEBUG_OUTPUTS[options.debug] || 'albedo';
    renderer.setViewport(0, 0, canvas.width, canvas.height);
    renderer.render(scene, camera);
  };
  return {
    asset,
    options,
    layout: { kind: asset.layout.kind, frames: asset.layout.frames, ringViews: asset.layout.ringViews },
    render,
    // The orthographic view the CPU reference renderer draws
    // (RenderImpostorView): direction `dir` (unit, centre -> camera), the
    // view square framing the bounding sphere, rays parallel.
    renderOrthographic(dir) {
      ortho.position.copy(center).addScaledVector(new THREE.Vector3(...dir), 2 * radius);
      ortho.lookAt(center);
      ortho.updateMatrixWorld();
      render(ortho);
    },
  };
}
