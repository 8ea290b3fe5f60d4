// Texture-array results (`texture_array`, `impostor bake --array`): each map
// is a strip one tile wide, layer i (= view i) at rows [i × tile, (i + 1) ×
// tile) (common/manifest/manifest_format.md). The viewer's material (impostor-three)
// lays a strip out as the atlas before drawing; the atlas panel shows it the
// same way through the package's own mapping, so the panel's tiles are the
// ones the viewer samples.
import { atlasLayout, isTextureArray, repackLayerStrip } from 'impostor-three';

export { isTextureArray };

// {width, height, data: Uint8Array RGBA8, rows top first} of the atlas that
// the strip at `url` holds (tiles no view uses stay transparent), like
// decodeKtx2Rgba.
export async function decodeLayerStrip(url, manifest) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  const image = await createImageBitmap(await response.blob(), { premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
  try {
    return repackLayerStrip(image, manifest, atlasLayout(manifest).side, url);
  } finally {
    image.close();
  }
}
