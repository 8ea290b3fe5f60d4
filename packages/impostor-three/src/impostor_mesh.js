// The card an impostor is drawn on, and the two meshes that draw it:
// ImpostorMesh (one object) and InstancedImpostorMesh (any number of
// instances in one draw call: each instance's frames and weights are chosen
// in the vertex shader from the direction to the camera, so instances may
// be rotated and scaled freely). The card's four corners are placed by the
// shader; the geometry's bounds are the asset's bounding sphere, so frustum
// culling and raycasting see the object, not the card.
import {
  Box3, BufferGeometry, Float32BufferAttribute, InstancedBufferAttribute, InstancedMesh, Matrix4, Mesh, Sphere, Vector3,
} from 'three';
import { ImpostorMaterial } from './impostor_material.js';

// Four corners (x, y in -1..1: the card's right and up), two triangles.
export class ImpostorCardGeometry extends BufferGeometry {
  constructor(asset) {
    super();
    this.type = 'ImpostorCardGeometry';
    this.setAttribute('position', new Float32BufferAttribute([-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0], 3));
    this.setIndex([0, 1, 2, 0, 2, 3]);
    this.impostorSphere = asset.boundingSphere.clone();
    this.computeBoundingSphere();
    this.computeBoundingBox();
  }

  computeBoundingSphere() {
    this.boundingSphere = this.impostorSphere.clone();
  }

  computeBoundingBox() {
    this.boundingBox = this.impostorSphere.getBoundingBox(new Box3());
  }
}

const sphere = new Sphere();
const point = new Vector3();
const matrix = new Matrix4();

function raycastSphere(object, raycaster, worldMatrix, intersects, instanceId) {
  sphere.copy(object.geometry.boundingSphere).applyMatrix4(worldMatrix);
  if (raycaster.ray.intersectSphere(sphere, point) === null) return;
  const distance = raycaster.ray.origin.distanceTo(point);
  if (distance < raycaster.near || distance > raycaster.far) return;
  const hit = { distance, point: point.clone(), object };
  if (instanceId !== undefined) hit.instanceId = instanceId;
  intersects.push(hit);
}

const asMaterial = (asset, m) => (m && m.isImpostorMaterial ? m : new ImpostorMaterial(asset, m || {}));

export class ImpostorMesh extends Mesh {
  // material: an ImpostorMaterial, or its parameters.
  constructor(asset, material) {
    const m = asMaterial(asset, material);
    super(new ImpostorCardGeometry(asset), m);
    this.isImpostorMesh = true;
    this.type = 'ImpostorMesh';
    this.asset = asset;
    this.customDepthMaterial = m.depthMaterial;
  }

  // Hits the object's bounding sphere.
  raycast(raycaster, intersects) {
    raycastSphere(this, raycaster, this.matrixWorld, intersects);
  }
}

export class InstancedImpostorMesh extends InstancedMesh {
  // count: instances (setMatrixAt as for any InstancedMesh, then
  // computeBoundingSphere() for frustum culling); material: an
  // ImpostorMaterial, or its parameters.
  constructor(asset, count, material) {
    const m = asMaterial(asset, material);
    super(new ImpostorCardGeometry(asset), m, count);
    this.isInstancedImpostorMesh = true;
    this.type = 'InstancedImpostorMesh';
    this.asset = asset;
    this.customDepthMaterial = m.depthMaterial;
    // Per instance (t, seed) for a material with crossFade: t 1 (the whole
    // impostor) until setFadeAt, seed the instance's index.
    const fade = new Float32Array(count * 2);
    for (let i = 0; i < count; ++i) fade.set([1, i], i * 2);
    this.geometry.setAttribute('impostorFade', new InstancedBufferAttribute(fade, 2));
  }

  // Instance `index`'s cross-fade at the LOD switch (material.crossFade):
  // t 0 draws none of it (its mesh draws every pixel), 1 all of it, between
  // the share the dither gives the impostor (crossFadeFactor gives t from
  // the on-screen size); seed (an integer, 0 .. 2^24 - 1; default the
  // index) must be the one the instance's mesh is drawn with.
  setFadeAt(index, t, seed = index) {
    const a = this.geometry.getAttribute('impostorFade');
    a.setXY(index, t, seed);
    a.needsUpdate = true;
    return this;
  }

  // [t, seed] of instance `index`.
  getFadeAt(index) {
    const a = this.geometry.getAttribute('impostorFade');
    return [a.getX(index), a.getY(index)];
  }

  // Hits each instance's bounding sphere (instanceId set).
  raycast(raycaster, intersects) {
    for (let i = 0; i < this.count; ++i) {
      this.getMatrixAt(i, matrix);
      raycastSphere(this, raycaster, matrix.premultiply(this.matrixWorld), intersects, i);
    }
  }
}
