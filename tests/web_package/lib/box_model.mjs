// The synthetic test asset's geometry and colours (plain data, loadable by
// Node.js and the browser test page alike): a box of half extents
// (0.6, 1.0, 0.4) centred at (0, 1, 0), each face its own flat sRGB colour.
export const BOX = Object.freeze({ center: [0, 1, 0], half: [0.6, 1.0, 0.4] });
// sRGB 8-bit albedo by face, in three.js BoxGeometry's group order.
export const FACE_COLOURS = Object.freeze({
  '+x': [220, 60, 50], '-x': [50, 200, 210], '+y': [70, 200, 60], '-y': [200, 60, 200], '+z': [60, 90, 230],
  '-z': [230, 200, 50],
});
