#!/usr/bin/env python3
"""The export-conventions round trip in Godot 3 (issue 41; the conventions:
docs/reference/engine-conventions.md).

The coloured-octant probe (tests/octant_probe.py: a cube whose eight octants
have their own base colour) is baked by a real farm (impostor-server with
one local worker on port 0), published with `impostor publish`, served with
`python3 -m http.server`, and engines/godot/example draws it under xvfb-run
(GLES3 on llvmpipe) from each octant's direction, as the glTF mesh and as the
add-on's Impostor, both unshaded. Asserted per direction, for both: the
colour at the middle of the picture (the corner nearest the camera; median
of 6 x 6 pixels) is that octant's palette entry within COLOUR_TOLERANCE
levels per sRGB channel and no other entry is nearer; the impostor shows the
mesh's octant on its flat pixels, and the silhouettes agree (IoU). A flipped
image row order, another up axis, a mirrored handedness or a map decoded in
the wrong colour space shows another octant or a colour off the palette.

views.png, result.json, Godot's log and the silhouette diff go to
--artifacts DIR. Exit 0 pass, 1 fail, 77 skip (no godot3 or xvfb-run).
Temporary files and processes are removed in every case.
"""
import argparse
import math
import os
import shutil
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
import godot_example_test as harness  # noqa: E402  (the farm, the example's runs, PNG)
import octant_probe  # noqa: E402

from godot_example_test import CHANNEL, SKIP, Failure, Process  # noqa: E402

ASSET = "probes/octant"
SIZE = 192
COLOUR_TOLERANCE = 20      # sRGB levels per channel (palette entries are >= 60 apart somewhere)
WINDOW = 3                 # the middle's median: 2 WINDOW x 2 WINDOW pixels about the centre
# Of the mesh's flat pixels (FLAT_MARGIN_PX from another octant, colour or
# the background), the share where the impostor shows the same octant.
FLAT_MARGIN_PX = 6
MIN_LABEL_AGREEMENT = 0.98
MIN_IOU = 0.95


def log(msg):
    print(f"godot_conventions_test: {msg}", flush=True)


def camera_of(d):
    """(azimuth, elevation) degrees of direction d, as the example places cameras."""
    x, y, z = d
    return math.degrees(math.atan2(x, z)), math.degrees(math.asin(y / math.sqrt(x * x + y * y + z * z)))


def nearest(palette, rgb):
    """(index, largest channel difference) of the palette entry nearest rgb."""
    d = np.abs(palette - np.asarray(rgb, int)[None, :]).max(axis=1)
    return int(d.argmin()), int(d.min())


def labels(palette, cell):
    """Per pixel: the octant shown (within tolerance), -1 off the palette, -2 uncovered."""
    d = np.abs(cell[:, :, None, :3].astype(int) - palette[None, None]).max(axis=3)
    out = d.argmin(axis=2)
    out[d.min(axis=2) > COLOUR_TOLERANCE] = -1
    out[cell[:, :, 3] < 128] = -2
    return out


def check_view(palette, octant, mesh, imp, failures, report):
    name = octant["name"]
    c = SIZE // 2
    for side, cell in (("mesh", mesh), ("impostor", imp)):
        win = cell[c - WINDOW:c + WINDOW, c - WINDOW:c + WINDOW]
        rgb = [int(np.median(win[:, :, k])) for k in range(3)]
        index, off = nearest(palette, rgb)
        got = octant_probe.octant_name(index)
        report.append(f"{name} {side}: middle rgb{tuple(rgb)}, nearest {got} off by {off}; "
                      f"want {name} rgb{tuple(octant['srgb'])}")
        if (win[:, :, 3] < 128).any():
            failures.append(f"{name} {side}: the middle of the picture is not covered")
        elif index != octant["index"] or off > COLOUR_TOLERANCE:
            failures.append(f"{name} {side}: the middle shows rgb{tuple(rgb)} (nearest {got}, off by {off}), "
                            f"want rgb{tuple(octant['srgb'])} within {COLOUR_TOLERANCE}")
    a, b = labels(palette, mesh), labels(palette, imp)
    union = np.count_nonzero((a != -2) | (b != -2))
    iou = np.count_nonzero((a != -2) & (b != -2)) / max(1, union)
    r = FLAT_MARGIN_PX
    flat = a >= 0
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            flat &= np.roll(np.roll(a, dy, axis=0), dx, axis=1) == a
    flat[:r] = flat[-r:] = False
    flat[:, :r] = flat[:, -r:] = False
    agreement = np.count_nonzero(b[flat] == a[flat]) / max(1, np.count_nonzero(flat))
    report.append(f"{name}: silhouette IoU {iou:.4f}, octant agreement {100 * agreement:.2f}% "
                  f"of {np.count_nonzero(flat)} flat pixels")
    if iou < MIN_IOU:
        failures.append(f"{name}: silhouette IoU {iou:.4f} < {MIN_IOU}")
    if agreement < MIN_LABEL_AGREEMENT:
        failures.append(f"{name}: the impostor shows the mesh's octant on {100 * agreement:.2f}% of its flat "
                        f"pixels, want >= {100 * MIN_LABEL_AGREEMENT:g}%")
    return (a != -2), (b != -2)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin-dir", default=os.path.join(REPO, "build", "bin"))
    ap.add_argument("--example", default=os.path.join(REPO, "engines", "godot", "example"))
    ap.add_argument("--artifacts", default="", help="where images and logs go (default: nowhere)")
    ap.add_argument("--godot", default=shutil.which("godot3") or "")
    args = ap.parse_args()

    xvfb = shutil.which("xvfb-run")
    if not args.godot or not os.access(args.godot, os.X_OK) or not xvfb:
        print("SKIP: godot3 and xvfb-run are needed (deploy/install-deps.sh installs godot3, xvfb and xauth); "
              f"godot3: {args.godot or 'not found'}, xvfb-run: {xvfb or 'not found'}", flush=True)
        return SKIP
    server_bin = os.path.join(args.bin_dir, "impostor-server")
    cli = os.path.join(args.bin_dir, "impostor")
    for path in (server_bin, cli, os.path.join(args.bin_dir, "impostor-worker")):
        if not os.path.exists(path):
            raise Failure(f"{path} is missing")

    tmp = tempfile.mkdtemp(prefix="impostor-godot-conventions-")
    artifacts = args.artifacts or os.path.join(tmp, "artifacts")
    os.makedirs(artifacts, exist_ok=True)
    procs = []
    try:
        return run_test(args, tmp, artifacts, procs, server_bin, cli, xvfb)
    finally:
        for p in reversed(procs):
            p.stop()
        shutil.rmtree(tmp, ignore_errors=True)


def run_test(args, tmp, artifacts, procs, server_bin, cli, xvfb):
    t0 = time.monotonic()
    probe = os.path.join(tmp, "octant_probe.glb")
    with open(probe, "wb") as f:
        f.write(octant_probe.probe_glb())
    octants = octant_probe.description()["octants"]
    palette = np.array([o["srgb"] for o in octants], int)
    release = os.path.join(tmp, "mirrors", "release")
    key = harness.bake_and_publish(server_bin, cli, probe, tmp, procs, release, ASSET,
                                   ["--layout", "octahedral", "--frames", "8", "--resolution", "512"])
    log(f"baked and published {ASSET} = {key} in {time.monotonic() - t0:.1f} s")
    web = Process([sys.executable, "-u", "-m", "http.server", "0", "--bind", "127.0.0.1",
                   "--directory", os.path.join(tmp, "mirrors")], "http.server")
    procs.append(web)
    port = web.wait_for("Serving HTTP", 30).split(" port ")[1].split()[0]

    project = os.path.join(tmp, "project")
    shutil.copytree(args.example, project, symlinks=False)
    env = harness.example_env(tmp)
    cameras = [camera_of(o["direction"]) for o in octants]
    code, result, _, out, art = harness.run_example(
        xvfb, args.godot, project, env, tmp, "conventions", artifacts,
        [f"--mirrors=http://127.0.0.1:{port}/release", f"--channel={CHANNEL}", f"--name={ASSET}",
         f"--mesh={probe}", "--scene=0", f"--size={SIZE}",
         "--cameras=" + ";".join(f"{az:.4f},{el:.4f}" for az, el in cameras)])
    if code != 0 or not result.get("ok"):
        raise Failure(f"refused (exit {code}): {result.get('error')}")
    if not all(f["verified"] for f in result["files"]):
        raise Failure(f"unverified files: {result['files']}")
    img = harness.read_png(os.path.join(out, "views.png"))
    if img.shape[:2] != (SIZE * len(octants), 2 * SIZE):
        raise Failure(f"views.png is {img.shape[1]}x{img.shape[0]}, want {2 * SIZE}x{SIZE * len(octants)}")
    failures, report, masks = [], [], []
    for k, octant in enumerate(octants):
        cell = img[k * SIZE:(k + 1) * SIZE]
        masks.append(check_view(palette, octant, cell[:, :SIZE], cell[:, SIZE:], failures, report))
    harness.write_diff(os.path.join(art, "silhouettes.png"), masks)
    for line in report:
        log(line)
    if failures:
        raise Failure("\n".join(failures) + f"\nimages in {art}" if args.artifacts else "\n".join(failures))
    log(f"PASS in {time.monotonic() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Failure as e:
        print(f"FAIL: {e}", flush=True)
        sys.exit(1)
