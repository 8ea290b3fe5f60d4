#!/usr/bin/env python3
"""The Godot add-on against a real published release (issue 41, part 2).

Starts a farm (impostor-server with one local worker on port 0), bakes
BoxTextured small, publishes it with `impostor publish` into a temporary
tree, copies that tree with one blob's byte flipped, serves both with
`python3 -m http.server` on 127.0.0.1, and runs engines/godot/example under
xvfb-run (Godot 3, GLES3 on llvmpipe) three times:

  1. mirrors [tampered, good], a fresh cache (the default, user://): every
     file verified and cached there, the tampered blob taken from the good
     mirror after the mismatch is reported; per camera of views.png the impostor's silhouette against
     the mesh's, IoU >= MIN_IOU; the forest of 1024 instances at most
     MAX_FOREST_DRAW_CALLS draw calls;
  2. mirrors [tampered], a fresh cache: refused (exit 1) with an error naming
     the blob, its catalog digest and the digest of the bytes served, and
     nothing drawn in the impostor's cells;
  3. mirrors [a port nobody listens on], run 1's cache: offline, every file
     from the cache, the same silhouettes.

Images and result.json of every run, and per-camera silhouette diffs (white
both, magenta mesh only, cyan impostor only), go to --artifacts DIR.
Exit 0 pass, 1 fail, 77 skip (no godot3 or xvfb-run). Temporary files and
processes are removed in every case (--keep leaves the files).
"""
import argparse
import hashlib
import json
import math
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zlib

import numpy as np

MIN_IOU = 0.95
MIN_MESH_FRACTION = 0.05     # of a view's pixels: the mesh is really there
MAX_FOREST_DRAW_CALLS = 2    # GLES3: depth prepass + colour, whatever the count
ASSET = "props/box"
CHANNEL = "nightly"
SKIP = 77

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))


class Failure(Exception):
    pass


def log(msg):
    print(f"godot_example_test: {msg}", flush=True)


# ---- PNG (8-bit RGB / RGBA, non-interlaced: what Godot's save_png writes) ----

def read_png(path):
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise Failure(f"{path}: not a PNG")
    pos, idat, header = 8, [], None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        pos += 12 + length
    width, height, depth, colour, _, _, interlace = header
    channels = {2: 3, 6: 4}.get(colour)
    if depth != 8 or channels is None or interlace:
        raise Failure(f"{path}: PNG depth {depth} colour type {colour} interlace {interlace} not read here")
    raw = zlib.decompress(b"".join(idat))
    stride = width * channels
    out = bytearray(height * stride)
    prev = bytearray(stride)
    bpp = channels
    for y in range(height):
        kind = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if kind == 1:
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 255
        elif kind == 2:
            line = bytearray((a + b) & 255 for a, b in zip(line, prev))
        elif kind == 3:
            for i in range(stride):
                left = line[i - bpp] if i >= bpp else 0
                line[i] = (line[i] + ((left + prev[i]) >> 1)) & 255
        elif kind == 4:
            for i in range(stride):
                a = line[i - bpp] if i >= bpp else 0
                b = prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        out[y * stride:(y + 1) * stride] = line
        prev = line
    img = np.frombuffer(bytes(out), dtype=np.uint8).reshape(height, width, channels)
    if channels == 3:
        img = np.concatenate([img, np.full((height, width, 1), 255, np.uint8)], axis=2)
    return img


def write_png(path, rgb):
    height, width, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(height))

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


# ---- processes ----

class Process:
    """A child process whose stdout is read line by line in a thread."""

    def __init__(self, argv, name, **kwargs):
        self.name = name
        self.lines = []
        self._cond = threading.Condition()
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     start_new_session=True, **kwargs)
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self):
        for line in self.proc.stdout:
            with self._cond:
                self.lines.append(line.rstrip("\n"))
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def wait_for(self, marker, timeout):
        """The first output line containing `marker`; Failure on exit or timeout."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                for line in self.lines:
                    if marker in line:
                        return line
                if self.proc.poll() is not None and not self._thread.is_alive():
                    raise Failure(f"{self.name} exited ({self.proc.returncode}) before printing '{marker}':\n"
                                  + "\n".join(self.lines[-20:]))
                left = deadline - time.monotonic()
                if left <= 0:
                    raise Failure(f"{self.name}: no '{marker}' within {timeout} s:\n" + "\n".join(self.lines[-20:]))
                self._cond.wait(min(left, 0.5))

    def stop(self):
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGTERM)
                self.proc.wait(timeout=10)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                self.proc.wait()
        self._thread.join(timeout=5)


def processes_with(marker):
    """Pids of the processes whose command line holds `marker`."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmdline = f.read()
            with open(f"/proc/{pid}/stat") as f:
                zombie = f.read().rsplit(")", 1)[1].split()[0] == "Z"
        except (OSError, IndexError):
            continue
        if marker.encode() in cmdline and not zombie:
            found.append(int(pid))
    return found


def stop_strays(marker):
    """Ends any process still running whose command line holds `marker` (a
    path in our temporary directory, so only processes this test started)
    a few seconds after its xvfb-run returned: xvfb-run signals its Xvfb and
    does not wait for it."""
    deadline = time.monotonic() + 5
    while processes_with(marker) and time.monotonic() < deadline:
        time.sleep(0.1)
    for pid in processes_with(marker):
        log(f"stopping stray process {pid} ({marker})")
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def run(argv, what, timeout, **kwargs):
    p = subprocess.run(argv, capture_output=True, text=True, timeout=timeout, **kwargs)
    if p.returncode != 0:
        raise Failure(f"{what} failed ({p.returncode}):\n{p.stdout[-3000:]}\n{p.stderr[-3000:]}")
    return p.stdout


# ---- the checks ----

def silhouettes(views_png, cameras, size):
    img = read_png(views_png)
    if img.shape[0] != size * len(cameras) or img.shape[1] != 2 * size:
        raise Failure(f"{views_png}: {img.shape[1]}x{img.shape[0]}, want {2 * size}x{size * len(cameras)}")
    out = []
    for k in range(len(cameras)):
        cell = img[k * size:(k + 1) * size]
        out.append((cell[:, :size, 3] >= 128, cell[:, size:, 3] >= 128))
    return out


def write_diff(path, masks):
    rows = []
    for mesh, imp in masks:
        rgb = np.zeros(mesh.shape + (3,), np.uint8)
        rgb[mesh & imp] = (255, 255, 255)
        rgb[mesh & ~imp] = (255, 0, 255)
        rgb[~mesh & imp] = (0, 255, 255)
        rows.append(rgb)
    write_png(path, np.concatenate(rows, axis=0))


def check_ious(masks, cameras, label):
    ious = []
    for (mesh, imp), cam in zip(masks, cameras):
        union = np.count_nonzero(mesh | imp)
        iou = np.count_nonzero(mesh & imp) / max(1, union)
        ious.append(iou)
        log(f"{label}: camera az {cam[0]:g} el {cam[1]:g}: IoU {iou:.4f} "
            f"(mesh {np.count_nonzero(mesh)} px, impostor {np.count_nonzero(imp)} px)")
        if np.count_nonzero(mesh) < MIN_MESH_FRACTION * mesh.size:
            raise Failure(f"{label}: camera {cam}: the mesh covers {np.count_nonzero(mesh)} px: nothing to compare")
        if iou < MIN_IOU:
            raise Failure(f"{label}: camera {cam}: silhouette IoU {iou:.4f} < {MIN_IOU}")
    return ious


def bake_and_publish(server_bin, cli, model, tmp, procs, release, name, bake_args):
    """Starts a farm (impostor-server with one local worker on port 0, its
    data under `tmp`), bakes `model` with `bake_args`, publishes it as
    `name` on CHANNEL into the release tree `release` and stops the farm.
    Returns the cache key; Failure naming the step that failed."""
    # Its TMPDIR (and its local workers' scratch) under `tmp`: even a killed
    # worker leaves nothing in /tmp.
    scratch = os.path.join(tmp, "farm.tmp")
    os.makedirs(scratch, exist_ok=True)
    farm = Process([server_bin, "--listen", "127.0.0.1:0", "--data", os.path.join(tmp, "farm"),
                    "--local-workers", "1"], "impostor-server", env=dict(os.environ, TMPDIR=scratch))
    procs.append(farm)
    addr = farm.wait_for("listening on", 60).split("listening on", 1)[1].strip()
    baked = json.loads(run([cli, "bake", model, "--out", os.path.join(tmp, "baked"), "--server", addr,
                            *bake_args, "--json", "--quiet"], "impostor bake", 300))
    key = baked["cache_key"]
    run([cli, "publish", f"{name}={key}", "--channel", CHANNEL, "--out", release, "--server", addr, "--json"],
        "impostor publish", 120)
    farm.stop()
    return key


def example_env(tmp):
    """The environment of the example's runs: Godot's user:// and Mesa's
    shader cache (shared by the runs) under `tmp`, not the user's home."""
    env = dict(os.environ)
    for var in ("XDG_DATA_HOME", "XDG_CONFIG_HOME", "XDG_CACHE_HOME"):
        env[var] = os.path.join(tmp, "xdg", var.lower())
        os.makedirs(env[var])
    env["LC_ALL"] = env["LANG"] = "en_US.UTF-8"  # Godot 3.2 logs an error for locale "C"
    # (Godot 3.2.3 logs a failed make_dir_recursive when it creates this.)
    os.makedirs(os.path.join(env["XDG_DATA_HOME"], "godot", "app_userdata", "Impostor example"))
    return env


def run_example(xvfb, godot, project, env, tmp, label, artifacts, example_args):
    """Runs the example project under xvfb-run with `example_args` (and
    --out=tmp/out_LABEL); copies its log, result.json and PNGs to
    artifacts/LABEL. Returns (exit code, result, log text, out dir, artifact
    dir); Failure when it wrote no result.json."""
    out = os.path.join(tmp, f"out_{label}")
    # The X authority file in our directory (-f): xvfb-run then makes no
    # temporary directory of its own, whose removal can fail and leave
    # Xvfb running (exit 5, the command's status lost). Godot's status
    # goes to a file all the same.
    status_file = os.path.join(tmp, f"status_{label}")
    auth_file = os.path.join(tmp, f"xauth_{label}")
    argv = [xvfb, "-a", "-f", auth_file, "-s", "-screen 0 1024x768x24",
            "sh", "-c", '"$@"; echo $? > "$0"', status_file,
            godot, "--audio-driver", "Dummy", "--path", project, "--", *example_args, f"--out={out}"]
    t = time.monotonic()
    p = subprocess.run(argv, capture_output=True, text=True, timeout=240, env=env)
    log_text = p.stdout + p.stderr
    returncode = p.returncode
    if os.path.exists(status_file):
        with open(status_file) as f:
            returncode = int(f.read().strip())
    stop_strays(auth_file)
    art = os.path.join(artifacts, label)
    shutil.rmtree(art, ignore_errors=True)
    os.makedirs(art)
    with open(os.path.join(art, "godot.log"), "w") as f:
        f.write(log_text)
    result = {}
    if os.path.exists(os.path.join(out, "result.json")):
        with open(os.path.join(out, "result.json")) as f:
            result = json.load(f)
        for name in ("result.json", "views.png", "scene.png"):
            if os.path.exists(os.path.join(out, name)):
                shutil.copy(os.path.join(out, name), art)
    log(f"{label}: godot exited {returncode} in {time.monotonic() - t:.1f} s, "
        f"timings {result.get('timings_ms')}")
    if not result:
        raise Failure(f"{label}: no result.json (exit {returncode}); log in {art}:\n{log_text[-3000:]}")
    return returncode, result, log_text, out, art


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin-dir", default=os.path.join(REPO, "build", "bin"))
    ap.add_argument("--assets-dir", default=os.path.join(REPO, "..", "shared", "assets"))
    ap.add_argument("--model", default="props_pbr/BoxTextured/glTF-Binary/BoxTextured.glb")
    ap.add_argument("--example", default=os.path.join(REPO, "engines", "godot", "example"))
    ap.add_argument("--artifacts", default=os.path.join(tempfile.gettempdir(), "impostor-godot-artifacts"))
    ap.add_argument("--godot", default=shutil.which("godot3") or "")
    ap.add_argument("--keep", action="store_true", help="leave the temporary directory")
    args = ap.parse_args()

    xvfb = shutil.which("xvfb-run")
    if not args.godot or not os.access(args.godot, os.X_OK) or not xvfb:
        print("SKIP: godot3 and xvfb-run are needed (deploy/install-deps.sh installs godot3, xvfb and xauth); "
              f"godot3: {args.godot or 'not found'}, xvfb-run: {xvfb or 'not found'}", flush=True)
        return SKIP
    server_bin = os.path.join(args.bin_dir, "impostor-server")
    cli = os.path.join(args.bin_dir, "impostor")
    model = os.path.join(args.assets_dir, args.model)
    for path in (server_bin, cli, model):
        if not os.path.exists(path):
            raise Failure(f"{path} is missing")

    os.makedirs(args.artifacts, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="impostor-godot-")
    procs = []
    try:
        return run_test(args, tmp, procs, server_bin, cli, model, xvfb)
    finally:
        for p in reversed(procs):
            p.stop()
        if args.keep:
            log(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)


def check_switch_distance(result, release, entry, size):
    """The add-on's good_up_to_pixels is the manifest's, and its switch
    distance is where the bounding sphere's diameter covers that many pixels
    of the views' camera (30 degree fov, `size` px tall), as the C++ SDK's
    SetImpostorSwitchPixels puts it."""
    manifest_file = next(f for f in entry["files"] if f["name"] == "manifest.json")
    with open(os.path.join(release, "v1", "blobs", "sha256", manifest_file["sha256"][:2],
                           manifest_file["sha256"])) as f:
        manifest = json.load(f)
    good = manifest.get("quality", {}).get("good_up_to_pixels", 0)
    if result.get("good_up_to_pixels") != good:
        raise Failure(f"first: good_up_to_pixels {result.get('good_up_to_pixels')}, the manifest says {good}")
    pixels = good if good > 0 else 16
    radius = manifest["bounding_sphere"]["radius"]
    want = 2 * radius * int(size) / (2 * math.tan(math.radians(15.0)) * pixels)
    got = result.get("switch_distance", -1.0)
    if not abs(got - want) <= 1e-4 * want:
        raise Failure(f"first: switch_distance {got}, want {want:.6f} ({pixels} px, radius {radius})")
    log(f"first: good up to {good} px; switch at {got:.4f} (radius {radius:.4f})")


def run_test(args, tmp, procs, server_bin, cli, model, xvfb):
    t0 = time.monotonic()
    # A farm, a small bake, a published release.
    good = os.path.join(tmp, "mirrors", "good")
    key = bake_and_publish(server_bin, cli, model, tmp, procs, good, ASSET, ["--frames", "8", "--resolution", "512"])
    log(f"baked and published {ASSET} = {key} in {time.monotonic() - t0:.1f} s")

    # The tampered copy: one byte of albedo_alpha.png's blob flipped.
    with open(os.path.join(good, "v1", "channels", f"{CHANNEL}.json")) as f:
        catalog_sha = json.load(f)["catalog"]["sha256"]
    with open(os.path.join(good, "v1", "catalogs", "sha256", catalog_sha[:2], catalog_sha)) as f:
        entry = json.load(f)["assets"][ASSET]
    victim = next(f for f in entry["files"] if f["name"] == "albedo_alpha.png")
    tampered = os.path.join(tmp, "mirrors", "tampered")
    shutil.copytree(good, tampered)
    blob = os.path.join(tampered, "v1", "blobs", "sha256", victim["sha256"][:2], victim["sha256"])
    with open(blob, "r+b") as f:
        f.seek(victim["size_bytes"] // 2)
        byte = f.read(1)
        f.seek(victim["size_bytes"] // 2)
        f.write(bytes([byte[0] ^ 0x01]))
    with open(blob, "rb") as f:
        tampered_sha = hashlib.sha256(f.read()).hexdigest()

    web = Process([sys.executable, "-u", "-m", "http.server", "0", "--bind", "127.0.0.1",
                   "--directory", os.path.join(tmp, "mirrors")], "http.server")
    procs.append(web)
    port = web.wait_for("Serving HTTP", 30).split(" port ")[1].split()[0]
    base = f"http://127.0.0.1:{port}"

    # The example project, its add-on copied in (the symlink resolved).
    project = os.path.join(tmp, "project")
    shutil.copytree(args.example, project, symlinks=False)
    env = example_env(tmp)

    def godot(label, mirrors, cache_args, extra=()):
        return run_example(xvfb, args.godot, project, env, tmp, label, args.artifacts,
                           [f"--mirrors={','.join(mirrors)}", f"--channel={CHANNEL}", f"--name={ASSET}",
                            f"--mesh={model}", *cache_args, *extra])

    # 1. The tampered mirror first, then the good one; a fresh cache in the
    # add-on's default place, user:// (under XDG_DATA_HOME here).
    code, result, text, out, art = godot("first", [f"{base}/tampered", f"{base}/good"], [])
    if code != 0 or not result.get("ok"):
        raise Failure(f"first: refused (exit {code}): {result.get('error')}")
    files = {f["name"]: f for f in result["files"]}
    if sorted(files) != sorted(f["name"] for f in entry["files"]):
        raise Failure(f"first: files {sorted(files)}, the catalog lists {[f['name'] for f in entry['files']]}")
    for f in entry["files"]:
        got = files[f["name"]]
        if not got["verified"] or got["sha256"] != f["sha256"] or got["source"] != "network":
            raise Failure(f"first: {f['name']}: {got}")
    if "/good/" not in files["albedo_alpha.png"]["url"]:
        raise Failure(f"first: albedo_alpha.png came from {files['albedo_alpha.png']['url']}, not the good mirror")
    if f"expected {victim['sha256']}, got {tampered_sha}" not in text:
        raise Failure("first: the tampered mirror's mismatch was not reported")
    cameras = result["cameras"]
    size = result["size"]
    check_switch_distance(result, good, entry, size)
    masks = silhouettes(os.path.join(out, "views.png"), cameras, size)
    write_diff(os.path.join(art, "silhouettes.png"), masks)
    ious = check_ious(masks, cameras, "first")
    forest = result.get("forest", {})
    log(f"first: forest of {forest.get('instances')} instances: {forest.get('draw_calls')} draw call(s)")
    if not 0 < forest.get("draw_calls", -1) <= MAX_FOREST_DRAW_CALLS:
        raise Failure(f"first: forest {forest}: want 1..{MAX_FOREST_DRAW_CALLS} draw calls")
    if not os.path.exists(os.path.join(out, "scene.png")):
        raise Failure("first: no scene.png")
    user_cache = os.path.join(env["XDG_DATA_HOME"], "godot", "app_userdata", "Impostor example", "impostor_cache")
    for f in entry["files"]:
        cached = os.path.join(user_cache, "v1", "blobs", "sha256", f["sha256"][:2], f["sha256"])
        if not os.path.exists(cached):
            raise Failure(f"first: {f['name']} is not cached at {cached}")
        with open(cached, "rb") as fh:
            if hashlib.sha256(fh.read()).hexdigest() != f["sha256"]:
                raise Failure(f"first: the cached {f['name']} ({cached}) is not the catalog's bytes")

    # 2. The tampered mirror alone, a fresh cache: refused, nothing drawn.
    code, result, text, out, art = godot("tampered", [f"{base}/tampered"],
                                         [f"--cache-dir={os.path.join(tmp, 'cache_tampered')}"], ["--scene=0"])
    error = result.get("error", "")
    if result.get("ok"):
        raise Failure(f"tampered: a tampered blob was accepted (exit {code}): {result.get('files')}")
    if code != 1:
        raise Failure(f"tampered: refused, but the example exited {code}, want 1")
    for part in ("albedo_alpha.png", victim["sha256"], tampered_sha):
        if part not in error:
            raise Failure(f"tampered: the error does not name {part}: {error}")
    log(f"tampered: refused: {error}")
    masks = silhouettes(os.path.join(out, "views.png"), cameras, size)
    for (mesh, imp), cam in zip(masks, cameras):
        if np.count_nonzero(imp) != 0 or np.count_nonzero(mesh) == 0:
            raise Failure(f"tampered: camera {cam}: impostor {np.count_nonzero(imp)} px, mesh "
                          f"{np.count_nonzero(mesh)} px: want nothing drawn beside the mesh")

    # 3. Offline: no mirror answers; everything from run 1's cache.
    code, result, text, out, art = godot("offline", ["http://127.0.0.1:9"], [], ["--scene=0"])
    if code != 0 or not result.get("ok"):
        raise Failure(f"offline: refused (exit {code}): {result.get('error')}")
    sources = {f["name"]: f["source"] for f in result["files"]}
    if set(sources.values()) != {"cache"}:
        raise Failure(f"offline: sources {sources}, want every file from the cache")
    offline = check_ious(silhouettes(os.path.join(out, "views.png"), cameras, size), cameras, "offline")

    log(f"PASS in {time.monotonic() - t0:.1f} s: IoU min {min(ious):.4f} mean {sum(ious) / len(ious):.4f} "
        f"over {len(ious)} cameras (offline: min {min(offline):.4f}); artifacts in {args.artifacts}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Failure as e:
        print(f"FAIL: {e}", flush=True)
        sys.exit(1)
