// The synthetic test asset's geometry and colours: a box of half extents
// (0.6, 1.0, 0.4) centred at (0, 1, 0), each face its own flat sRGB colour;
// the synthetic result's writer bakes it by hand, the browser test serves it
// as the mesh (boxGlb) to the example page.
export const BOX = Object.freeze({ center: [0, 1, 0], half: [0.6, 1.0, 0.4] });
// sRGB 8-bit albedo by face, in three.js BoxGeometry's group order.
export const FACE_COLOURS = Object.freeze({
  '+x': [220, 60, 50], '-x': [50, 200, 210], '+y': [70, 200, 60], '-y': [200, 60, 200], '+z': [60, 90, 230],
  '-z': [230, 200, 50],
});

const srgbToLinear = (c) => {
  const v = c / 255;
  return v <= 0.04045 ? v / 12.92 : ((v + 0.055) / 1.055) ** 2.4;
};

// The box as a glTF 2.0 binary (the mesh the synthetic result stands for,
// for the example page's ?mesh=): one primitive per face, each with its own
// material (baseColorFactor: the face's colour, linear).
export function boxGlb() {
  const faces = Object.keys(FACE_COLOURS);
  const bin = [];
  let offset = 0;
  const views = [], accessors = [], primitives = [];
  const push = (bytes, target) => {
    views.push({ buffer: 0, byteOffset: offset, byteLength: bytes.byteLength, target });
    bin.push(new Uint8Array(bytes.buffer, bytes.byteOffset, bytes.byteLength));
    offset += bytes.byteLength;
    const pad = (4 - (offset % 4)) % 4;
    if (pad) { bin.push(new Uint8Array(pad)); offset += pad; }
    return views.length - 1;
  };
  faces.forEach((face, k) => {
    const axis = 'xyz'.indexOf(face[1]), sign = face[0] === '+' ? 1 : -1;
    const u = (axis + 1) % 3, v = (axis + 2) % 3;  // u x v = +axis
    const corners = [[-1, -1], [1, -1], [1, 1], [-1, 1]].map(([a, b]) => {
      const p = [...BOX.center];
      p[axis] += sign * BOX.half[axis];
      p[u] += a * BOX.half[u];
      p[v] += b * BOX.half[v];
      return p;
    });
    if (sign < 0) corners.reverse();  // counter-clockwise seen from outside
    const normal = [0, 0, 0];
    normal[axis] = sign;
    const pos = new Float32Array(corners.flat());
    const nrm = new Float32Array([...normal, ...normal, ...normal, ...normal]);
    const lo = [0, 1, 2].map((i) => Math.min(...corners.map((c) => c[i])));
    const hi = [0, 1, 2].map((i) => Math.max(...corners.map((c) => c[i])));
    accessors.push({ bufferView: push(pos, 34962), componentType: 5126, count: 4, type: 'VEC3', min: lo, max: hi });
    accessors.push({ bufferView: push(nrm, 34962), componentType: 5126, count: 4, type: 'VEC3' });
    accessors.push({ bufferView: push(new Uint16Array([0, 1, 2, 0, 2, 3]), 34963), componentType: 5123, count: 6, type: 'SCALAR' });
    primitives.push({ attributes: { POSITION: 3 * k, NORMAL: 3 * k + 1 }, indices: 3 * k + 2, material: k });
  });
  const gltf = {
    asset: { version: '2.0', generator: 'impostor tests/web_package/lib/box_model.mjs' },
    scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }], meshes: [{ primitives }],
    materials: faces.map((f) => ({ name: f, pbrMetallicRoughness: {
      baseColorFactor: [...FACE_COLOURS[f].map(srgbToLinear), 1], metallicFactor: 0, roughnessFactor: 1 } })),
    accessors, bufferViews: views, buffers: [{ byteLength: offset }],
  };
  let json = Buffer.from(JSON.stringify(gltf));
  json = Buffer.concat([json, Buffer.alloc((4 - (json.length % 4)) % 4, 0x20)]);
  const body = Buffer.concat(bin.map((b) => Buffer.from(b)));
  const header = Buffer.alloc(12);
  header.write('glTF', 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(12 + 8 + json.length + 8 + body.length, 8);
  const chunk = (len, type) => {
    const c = Buffer.alloc(8);
    c.writeUInt32LE(len, 0);
    c.write(type, 4, 'latin1');
    return c;
  };
  return Buffer.concat([header, chunk(json.length, 'JSON'), json, chunk(body.length, 'BIN\0'), body]);
}
