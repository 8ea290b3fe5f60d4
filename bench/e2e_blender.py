"""Step 6 of bench/e2e_bench.sh (--blender; bench/compare_blender.sh): Blender
3.4 Cycles rendering a warm bake's own views, timed beside the bake. Used by
e2e_bench.py; not run on its own."""
import json
import os
import re
import subprocess
import time
from pathlib import Path

from e2e_errors import BenchError

# Cycles samples per pixel of the Blender comparison (bench/blender_views.py).
BLENDER_SAMPLES = 16


def blender_env(env):
    """`env` for Debian's Blender: its embedded Python takes its prefix from
    the first `python3` on PATH, so a pyenv or virtualenv Python running this
    bench (which puts its own bin first) would hand it a standard library
    without Debian's numpy, which its glTF importer needs."""
    out = {k: v for k, v in env.items() if not k.startswith("PYENV") and k != "VIRTUAL_ENV"}
    keep = [d for d in env.get("PATH", "").split(os.pathsep)
            if "/.pyenv/" not in d and not (env.get("VIRTUAL_ENV") and d.startswith(env["VIRTUAL_ENV"]))]
    out["PATH"] = os.pathsep.join(keep)
    return out


def render_views(bench, result_dir):
    """Blender 3.4 Cycles (CPU, 16 samples) renders the views the bake
    rendered, at the pixels the bake rendered them (tile size times
    supersampling), read from the result's manifest.json by
    bench/blender_views.py. Timed from process start to exit; with
    --blender-views N only N views are rendered and the render time is
    scaled to all of them (process start and import as measured)."""
    manifest_path = Path(result_dir) / "manifest.json"
    try:
        manifest = json.loads(manifest_path.read_text())
    except (OSError, ValueError) as e:
        raise BenchError("blender", f"cannot read the bake's {manifest_path}: {e}")
    pixels = int(manifest["tile_size"]) * int(manifest.get("supersampling", 2))
    views = len(manifest["views"])
    out = bench.fresh("blender")
    out.mkdir(parents=True)
    limit = bench.a.blender_views
    script = Path(__file__).resolve().parent / "blender_views.py"
    cmd = ["blender", "-b", "--factory-startup", "--python-exit-code", "1", "--python", script, "--",
           bench.model, manifest_path, str(pixels), str(BLENDER_SAMPLES), out, str(limit)]
    t0 = time.perf_counter()
    # Listed in WORK/pids, so the script's trap stops a render of many
    # minutes when the bench is interrupted.
    proc = subprocess.Popen([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=blender_env(bench.env))
    bench.note_pid("blender", proc.pid)
    try:
        stdout, _ = proc.communicate(timeout=3600)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise BenchError("blender", "blender ran past 3600 s")
    finally:
        bench.drop_pid("blender")
    wall = time.perf_counter() - t0
    (bench.logs / "blender.log").write_text(stdout)
    if proc.returncode != 0:
        raise BenchError("blender", f"blender exited {proc.returncode}:\n{stdout[-1500:]}")
    m = re.search(r"^blender_views: .* render_s ([\d.]+)$", stdout, re.M)
    rendered = len(list(Path(out).glob("view_*.png")))
    expected = min(limit, views) if limit > 0 else views
    if m is None or rendered != expected:
        raise BenchError("blender", f"blender wrote {rendered} of {expected} views:\n{stdout[-1500:]}")
    render_s = float(m.group(1))
    seconds, how = wall, "process start to exit"
    if rendered < views:
        seconds = wall - render_s + render_s * views / rendered
        how = f"extrapolated from {rendered} of {views} views ({render_s / rendered:.2f} s a view)"
    return {"seconds": seconds, "how": how, "views": views, "pixels": pixels}

def rows(b, e2e_warm):
    return [
        f"| Blender 3.4 Cycles, CPU, {BLENDER_SAMPLES} samples, the same {b['views']} views at {b['pixels']} px | "
        f"{b['seconds']:.2f} s | {b['how']}; after the warm bakes, on the last one's manifest |",
        f"| **Blender / end to end** (warm) | **{b['seconds'] / e2e_warm:.1f}×** | target ≥ 30 |",
    ]
