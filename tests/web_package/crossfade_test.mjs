// impostor-three's cross-fade helpers (src/cross_fade.js) against the C++
// SDK's definition (impostor/lod.h): the documented pattern (the table
// tests/lod/lod_crossfade_test.cc checks too), mesh and impostor
// complementary at every t, the impostor's share of every 4 x 4 block within
// 1/32 of t, and the band's fade factor; the embedded GLSL is
// shaders/impostor_crossfade.glsl byte for byte.
// Run: node --test tests/web_package/crossfade_test.mjs
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { test } from 'node:test';

const here = dirname(fileURLToPath(import.meta.url));
const repo = resolve(here, '..', '..');
const pkg = join(repo, 'packages', 'impostor-three');
const {
  crossFadeDrawsImpostor, crossFadeDrawsMesh, crossFadeFactor, crossFadeThreshold, DEFAULT_CROSS_FADE_BAND,
  DEFAULT_IMPOSTOR_SWITCH_PIXELS, impostorSwitchScale,
} = await import(join(pkg, 'src', 'cross_fade.js'));

test('the pattern is the documented one (the C++ test has the same table)', () => {
  const table = [
    [0, [[0, 8, 2, 10], [12, 4, 14, 6], [3, 11, 1, 9], [15, 7, 13, 5]]],
    [1, [[9, 1, 11, 3], [5, 13, 7, 15], [12, 4, 10, 2], [8, 0, 6, 14]]],
    [7, [[5, 13, 7, 15], [1, 9, 3, 11], [8, 0, 6, 14], [4, 12, 2, 10]]],
  ];
  for (const [seed, levels] of table) {
    for (let y = 0; y < 4; ++y) {
      for (let x = 0; x < 4; ++x) {
        assert.equal(crossFadeThreshold(seed, x, y), (levels[y][x] + 0.5) / 16, `seed ${seed} pixel (${x}, ${y})`);
        assert.equal(crossFadeThreshold(seed, x + 4, y - 8), crossFadeThreshold(seed, x, y), 'repeats every 4');
      }
    }
  }
  // Seeds past 2^31 wrap as the GLSL's uint does.
  assert.equal(crossFadeThreshold(0xffffffff, 0, 0), crossFadeThreshold(-1, 0, 0));
});

test('mesh and impostor are complementary and the impostor gets t of every block', () => {
  for (const seed of [0, 1, 2, 99, 0xffffffff]) {
    for (let k = -4; k <= 68; ++k) {
      const t = k / 64;
      for (let by = -8; by < 8; by += 4) {
        for (let bx = -8; bx < 8; bx += 4) {
          let impostor = 0;
          for (let y = by; y < by + 4; ++y) {
            for (let x = bx; x < bx + 4; ++x) {
              const imp = crossFadeDrawsImpostor(t, seed, x, y);
              assert.notEqual(imp, crossFadeDrawsMesh(t, seed, x, y), `pixel (${x}, ${y}) seed ${seed} t ${t}`);
              impostor += imp ? 1 : 0;
            }
          }
          const want = Math.min(Math.max(t, 0), 1);
          assert.ok(Math.abs(impostor / 16 - want) <= 1 / 32, `seed ${seed} t ${t}: ${impostor} of 16`);
        }
      }
    }
  }
});

test('the fade factor runs from 0 above the band to 1 at the switch', () => {
  assert.equal(DEFAULT_CROSS_FADE_BAND, 0.1);
  assert.equal(crossFadeFactor(200, 100, 0.2), 0);
  assert.ok(Math.abs(crossFadeFactor(110, 100, 0.2) - 0.5) < 1e-9);
  assert.ok(Math.abs(crossFadeFactor(105, 100) - 0.5) < 1e-9, 'default band 0.1');
  assert.equal(crossFadeFactor(100, 100, 0.2), 1);
  assert.equal(crossFadeFactor(50, 100, 0.2), 1);
  assert.equal(crossFadeFactor(100.001, 100, 0), 0, 'band 0: the hard switch');
  let last = 0;
  for (let s = 130; s >= 90; s -= 0.25) {
    const t = crossFadeFactor(s, 100, 0.2);
    assert.ok(t >= last, `monotonic at ${s}`);
    last = t;
  }
});

test('the package embeds shaders/impostor_crossfade.glsl unchanged', async () => {
  const { impostorCrossFadeGlsl } = await import(join(pkg, 'src', 'shaders', 'impostor_crossfade.glsl.js'));
  assert.ok(impostorCrossFadeGlsl === readFileSync(join(repo, 'shaders', 'impostor_crossfade.glsl'), 'utf8'),
    'stale: run node packages/impostor-three/scripts/embed_runtime.mjs');
});

// Issue 43: the switch where the bake's good-for size puts it (the C++ SDK's
// rule: diameter pixels / (2 * radius)), the fixed 16 px without one, and
// nothing from a radius that is not > 0.
test('the impostor switch follows the good-for size', () => {
  assert.equal(impostorSwitchScale(140, 2), 35);
  assert.equal(impostorSwitchScale(0, 2), DEFAULT_IMPOSTOR_SWITCH_PIXELS / 4);
  assert.equal(impostorSwitchScale(0, 2, 64), 16);
  assert.ok(Number.isNaN(impostorSwitchScale(140, 0)));
  assert.ok(Number.isNaN(impostorSwitchScale(140, -1)));
  // The fade ends exactly at the switch and starts a band above it.
  const sw = impostorSwitchScale(140, 2);
  assert.equal(crossFadeFactor(sw, sw), 1);
  assert.equal(crossFadeFactor(sw * (1 + DEFAULT_CROSS_FADE_BAND), sw), 0);
});
