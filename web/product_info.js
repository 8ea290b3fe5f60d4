// What the result page says about a product besides its atlas: the quality
// figures the cards and surfels bakes measure for themselves (manifest
// cards.quality, surfels.quality; common/manifest/manifest_format.md), the note shown
// where the viewer has nothing to draw, and which level of a LOD chain the
// viewer draws. Kept apart from result.js so each product's wording is in
// one place.

const productName = (m) => (m.product || 'PRODUCT_ATLAS').replace('PRODUCT_', '').toLowerCase();

// The product's own held-out-view comparison as [label, value] rows, or
// null when the manifest has none (atlas products use m.quality instead).
export function productQuality(m) {
  if (m.cards && m.cards.quality && m.cards.quality.views) {
    const q = m.cards.quality;
    return [['product', 'cards (the quads rendered against the mesh)'], ['held-out views', q.views],
      ['silhouette IoU (min / mean)', `${q.silhouette_iou_min.toFixed(4)} / ${q.silhouette_iou_mean.toFixed(4)}`],
      ['albedo PSNR dB', q.albedo_psnr_db.toFixed(2)]];
  }
  if (m.surfels && m.surfels.quality && m.surfels.quality.views) {
    const q = m.surfels.quality;
    return [['product', 'surfels (the points rendered as splats against the mesh)'], ['held-out views', q.views],
      ['view size px', `${q.view_pixels}×${q.view_pixels}`],
      ['silhouette IoU (min / mean)', `${q.silhouette_iou_min.toFixed(4)} / ${q.silhouette_iou_mean.toFixed(4)}`],
      ['albedo PSNR dB', q.albedo_psnr_db.toFixed(2)]];
  }
  return null;
}

// Why there is no 3D view and what opens the product's files instead.
export function noViewerNote(m) {
  const name = productName(m);
  if (m.surfels) {
    const ply = m.surfels.ply_file || 'surfels.ply';
    const bin = m.surfels.file || 'surfels.bin';
    return `no 3D view here for product ${name}: ${ply} (the points as a binary PLY) opens in point-cloud viewers `
      + `such as MeshLab or CloudCompare; ${bin} is the engine's point buffer (12 float32 per point)`;
  }
  if (m.cards) {
    return `no 3D view here for product ${name}: ${m.cards.file || 'cards.glb'} opens in any glTF viewer`;
  }
  return `no 3D view here for product ${name}: its files are below`;
}

// For a LOD chain (whose top-level atlas fields and maps are its impostor
// level's), the sentence naming the level the viewer draws; '' otherwise.
export function lodChainLevelNote(m) {
  if (!Array.isArray(m.lods) || m.lods.length === 0) return '';
  const impostor = m.lods.find((l) => l.kind === 'impostor') || m.lods[m.lods.length - 1];
  const meshes = m.lods.filter((l) => l.kind === 'mesh').map((l) => l.file);
  return `LOD chain: the impostor is level lod${impostor.level} (${impostor.file}, the maps below)`
    + (meshes.length ? `; the mesh levels ${meshes.join(', ')} open in any glTF viewer` : '');
}
