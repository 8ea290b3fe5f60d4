#!/usr/bin/env python3
"""The coloured-octant probe of the export-conventions round trip (issue 41).

Writes a small glTF 2.0 binary: a cube of side 1 centred at the origin, each
face cut into four quarters, each quarter coloured by the octant it lies in
(the signs of its centre's x, y, z), so that the three quarters meeting at a
corner share that corner's colour. Seen from the octant direction (sx, sy,
sz) the corner is at the middle of the picture: the colour there names the
octant an engine drew from. Eight opaque materials with only a
baseColorFactor (linear, the glTF way), no texture, no UV.

The palette is given in sRGB 8-bit, what a correct engine shows on screen;
its values are mid-tones far apart, so a map decoded as linear (or decoded
twice) lands on no entry. Octant index: 1 * (x < 0) + 2 * (y < 0) + 4 * (z < 0).

Used by tests/web_package/conventions_test.mjs (three.js) and
tests/godot/godot_conventions_test.py (Godot 3):
    python3 tests/octant_probe.py --out probe.glb   # prints the palette as JSON
"""
import argparse
import json
import struct

HALF = 0.5

# sRGB 8-bit, by octant index.
PALETTE = [
    (200, 60, 60),    # +x +y +z  red
    (60, 180, 60),    # -x +y +z  green
    (60, 90, 210),    # +x -y +z  blue
    (210, 190, 60),   # -x -y +z  yellow
    (180, 70, 200),   # +x +y -z  violet
    (60, 190, 200),   # -x +y -z  cyan
    (230, 140, 40),   # +x -y -z  orange
    (128, 128, 128),  # -x -y -z  grey
]


def octant_index(x, y, z):
    return (1 if x < 0 else 0) + (2 if y < 0 else 0) + (4 if z < 0 else 0)


def octant_name(index):
    return "".join(("-" if index & bit else "+") + axis for bit, axis in ((1, "x"), (2, "y"), (4, "z")))


def srgb_to_linear(c):
    c /= 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


def quarters():
    """(octant, normal, four corners counter-clockwise seen from outside) of each quarter face."""
    out = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            # u, v span the face with u x v = n (counter-clockwise from outside).
            u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
            for su in (1.0, -1.0):
                for sv in (1.0, -1.0):
                    corners = []
                    for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = sign * HALF
                        p[u_axis] = su * HALF * a
                        p[v_axis] = sv * HALF * b
                        corners.append(p)
                    # The quad spans (su*u, sv*v): flip its order when that mirrors it.
                    if (sign * su * sv) < 0:
                        corners.reverse()
                    centre = [sum(c[i] for c in corners) / 4 for i in range(3)]
                    out.append((octant_index(*centre), n, corners))
    return out


def probe_glb():
    """The probe as .glb bytes."""
    by_octant = {k: [] for k in range(8)}
    for octant, n, corners in quarters():
        by_octant[octant].append((n, corners))
    bin_chunk = bytearray()
    accessors, views, primitives = [], [], []

    def add_view(data, target):
        while len(bin_chunk) % 4:
            bin_chunk.append(0)
        views.append({"buffer": 0, "byteOffset": len(bin_chunk), "byteLength": len(data), "target": target})
        bin_chunk.extend(data)
        return len(views) - 1

    for octant in range(8):
        positions, normals, indices = [], [], []
        for n, corners in by_octant[octant]:
            base = len(positions)
            positions.extend(corners)
            normals.extend([n] * 4)
            indices.extend([base, base + 1, base + 2, base, base + 2, base + 3])
        pos_view = add_view(b"".join(struct.pack("<3f", *p) for p in positions), 34962)
        nrm_view = add_view(b"".join(struct.pack("<3f", *p) for p in normals), 34962)
        idx_view = add_view(struct.pack(f"<{len(indices)}H", *indices), 34963)
        lo = [min(p[i] for p in positions) for i in range(3)]
        hi = [max(p[i] for p in positions) for i in range(3)]
        accessors.append({"bufferView": pos_view, "componentType": 5126, "count": len(positions), "type": "VEC3",
                          "min": lo, "max": hi})
        accessors.append({"bufferView": nrm_view, "componentType": 5126, "count": len(normals), "type": "VEC3"})
        accessors.append({"bufferView": idx_view, "componentType": 5123, "count": len(indices), "type": "SCALAR"})
        primitives.append({"attributes": {"POSITION": len(accessors) - 3, "NORMAL": len(accessors) - 2},
                           "indices": len(accessors) - 1, "material": octant})
    materials = [{"name": f"octant {octant_name(k)}",
                  "pbrMetallicRoughness": {"baseColorFactor": [*(srgb_to_linear(c) for c in PALETTE[k]), 1.0],
                                           "metallicFactor": 0.0, "roughnessFactor": 1.0}}
                 for k in range(8)]
    while len(bin_chunk) % 4:
        bin_chunk.append(0)
    gltf = {
        "asset": {"version": "2.0", "generator": "impostor tests/octant_probe.py"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"name": "octant_probe", "mesh": 0}],
        "meshes": [{"name": "octant_probe", "primitives": primitives}], "materials": materials,
        "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": len(bin_chunk)}],
    }
    js = json.dumps(gltf, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(bin_chunk), b"BIN\x00") + bytes(bin_chunk)
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def description():
    """What the tests need: the palette by octant, with each octant's unit direction."""
    octants = []
    for k in range(8):
        d = [-1.0 if k & bit else 1.0 for bit in (1, 2, 4)]
        octants.append({"index": k, "name": octant_name(k), "direction": d, "srgb": list(PALETTE[k])})
    return {"half_extent": HALF, "octants": octants}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="the .glb to write")
    args = ap.parse_args()
    with open(args.out, "wb") as f:
        f.write(probe_glb())
    print(json.dumps(description()))


if __name__ == "__main__":
    main()
