// The atlas layout of a baked result (common/manifest_format.md, "Frame
// directions"), as the runtime shader takes it: IMPOSTOR_LAYOUT_* kind,
// frames, ring views. Names are the manifest's ("hemi-octahedral"); the
// farm's JSON API spells them as protobuf enums ("LAYOUT_HEMI_OCTAHEDRAL"),
// which layoutName() turns back into the name users write. Pure functions.

export const LAYOUT_KINDS = Object.freeze({
  octahedral: 0,
  'hemi-octahedral': 1,
  'azimuth-elevation': 2,
  'ring-top': 3,
  billboard: 4,
});

const BILLBOARD_RING_VIEWS = 8;

// "hemi-octahedral" for "hemi-octahedral", "LAYOUT_HEMI_OCTAHEDRAL" or
// "HEMI_OCTAHEDRAL"; "octahedral" for an empty or unspecified layout (as
// bakes made before layouts existed); other strings unchanged.
export function layoutName(layout) {
  if (layout === undefined || layout === null || layout === '' || layout === 'LAYOUT_UNSPECIFIED') return 'octahedral';
  const s = String(layout);
  const name = s.replace(/^LAYOUT_/, '').toLowerCase().replace(/_/g, '-');
  return name in LAYOUT_KINDS ? name : s;
}

// "atlas" for "PRODUCT_ATLAS" (and an absent product), "lod-chain" for
// "PRODUCT_LOD_CHAIN", and so on.
export function productName(product) {
  if (product === undefined || product === null || product === '' || product === 'PRODUCT_UNSPECIFIED') return 'atlas';
  return String(product).replace(/^PRODUCT_/, '').toLowerCase().replace(/_/g, '-');
}

// {kind, name, frames, ringViews, tileSize, viewCount, side} of a manifest
// (manifest.json, or the JSON API's form of it), as AtlasLayoutFromManifest
// in client/include/impostor/runtime.h; throws a TypeError naming what does
// not fit (an unknown layout, a view count the layout cannot have).
export function atlasLayout(manifest) {
  const name = layoutName(manifest.layout);
  const kind = LAYOUT_KINDS[name];
  if (kind === undefined) throw new TypeError(`layout "${manifest.layout}" is not one this runtime draws`);
  const frames = manifest.frames;
  const viewCount = Array.isArray(manifest.views) ? manifest.views.length : 0;
  if (!Number.isInteger(frames) || frames < 1 || frames > 64) throw new TypeError(`frames ${frames}: want 1..64`);
  let ringViews = 0;
  if (kind === LAYOUT_KINDS['ring-top']) ringViews = viewCount - 1;
  if (kind === LAYOUT_KINDS.billboard) ringViews = BILLBOARD_RING_VIEWS;
  const want = kind <= LAYOUT_KINDS['azimuth-elevation'] ? frames * frames : ringViews + 1;
  if (kind === LAYOUT_KINDS['ring-top'] && ringViews < 1) throw new TypeError('ring-top: the manifest lists no ring views');
  if (viewCount !== want) throw new TypeError(`${name} with frames ${frames}: ${want} views expected, the manifest lists ${viewCount}`);
  const tileSize = manifest.tile_size;
  if (!Number.isInteger(tileSize) || tileSize < 1) throw new TypeError(`tile_size ${tileSize}: want a whole number >= 1`);
  let side = frames;
  if (ringViews > 0) {
    side = 1;
    while (side * side < ringViews + 1) ++side;
  }
  return { kind, name, frames, ringViews, tileSize, viewCount, side };
}
