// One baked impostor ready to draw: its manifest, layout, bounding sphere
// and map textures, plus where every file came from (the loader's report).
// Made by ImpostorLoader; owns its textures (dispose() frees them). Shared
// by any number of ImpostorMaterials and meshes.
import { Sphere, Vector3 } from 'three';
import { atlasLayout, layoutName, productName } from './layout.js';

export class ImpostorAsset {
  // {name, manifest, textures: {albedo, normalDepth, orm}, files, catalog}
  constructor({ name, manifest, textures, files = [], catalog = null }) {
    this.isImpostorAsset = true;
    this.name = name;
    this.key = manifest.cache_key || '';
    this.manifest = manifest;
    this.product = productName(manifest.product);
    this.layout = atlasLayout(manifest);
    this.layoutName = layoutName(manifest.layout);
    const bs = manifest.bounding_sphere;
    this.boundingSphere = new Sphere(new Vector3(...bs.center), bs.radius);
    this.textures = textures;
    // [{name, semantic, sha256, sizeBytes, verified, source: 'cache' | 'network' | 'given', url}]
    this.files = files;
    // {channel, catalogSha256} of the release it came from, null otherwise.
    this.catalog = catalog;
    const q = manifest.quality || {};
    // What the quality pass measured, the material's defaults.
    this.blend = q.blend === 'bilinear4' ? 'bilinear4' : 'triangle3';
    this.reconstruction = 'depth';
    // The on-screen size below which to draw it instead of the mesh
    // (impostorSwitchScale); 0 when the bake did not measure one.
    this.goodUpToPixels = Number.isInteger(q.good_up_to_pixels) && q.good_up_to_pixels > 0 ? q.good_up_to_pixels : 0;
  }

  dispose() {
    for (const t of Object.values(this.textures)) if (t) t.dispose();
  }
}
