// Texture-array results (`impostor bake --array`): each map is a strip one
// tile wide, layer i (= view i) at rows [i × tile, (i + 1) × tile)
// (common/manifest_format.md). The runtime shader samples frame i at its
// atlas tile, so a strip is laid out as the atlas first: layer i goes to
// frame i's tile (i % side, i / side), giving the same RGBA8 picture as the
// atlas bake of the same mesh with the runtime's math unchanged.

// What the C++ SDK checks (client/cache/manifest_summary.cc): the manifest
// has no flag of its own; the albedo map is one tile wide and a tile per
// view high.
export function isTextureArray(manifest) {
  const views = manifest.views ? manifest.views.length : 0;
  const albedo = (manifest.maps || []).find((m) => m.semantic === 'albedo_alpha');
  const tile = manifest.tile_size;
  return views > 1 && !!albedo && albedo.width === tile && albedo.height === tile * views;
}

// [{layer: [x, y, w, h] in the strip (the view's `tile`), tile: [col, row]
// in the atlas}] and the atlas side in pixels. `side` is the layout's grid
// side (atlasLayout(manifest).side).
export function layerPlacements(manifest, side = manifest.frames) {
  const tile = manifest.tile_size;
  const placements = manifest.views.map((view, i) => {
    // manifest.json writes tile as [x, y, w, h]; the farm's JSON API as {x, y, width, height}.
    const t = Array.isArray(view.tile) ? { x: view.tile[0], y: view.tile[1], width: view.tile[2], height: view.tile[3] }
      : view.tile || {};
    const index = view.index ?? i;
    return {
      layer: [t.x ?? 0, t.y ?? i * tile, t.width || tile, t.height || tile],
      tile: [index % side, Math.floor(index / side)],
    };
  });
  return { placements, side: side * tile };
}

// {width, height, data: Uint8Array RGBA8, rows top first} of the atlas that
// the strip `image` (an ImageBitmap decoded without premultiplying or colour
// conversion) holds; tiles no view uses stay transparent. The bytes are
// copied untouched: each layer is uploaded as a sub-rectangle
// (UNPACK_SKIP_ROWS) into a WebGL2 texture the atlas's size and read back,
// so the strip itself never has to fit a texture (a 16 × 16 bake at 128 px
// is 32768 px high, beyond MAX_TEXTURE_SIZE). `what` names the map in errors.
export function repackLayerStrip(image, manifest, side, what) {
  const { placements, side: size } = layerPlacements(manifest, side);
  const canvas = typeof OffscreenCanvas !== 'undefined' ? new OffscreenCanvas(1, 1) : document.createElement('canvas');
  const gl = canvas.getContext('webgl2');
  if (!gl) throw new Error('WebGL2 is not available');
  try {
    const tex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA8, size, size);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, size, size, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(size * size * 4));
    gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
    for (const { layer: [x, y, w, h], tile: [col, row] } of placements) {
      if (y + h > image.height || x + w > image.width) {
        throw new Error(`${what}: layer at row ${y} lies outside the ${image.width}×${image.height} strip`);
      }
      gl.pixelStorei(gl.UNPACK_SKIP_PIXELS, x);
      gl.pixelStorei(gl.UNPACK_SKIP_ROWS, y);
      gl.texSubImage2D(gl.TEXTURE_2D, 0, col * manifest.tile_size, row * manifest.tile_size, w, h, gl.RGBA,
        gl.UNSIGNED_BYTE, image);
    }
    const fbo = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
    const data = new Uint8Array(size * size * 4);
    // Texture row 0 (the image's top row, no FLIP_Y) is framebuffer row 0.
    gl.readPixels(0, 0, size, size, gl.RGBA, gl.UNSIGNED_BYTE, data);
    const error = gl.getError();
    if (error !== gl.NO_ERROR) throw new Error(`${what}: repacking the texture-array layers failed (GL error ${error})`);
    return { width: size, height: size, data };
  } finally {
    const lose = gl.getExtension('WEBGL_lose_context');
    if (lose) lose.loseContext();  // a page may hold only so many contexts
  }
}
