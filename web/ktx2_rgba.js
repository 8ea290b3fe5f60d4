// KTX2 maps (`--texture-format ktx2`: Basis Universal UASTC with the bake's
// own mip chain) decoded to plain RGBA8 for the atlas panel's picture, as
// the viewer's material (impostor-three) decodes them by default. three.js's
// KTX2Loader runs the Basis transcoder that three's npm package ships
// (examples/jsm/libs/basis, served under /static with the rest of three).
// Every transcode target is switched off so the transcoder writes RGBA32:
// the values are the stored ones (sRGB-encoded for albedo), uploaded like
// the PNG's bytes. An engine would transcode to BC7/ASTC/ETC2 instead.
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';

const TRANSCODER_PATH = '/static/node_modules/three/examples/jsm/libs/basis/';
let loader = null;

function rgbaLoader() {
  if (loader === null) {
    loader = new KTX2Loader();
    loader.setTranscoderPath(TRANSCODER_PATH);
    loader.workerConfig = {
      astcSupported: false, astcHDRSupported: false, etc1Supported: false, etc2Supported: false,
      dxtSupported: false, bptcSupported: false, pvrtcSupported: false,
    };
  }
  return loader;
}

export function isKtx2(file) { return file.toLowerCase().endsWith('.ktx2'); }

// {width, height, data: Uint8Array RGBA, rows top first} of level 0.
export async function decodeKtx2Rgba(url) {
  let texture;
  try {
    texture = await rgbaLoader().loadAsync(url);
  } catch (e) {
    throw new Error(`${url}: cannot decode the KTX2 map (${e && e.message ? e.message : e})`);
  }
  const level = texture.mipmaps && texture.mipmaps[0];
  if (!level || !(level.data instanceof Uint8Array) || level.data.length !== level.width * level.height * 4) {
    throw new Error(`${url}: the KTX2 transcoder returned no RGBA8 level 0`);
  }
  texture.dispose();
  return { width: level.width, height: level.height, data: level.data };
}
