// impostor-three as a package: the runtime it embeds is
// shaders/impostor_runtime.glsl byte for byte; `npm pack` works offline and
// ships every module and declaration its exports name; every name the
// entry points export is declared in the .d.ts files; and its three.js side
// (ImpostorMaterial, the meshes) behaves in Node.js with the dashboard's
// three (web/node_modules/three), no browser needed.
// Run: node --test tests/web_package/package_test.mjs
import assert from 'node:assert/strict';
import { execFileSync, spawnSync } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, symlinkSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { test } from 'node:test';

const here = dirname(fileURLToPath(import.meta.url));
const repo = resolve(here, '..', '..');
const pkg = join(repo, 'packages', 'impostor-three');
const threeDir = join(repo, 'web', 'node_modules', 'three');

test('the package embeds shaders/impostor_runtime.glsl unchanged', async () => {
  const { impostorRuntimeGlsl } = await import(join(pkg, 'src', 'shaders', 'impostor_runtime.glsl.js'));
  assert.ok(impostorRuntimeGlsl === readFileSync(join(repo, 'shaders', 'impostor_runtime.glsl'), 'utf8'),
    'stale: run node packages/impostor-three/scripts/embed_runtime.mjs');
});

test('npm pack works offline and ships what the exports name', () => {
  const dest = mkdtempSync(join(tmpdir(), 'impostor-three-pack-'));
  try {
    const out = execFileSync('npm', ['pack', '--offline', '--json', '--pack-destination', dest], {
      cwd: pkg, encoding: 'utf8', env: { ...process.env, npm_config_cache: join(dest, 'cache'), npm_config_update_notifier: 'false' },
    });
    const [report] = JSON.parse(out.slice(out.indexOf('[')));
    assert.ok(existsSync(join(dest, report.filename)), `no ${report.filename}`);
    const files = new Set(report.files.map((f) => f.path));
    const manifest = JSON.parse(readFileSync(join(pkg, 'package.json'), 'utf8'));
    const targets = [manifest.main, manifest.types];
    for (const entry of Object.values(manifest.exports)) {
      if (typeof entry === 'string') targets.push(entry);
      else targets.push(...Object.values(entry));
    }
    for (const t of targets) assert.ok(files.has(t.replace(/^\.\//, '')), `${t} is not in the tarball: ${[...files].join(', ')}`);
    for (const f of ['README.md', 'src/shaders/impostor_runtime.glsl.js', 'src/shaders/impostor_shaders.js']) {
      assert.ok(files.has(f), `${f} is not in the tarball`);
    }
    assert.ok(![...files].some((f) => f.startsWith('scripts/') || f.endsWith('.tgz')), 'build scripts shipped');
    assert.equal(manifest.peerDependencies.three, `~${JSON.parse(readFileSync(join(repo, 'web', 'package-lock.json'), 'utf8'))
      .packages['node_modules/three'].version}`, "three's peer range follows the dashboard's pin");
  } finally {
    rmSync(dest, { recursive: true, force: true });
  }
});

// Names exported by an entry point, following `export *` and `export {}` lists.
function exportedNames(file) {
  const text = readFileSync(file, 'utf8');
  const names = new Set();
  for (const m of text.matchAll(/export\s*\{([^}]*)\}/g)) {
    for (const part of m[1].split(',')) if (part.trim()) names.add(part.trim().split(/\s+as\s+/).pop());
  }
  for (const m of text.matchAll(/export\s+(?:async\s+)?(?:class|function|const|let)\s+([A-Za-z_$][\w$]*)/g)) names.add(m[1]);
  for (const m of text.matchAll(/export\s+\*\s+from\s+'([^']+)'/g)) {
    for (const n of exportedNames(resolve(dirname(file), m[1]))) names.add(n);
  }
  return names;
}

function declaredNames(file) {
  const text = readFileSync(file, 'utf8');
  const names = new Set();
  for (const m of text.matchAll(/export\s+(?:declare\s+)?(?:class|function|const|interface|type)\s+([A-Za-z_$][\w$]*)/g)) names.add(m[1]);
  for (const m of text.matchAll(/export\s+\*\s+from\s+'([^']+)'/g)) {
    for (const n of declaredNames(resolve(dirname(file), m[1]).replace(/\.js$/, '.d.ts'))) names.add(n);
  }
  return names;
}

test('every exported name is declared in the .d.ts files', () => {
  for (const [js, dts] of [['src/index.js', 'src/index.d.ts'], ['src/release/index.js', 'src/release/index.d.ts']]) {
    const declared = declaredNames(join(pkg, dts));
    const missing = [...exportedNames(join(pkg, js))].filter((n) => !declared.has(n));
    assert.deepEqual(missing, [], `${js}: not declared in ${dts}`);
  }
});

// Runs in a temporary project whose node_modules link the dashboard's three
// and this package, as an app that installed both would see them.
const THREE_SIDE = String.raw`
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { ImpostorAsset, ImpostorMaterial, ImpostorMesh, InstancedImpostorMesh } from 'impostor-three';

const views = Array.from({ length: 64 }, (_, i) => ({ index: i }));
const manifest = { cache_key: 'ab'.repeat(32), product: 'PRODUCT_ATLAS', layout: 'LAYOUT_HEMI_OCTAHEDRAL', frames: 8,
  tile_size: 64, resolution: 512, views, bounding_sphere: { center: [1, 2, 3], radius: 2 }, maps: [],
  quality: { blend: 'bilinear4' } };
const textures = { albedo: new THREE.Texture(), normalDepth: new THREE.Texture(), orm: null };
const asset = new ImpostorAsset({ name: 'trees/oak', manifest, textures });
assert.equal(asset.layoutName, 'hemi-octahedral');
assert.equal(asset.product, 'atlas');

const m = new ImpostorMaterial(asset);
assert.equal(m.reconstruction, 'depth', 'depth-aware by default');
assert.equal(m.blend, 'bilinear4', "the quality pass's blend");
assert.equal(m.output, 'lit');
assert.equal(m.depthOffset, true);
assert.equal(m.defines.IMPOSTOR_DEPTH_OFFSET, 1, 'the depth offset is compiled in');
const version = m.version;
m.depthOffset = false;
assert.equal('IMPOSTOR_DEPTH_OFFSET' in m.defines, false, 'no depth offset: gl_FragDepth is not written');
assert.ok(m.version > version, 'the program is rebuilt');
m.depthOffset = true;
assert.equal(m.defines.IMPOSTOR_DEPTH_OFFSET, 1);
assert.deepEqual(m.uniforms.impostorLayout.value, [1, 8, 0, 64]);
assert.deepEqual(m.uniforms.impostorMode.value, [1, 2, 0, 0]);
assert.equal(m.uniforms.impostorOrm.value, textures.albedo, 'no ORM map: has_orm 0, a bound placeholder');
assert.equal(m.glslVersion, THREE.GLSL3);
m.reconstruction = 'plain';
m.output = 'normal';
assert.deepEqual(m.uniforms.impostorMode.value, [1, 0, 0, 3]);
assert.throws(() => { m.reconstruction = 'spline'; }, /reconstruction "spline": want one of plain, parallax, depth/);
assert.equal(m.depthMaterial.uniforms.impostorMode, m.uniforms.impostorMode, 'the depth variant shares the settings');
assert.equal(m.depthMaterial.uniforms.impostorAlbedo, m.uniforms.impostorAlbedo);
const copy = m.clone();
assert.equal(copy.reconstruction, 'plain');
assert.notEqual(copy.uniforms.impostorMode, m.uniforms.impostorMode);

const single = new ImpostorMesh(asset, { output: 'albedo' });
assert.equal(single.material.output, 'albedo');
assert.equal(single.customDepthMaterial, single.material.depthMaterial);
assert.deepEqual(single.geometry.boundingSphere.center.toArray(), [1, 2, 3]);
single.geometry.computeBoundingSphere();
assert.equal(single.geometry.boundingSphere.radius, 2, 'bounds stay the asset sphere, not the card');

const forest = new InstancedImpostorMesh(asset, 3);
forest.setMatrixAt(1, new THREE.Matrix4().makeTranslation(100, 0, 0));
forest.setMatrixAt(2, new THREE.Matrix4().makeTranslation(0, 0, -100));
forest.computeBoundingSphere();
assert.ok(forest.boundingSphere.containsPoint(new THREE.Vector3(101, 2, 3)), 'instance bounds');
forest.updateMatrixWorld();
const ray = new THREE.Raycaster(new THREE.Vector3(101, 2, 50), new THREE.Vector3(0, 0, -1));
const hits = ray.intersectObject(forest);
assert.equal(hits.length, 1);
assert.equal(hits[0].instanceId, 1);
assert.ok(Math.abs(hits[0].distance - 45) < 1e-6, String(hits[0].distance));

// Cross-fade: off by default (compiled out of both variants); on, both get
// the define; per instance (t, seed) on the card, t 1 and seed = index
// until set.
assert.equal(m.crossFade, false);
assert.equal('IMPOSTOR_CROSS_FADE' in m.defines || 'IMPOSTOR_CROSS_FADE' in m.depthMaterial.defines, false);
m.crossFade = true;
assert.equal(m.defines.IMPOSTOR_CROSS_FADE, 1);
assert.equal(m.depthMaterial.defines.IMPOSTOR_CROSS_FADE, 1, 'the shadow pass fades with the colour');
assert.equal(m.depthMaterial.uniforms.impostorCrossFade, m.uniforms.impostorCrossFade);
m.fade = 0.25;
m.fadeSeed = 9;
assert.deepEqual(m.uniforms.impostorCrossFade.value.toArray(), [0.25, 9]);
assert.equal(m.clone().crossFade, true);
m.crossFade = false;
assert.equal('IMPOSTOR_CROSS_FADE' in m.depthMaterial.defines, false);
const fading = new InstancedImpostorMesh(asset, 4, { crossFade: true });
assert.deepEqual(fading.getFadeAt(3), [1, 3]);
fading.setFadeAt(2, 0.5);
assert.deepEqual(fading.getFadeAt(2), [0.5, 2]);
fading.setFadeAt(2, 0.75, 40);
assert.deepEqual(fading.getFadeAt(2), [0.75, 40]);
assert.equal(fading.geometry.getAttribute('impostorFade').isInstancedBufferAttribute, true);
console.log('three side ok');
`;

test("the three.js side: ImpostorMaterial's settings, the meshes' bounds and raycasts", (t) => {
  if (!existsSync(join(threeDir, 'package.json'))) {
    t.skip(`${threeDir} missing (npm ci in web/)`);
    return;
  }
  const dir = mkdtempSync(join(tmpdir(), 'impostor-three-node-'));
  try {
    mkdirSync(join(dir, 'node_modules'));
    symlinkSync(threeDir, join(dir, 'node_modules', 'three'));
    symlinkSync(pkg, join(dir, 'node_modules', 'impostor-three'));
    writeFileSync(join(dir, 'package.json'), '{"type": "module"}');
    writeFileSync(join(dir, 'three_side.mjs'), THREE_SIDE);
    // --preserve-symlinks: the package resolves `three` from the app's node_modules, as when installed.
    const run = spawnSync(process.execPath, ['--preserve-symlinks', 'three_side.mjs'], { cwd: dir, encoding: 'utf8' });
    assert.equal(run.status, 0, run.stderr + run.stdout);
    assert.match(run.stdout, /three side ok/);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
});
