#!/usr/bin/env python3
"""Where a bake's held-out silhouette IoU goes, pixel by pixel.

    python3 bench/silhouette_trace.py RESULT_DIR

RESULT_DIR holds a result's quality views (`impostor fetch KEY --out DIR`):
view_NN_mesh.png, whose alpha is the share of the mesh's 3 x 3 samples that
cover the pixel, and view_NN_impostor.png; covered is alpha >= 128 in both
(views.json). Prints, over all views: the pixels only one side covers, by
how many of its 9 samples the mesh has there and whether the other side
covers a pixel within 1 px; the IoU against the mesh cut at each t of 9
samples (is the impostor fat or thin?); and each view's IoU with the
impostor shifted by one pixel each way (is a view misregistered?).
docs/quality.md, "GlassVaseFlowers, traced pixel by pixel", is one run.
Standard library only (a plain PNG decoder for the 8-bit RGBA views).
"""
import glob
import os
import struct
import sys
import zlib
from collections import Counter


def read_alpha(path):
    """The alpha channel of an 8-bit RGBA PNG, as a list of rows."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit(f"{path}: not a PNG")
    pos, idat, width, height = 8, b"", 0, 0
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, chunk = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack(">IIBB", chunk[:10])
            if depth != 8 or colour != 6:
                sys.exit(f"{path}: not 8-bit RGBA (bit depth {depth}, colour type {colour})")
        elif kind == b"IDAT":
            idat += chunk
    raw, bpp = zlib.decompress(idat), 4
    stride, rows, prev, i = width * bpp, [], bytearray(width * bpp), 0
    for _ in range(height):
        kind, line = raw[i], bytearray(raw[i + 1:i + 1 + stride])
        i += 1 + stride
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if kind == 1:
                line[x] = (line[x] + a) & 255
            elif kind == 2:
                line[x] = (line[x] + b) & 255
            elif kind == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line[3::4])
        prev = line
    return rows


def near(mask, y, x):
    h, w = len(mask), len(mask[0])
    return any(mask[yy][xx] for yy in range(max(0, y - 1), min(h, y + 2)) for xx in range(max(0, x - 1), min(w, x + 2)))


def iou(mesh, imp, dx=0, dy=0):
    h, w = len(mesh), len(mesh[0])
    both = union = 0
    for y in range(h):
        for x in range(w):
            yy, xx = y + dy, x + dx
            i = imp[yy][xx] if 0 <= yy < h and 0 <= xx < w else False
            union += mesh[y][x] or i
            both += mesh[y][x] and i
    return both / union if union else 1.0


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: python3 bench/silhouette_trace.py RESULT_DIR")
    meshes = sorted(glob.glob(os.path.join(sys.argv[1], "view_*_mesh.png")))
    if not meshes:
        sys.exit(f"{sys.argv[1]}: no view_NN_mesh.png (a result baked with its quality pass)")
    only = {"impostor": Counter(), "mesh": Counter()}
    touching = Counter()
    both = union = 0
    cut = {t: [0, 0] for t in range(1, 10)}
    shifts = []
    for mesh_png in meshes:
        samples = [[round(a * 9 / 255) for a in row] for row in read_alpha(mesh_png)]
        imp = [[a >= 128 for a in row] for row in read_alpha(mesh_png.replace("_mesh.png", "_impostor.png"))]
        mesh = [[k >= 5 for k in row] for row in samples]
        for y, row in enumerate(samples):
            for x, k in enumerate(row):
                m, i = mesh[y][x], imp[y][x]
                union += m or i
                both += m and i
                if i and not m:
                    only["impostor"][k] += 1
                    touching["impostor"] += near(mesh, y, x)
                elif m and not i:
                    only["mesh"][k] += 1
                    touching["mesh"] += near(imp, y, x)
                for t in cut:
                    cut[t][0] += (k >= t) and i
                    cut[t][1] += (k >= t) or i
        scores = {(dx, dy): iou(mesh, imp, dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1)}
        shifts.append((os.path.basename(mesh_png)[:7], scores[(0, 0)], max(scores, key=scores.get)))
    print(f"{len(meshes)} views: covered by both {both}, by either {union}, IoU {both / union:.4f}")
    for side in ("impostor", "mesh"):
        n = sum(only[side].values())
        by_k = ", ".join(f"{k}: {c}" for k, c in sorted(only[side].items()))
        print(f"the {side}'s only: {n} (mesh samples of 9 -> pixels: {by_k}); "
              f"within 1 px of the other silhouette: {touching[side]}")
    print("IoU against the mesh covered by >= t of 9 samples: " +
          ", ".join(f"t={t} {a / b:.4f}" for t, (a, b) in cut.items()))
    for name, score, best in shifts:
        print(f"{name}: IoU {score:.4f}, best one-pixel shift {best}")


if __name__ == "__main__":
    main()
