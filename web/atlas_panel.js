// Debug view "the atlas with the active frames marked": the albedo atlas
// with an outline around each frame the impostor blends for the current
// camera, labelled with its index and weight. The frames come from the
// runtime shader itself (blend_probe.js), so the marks are the frames drawn.
// A texture-array result shows its layers at their frames' tiles (what the
// viewer samples, texture_array.js), so a 128 × 8192 strip is not squeezed
// into the square and the marks land on the layers they name.

const COLOURS = ['#ff5252', '#ffd740', '#69f0ae', '#40c4ff'];  // by weight rank

import { decodeKtx2Rgba, isKtx2 } from './ktx2_rgba.js';
import { decodeLayerStrip, isTextureArray } from './texture_array.js';

// Something drawImage takes: the PNG as an image, a KTX2 map decoded to
// RGBA8 (ktx2_rgba.js) or a texture-array strip laid out as the atlas
// (texture_array.js) as an ImageBitmap.
async function loadImage(url, manifest) {
  if (isKtx2(url) || isTextureArray(manifest)) {
    const { width, height, data } = isKtx2(url) ? await decodeKtx2Rgba(url) : await decodeLayerStrip(url, manifest);
    return createImageBitmap(new ImageData(new Uint8ClampedArray(data.buffer, data.byteOffset, data.length), width, height));
  }
  return new Promise((resolve, reject) => {
    const image = new Image();
    image.onload = () => resolve(image);
    image.onerror = () => reject(new Error(`atlas panel: cannot load ${url}`));
    image.src = url;
  });
}

// canvas: the panel's 2D canvas; list: an element for the text legend.
// Returns {update(entries)} where entries = [{index, weight, tile: [col, row]}]; `marked` holds the last drawn.
export async function createAtlasPanel(canvas, list, manifest, fileUrl) {
  const albedo = manifest.maps.find((m) => m.semantic === 'albedo_alpha');
  if (!albedo) throw new Error('atlas panel: the result has no albedo_alpha map');
  const image = await loadImage(fileUrl(albedo.file), manifest);
  const layers = isTextureArray(manifest);
  const ctx = canvas.getContext('2d');
  const scale = canvas.width / Math.max(image.width, image.height);
  const tile = manifest.tile_size * scale;
  const panel = {
    marked: [],
    update(entries) {
      ctx.clearRect(0, 0, canvas.width, canvas.height);
      ctx.imageSmoothingEnabled = true;
      ctx.drawImage(image, 0, 0, image.width * scale, image.height * scale);
      // Strongest last, so its outline is on top.
      const ranked = entries.map((e, i) => ({ ...e, rank: i })).sort((a, b) => a.weight - b.weight);
      const fontPx = Math.max(9, Math.min(16, Math.round(tile / 5)));
      ctx.font = `${fontPx}px system-ui, sans-serif`;
      ctx.textBaseline = 'top';
      for (const e of ranked) {
        const colour = COLOURS[entries.length - 1 - ranked.indexOf(e)] || COLOURS[3];
        const x = e.tile[0] * tile, y = e.tile[1] * tile;
        ctx.lineWidth = 1 + 3 * e.weight;
        ctx.strokeStyle = colour;
        ctx.strokeRect(x + ctx.lineWidth / 2, y + ctx.lineWidth / 2, tile - ctx.lineWidth, tile - ctx.lineWidth);
        ctx.fillStyle = 'rgba(0, 0, 0, 0.6)';
        // The weight in the tile; the index is in the legend below.
        const label = e.weight.toFixed(2);
        ctx.fillRect(x + 2, y + 2, ctx.measureText(label).width + 4, fontPx + 2);
        ctx.fillStyle = colour;
        ctx.fillText(label, x + 4, y + 3);
      }
      panel.marked = entries.map((e) => ({ index: e.index, weight: e.weight, tile: [...e.tile] }));
      list.textContent = entries.length
        ? entries.map((e) => `frame ${e.index} (${layers ? `layer ${e.index}, shown at ` : ''}tile ${e.tile[0]},${e.tile[1]}) weight ${e.weight.toFixed(3)}`).join(' · ')
        : 'no frames';
    },
  };
  return panel;
}
