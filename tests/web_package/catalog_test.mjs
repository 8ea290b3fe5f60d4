// impostor-three's channel and catalog readers (release_format.md) on
// untrusted bytes: each broken document is refused with a message naming
// where it came from and the field, as the C++ SDK's ParseCatalog /
// ParseChannel; a newer schema_version names both versions. Also the layout
// and product names the dashboard shows.
// Run: node --test tests/web_package/catalog_test.mjs
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { ImpostorSchemaError, parseCatalog, parseChannel } from '../../packages/impostor-three/src/release/index.js';
import { atlasLayout, layoutName, productName } from '../../packages/impostor-three/src/layout.js';

const HEX = 'ab'.repeat(32);
const HEX2 = 'cd'.repeat(32);

function catalog(edit = (c) => c) {
  const c = {
    schema: 'impostor-catalog', schema_version: 1, created_at: '2026-12-02T01:02:03Z', baker_version: '0.2.0',
    assets: {
      'trees/oak': {
        cache_key: HEX, product: 'atlas', layout: 'hemi-octahedral', frames: 12, resolution: 2048,
        manifest: { sha256: HEX2, size_bytes: 10 },
        files: [
          { name: 'albedo_alpha.png', semantic: 'albedo_alpha', sha256: HEX, size_bytes: 5, media_type: 'image/png',
            width: 2048, height: 2048, format: 'png_rgba8' },
          { name: 'manifest.json', semantic: 'manifest', sha256: HEX2, size_bytes: 10, media_type: 'application/json',
            width: 0, height: 0, format: 'json' },
        ],
      },
    },
  };
  edit(c);
  return JSON.stringify(c);
}

function channel(edit = (c) => c) {
  const c = { schema: 'impostor-channel', schema_version: 1, channel: 'nightly', catalog: { sha256: HEX, size_bytes: 12 },
    published_at: '2026-12-02T01:02:03Z' };
  edit(c);
  return JSON.stringify(c);
}

const oak = (c) => c.assets['trees/oak'];

test('a well-formed catalog and channel parse', () => {
  const c = parseCatalog(catalog(), 'm/c');
  const a = c.assets.get('trees/oak');
  assert.equal(a.layout, 'hemi-octahedral');
  assert.equal(a.files[0].sizeBytes, 5);
  assert.equal(a.manifest.sha256, HEX2);
  const ch = parseChannel(channel(), 'm/ch');
  assert.deepEqual(ch.catalog, { sha256: HEX, sizeBytes: 12 });
  assert.equal(ch.signature, null);
  // Fields a reader does not know are ignored; media_type defaults by extension.
  const extra = parseCatalog(catalog((c) => { c.future = 1; delete oak(c).files[0].media_type; }), 'm/c');
  assert.equal(extra.assets.get('trees/oak').files[0].mediaType, 'image/png');
});

const catalogCases = [
  { name: 'not JSON (an error page)', text: '<html>502</html>', want: /m\/c: not a JSON object \(a catalog was expected/ },
  { name: 'another schema', edit: (c) => { c.schema = 'x'; }, want: /schema is "x", expected "impostor-catalog"/ },
  { name: 'a newer schema_version', edit: (c) => { c.schema_version = 2; }, want: /schema_version 2 is newer than this reader's \(1\)/, type: ImpostorSchemaError },
  { name: 'schema_version 0', edit: (c) => { c.schema_version = 0; }, want: /schema_version must be >= 1/ },
  { name: 'no assets', edit: (c) => { delete c.assets; }, want: /assets is missing/ },
  { name: 'an asset name with ..', edit: (c) => { c.assets['a/../b'] = oak(c); }, want: /asset name "a\/\.\.\/b"/ },
  { name: 'a leading /', edit: (c) => { c.assets['/a'] = oak(c); }, want: /asset name "\/a"/ },
  { name: 'a bad cache key', edit: (c) => { oak(c).cache_key = 'XY'; }, want: /assets\["trees\/oak"\]\.cache_key must be 64 lowercase hex/ },
  { name: 'frames as a string', edit: (c) => { oak(c).frames = '12'; }, want: /assets\["trees\/oak"\]\.frames must be a whole number >= 0/ },
  { name: 'a negative size', edit: (c) => { oak(c).files[0].size_bytes = -1; }, want: /files\[0\]\.size_bytes must be a whole number/ },
  { name: 'an uppercase digest', edit: (c) => { oak(c).files[0].sha256 = HEX.toUpperCase(); }, want: /files\[0\]\.sha256 must be 64 lowercase hex/ },
  { name: 'a file name with a path', edit: (c) => { oak(c).files[0].name = '../x.png'; }, want: /files\[0\]\.name must be a plain file name/ },
  { name: 'a hidden file name', edit: (c) => { oak(c).files[0].name = '.x'; }, want: /files\[0\]\.name must be a plain file name/ },
  { name: 'a file listed twice', edit: (c) => { oak(c).files.unshift({ ...oak(c).files[0] }); }, want: /files\[1\]\.name "albedo_alpha\.png" is listed twice/ },
  { name: 'no manifest.json', edit: (c) => { oak(c).files.pop(); }, want: /files must list manifest\.json/ },
  { name: 'a manifest.json of another digest', edit: (c) => { oak(c).files[1].sha256 = HEX; }, want: /files\[1\]\.sha256 differs from the asset's manifest digest/ },
  { name: 'files not an array', edit: (c) => { oak(c).files = {}; }, want: /files must be an array/ },
];
for (const c of catalogCases) {
  test(`catalog refused: ${c.name}`, () => {
    assert.throws(() => parseCatalog(c.text ?? catalog(c.edit), 'm/c'), (e) => {
      assert.match(e.message, c.want, c.name);
      assert.ok(e.message.startsWith('m/c'), `${c.name}: names the source: ${e.message}`);
      if (c.type) assert.ok(e instanceof c.type, c.name);
      return true;
    });
  });
}

const channelCases = [
  { name: 'not JSON', text: 'oops', want: /m\/ch: not a JSON object \(a channel file was expected/ },
  { name: 'a newer schema_version', edit: (c) => { c.schema_version = 3; }, want: /schema_version 3 is newer than this reader's \(1\)/ },
  { name: 'no catalog', edit: (c) => { delete c.catalog; }, want: /catalog is missing/ },
  { name: 'a short catalog digest', edit: (c) => { c.catalog.sha256 = 'ab'; }, want: /catalog\.sha256 must be 64 lowercase hex/ },
  { name: 'a bad channel name', edit: (c) => { c.channel = '-x'; }, want: /channel "-x": must match/ },
  { name: 'a signature without a value', edit: (c) => { c.signature = { algorithm: 'ed25519', key_id: 'aa' }; }, want: /signature\.value is missing/ },
];
for (const c of channelCases) {
  test(`channel refused: ${c.name}`, () => {
    assert.throws(() => parseChannel(c.text ?? channel(c.edit), 'm/ch'), c.want);
  });
}

test('layouts and products are named as users write them', () => {
  const cases = [
    ['LAYOUT_HEMI_OCTAHEDRAL', 'hemi-octahedral'], ['hemi-octahedral', 'hemi-octahedral'], ['LAYOUT_OCTAHEDRAL', 'octahedral'],
    ['LAYOUT_AZIMUTH_ELEVATION', 'azimuth-elevation'], ['LAYOUT_RING_TOP', 'ring-top'], ['LAYOUT_BILLBOARD', 'billboard'],
    ['LAYOUT_UNSPECIFIED', 'octahedral'], [undefined, 'octahedral'], ['LAYOUT_SOMETHING_NEW', 'LAYOUT_SOMETHING_NEW'],
  ];
  for (const [given, want] of cases) assert.equal(layoutName(given), want, String(given));
  for (const [given, want] of [['PRODUCT_LOD_CHAIN', 'lod-chain'], ['PRODUCT_ATLAS', 'atlas'], ['cards', 'cards'], [undefined, 'atlas']]) {
    assert.equal(productName(given), want, String(given));
  }
});

test('atlasLayout takes the manifest or the JSON API form and refuses what does not fit', () => {
  const views = (n) => Array.from({ length: n }, (_, i) => ({ index: i }));
  const cases = [
    { m: { layout: 'LAYOUT_HEMI_OCTAHEDRAL', frames: 8, tile_size: 64, views: views(64) }, want: { kind: 1, frames: 8, ringViews: 0, side: 8 } },
    { m: { layout: 'ring-top', frames: 5, tile_size: 64, views: views(25) }, want: { kind: 3, frames: 5, ringViews: 24, side: 5 } },
    { m: { layout: 'billboard', frames: 3, tile_size: 64, views: views(9) }, want: { kind: 4, frames: 3, ringViews: 8, side: 3 } },
    { m: { layout: 'azimuth-elevation', frames: 7, tile_size: 32, views: views(49) }, want: { kind: 2, frames: 7, ringViews: 0, side: 7 } },
    { m: { layout: 'octahedral', frames: 8, tile_size: 64, views: views(63) }, throws: /64 views expected, the manifest lists 63/ },
    { m: { layout: 'spiral', frames: 8, tile_size: 64, views: views(64) }, throws: /layout "spiral" is not one this runtime draws/ },
  ];
  for (const c of cases) {
    if (c.throws) {
      assert.throws(() => atlasLayout(c.m), c.throws, c.m.layout);
      continue;
    }
    const got = atlasLayout(c.m);
    for (const [k, v] of Object.entries(c.want)) assert.equal(got[k], v, `${c.m.layout}.${k}`);
  }
});
