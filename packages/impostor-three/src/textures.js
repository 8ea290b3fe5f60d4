// The maps of a baked result as three.js textures, from bytes already
// verified: PNG (and JPEG/WebP) through createImageBitmap, KTX2 through
// three's KTX2Loader with the Basis transcoder the `three` package ships
// (examples/jsm/libs/basis/). The runtime reads texels with texelFetch and
// filters by hand within each frame's tile, so nothing is resampled: no
// flip, no premultiplied alpha, no colour conversion, and no mip chain is
// generated (a PNG atlas has one level; a KTX2 atlas keeps the levels the
// baker stored, whose tiles never mix frames). albedo_alpha and emissive
// are sRGB (read as linear through an sRGB format), the others linear.
import { DataTexture, NearestFilter, NoColorSpace, RGBAFormat, SRGBColorSpace, Texture, UnsignedByteType } from 'three';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
import { isTextureArray, repackLayerStrip } from './texture_array.js';

const SRGB_SEMANTICS = new Set(['albedo_alpha', 'emissive']);

// Every transcode target off: the transcoder writes RGBA32, the values the
// baker stored. detectSupport(renderer) on the loader picks GPU formats.
export const RGBA_WORKER_CONFIG = Object.freeze({
  astcSupported: false, astcHDRSupported: false, etc1Supported: false, etc2Supported: false,
  dxtSupported: false, bptcSupported: false, pvrtcSupported: false,
});

// Where the Basis transcoder of the `three` the page imports lives, from the
// page's import map (three/addons/ -> three's examples/jsm/); '' when the
// environment cannot resolve it (then give setTranscoderPath()).
export function defaultTranscoderPath() {
  try {
    const url = import.meta.resolve('three/addons/libs/basis/basis_transcoder.js');
    return url.slice(0, url.lastIndexOf('/') + 1);
  } catch {
    return '';
  }
}

export function isKtx2File(name) {
  return name.toLowerCase().endsWith('.ktx2');
}

function settle(texture, semantic, keepFilters) {
  texture.flipY = false;
  texture.premultiplyAlpha = false;
  texture.generateMipmaps = false;
  if (!keepFilters) {
    texture.minFilter = NearestFilter;
    texture.magFilter = NearestFilter;
  }
  texture.colorSpace = SRGB_SEMANTICS.has(semantic) ? SRGBColorSpace : NoColorSpace;
  texture.name = semantic;
  texture.needsUpdate = true;
  return texture;
}

const MEDIA = { png: 'image/png', jpg: 'image/jpeg', jpeg: 'image/jpeg', webp: 'image/webp' };

// One map as a texture. `bytes`: Uint8Array; `file`: its name in the result;
// `semantic`: the manifest's; `manifest`: for texture-array strips;
// `layoutSide`: the atlas grid side; `ktx2Loader`: a KTX2Loader whose
// transcoder is set up (KTX2 maps only). Rejects naming the file when the
// bytes do not decode.
export async function decodeMap({ bytes, file, semantic, manifest, layoutSide, ktx2Loader }) {
  if (isKtx2File(file)) {
    if (!ktx2Loader) throw new Error(`${file}: a KTX2 map needs a KTX2 loader (setKTX2Loader or setTranscoderPath)`);
    let texture;
    try {
      // parse() takes the buffer: copy the view's bytes out (the worker takes ownership).
      texture = await new Promise((resolve, reject) => {
        ktx2Loader.parse(bytes.slice().buffer, resolve, reject);
      });
    } catch (e) {
      throw new Error(`${file}: cannot decode the KTX2 map (${e && e.message ? e.message : e})`);
    }
    if (!texture.isCompressedTexture && !texture.isDataTexture) throw new Error(`${file}: the KTX2 map is not a 2D texture`);
    return settle(texture, semantic, true);
  }
  const ext = file.slice(file.lastIndexOf('.') + 1).toLowerCase();
  let image;
  try {
    image = await createImageBitmap(new Blob([bytes], { type: MEDIA[ext] || 'image/png' }),
      { premultiplyAlpha: 'none', colorSpaceConversion: 'none' });
  } catch (e) {
    throw new Error(`${file}: cannot decode the image (${e && e.message ? e.message : e})`);
  }
  if (isTextureArray(manifest)) {
    try {
      const { width, height, data } = repackLayerStrip(image, manifest, layoutSide, file);
      return settle(new DataTexture(data, width, height, RGBAFormat, UnsignedByteType), semantic, false);
    } finally {
      image.close();
    }
  }
  return settle(new Texture(image), semantic, false);
}

export function createRgbaKtx2Loader(manager, transcoderPath) {
  const loader = new KTX2Loader(manager);
  loader.setTranscoderPath(transcoderPath);
  loader.workerConfig = { ...RGBA_WORKER_CONFIG };
  return loader;
}
