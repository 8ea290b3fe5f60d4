"""The atlas material's frame choice, headless in Blender, no farm needed:

1. octahedral_frame.nearest_frame, on floats, picks the nearest baked frame
   (compared with every frame's direction) for random directions, directions
   at the octahedron's folded border, below the hemi-octahedron's horizon
   and on the frames themselves, at several grid sizes; the baker's rounding
   (what the material did before) misses on a share of them, which is
   printed;
2. the material's nodes pick the same frame: Cycles renders an imported
   atlas quad (create_atlas_impostor) with the atlas UV as its colour, from
   view directions where rounding picks another frame, and the tile seen
   must be the nearest frame's.

test_addon.py runs it first (ctest blender_addon) and checks decode() against
the directions of real bakes' manifests (check_frame_directions). Alone:
  blender -b --factory-startup --python-exit-code 1 --python test_atlas_material.py
"""
from __future__ import annotations

import math
import random
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, List, Tuple

import bpy
from mathutils import Vector

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

from impostor_farm import octahedral_frame  # noqa: E402
from impostor_farm.import_result import create_atlas_impostor  # noqa: E402
from impostor_farm.node_math import FloatMath  # noqa: E402

Vec = Tuple[float, float, float]
F = FloatMath()
LAYOUTS = ("octahedral", "hemi-octahedral")
# Pure-Python checks per (layout, grid size); the renders are slower.
SAMPLES = 3000
RENDER_FRAMES = 8
RENDERS_PER_LAYOUT = 8
# A frame's dot product with the view must equal the best one to this much
# (float64 throughout, so only rounding noise).
DOT_EPS = 1e-9


def check(condition: bool, what: str) -> None:
    if not condition:
        raise AssertionError(what)
    print(f"ok: {what}")


def dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def unit(v: Vec) -> Vec:
    n = math.sqrt(dot(v, v))
    return (v[0] / n, v[1] / n, v[2] / n)


def angle_deg(a: float) -> float:
    return math.degrees(math.acos(max(-1.0, min(1.0, a))))


def frame_directions(layout: str, frames: int) -> Dict[Tuple[int, int], Vec]:
    """Every frame's direction, through the decode the material's nodes use."""
    last = frames - 1
    return {(c, r): F.separate(octahedral_frame.decode(F, layout, c / last * 2 - 1, r / last * 2 - 1))
            for r in range(frames) for c in range(frames)}


def picked(layout: str, frames: int, d: Vec) -> Tuple[int, int]:
    col, row = octahedral_frame.nearest_frame(F, layout, frames, d)
    return int(col), int(row)


def rounded(layout: str, frames: int, d: Vec) -> Tuple[int, int]:
    """The frame the material showed before: the grid position rounded half up."""
    gx, gy = octahedral_frame.grid_position(F, layout, frames, d)
    return math.floor(gx + 0.5), math.floor(gy + 0.5)


def directions(layout: str, rng: random.Random) -> List[Vec]:
    out = []
    for i in range(SAMPLES):
        d = [rng.gauss(0, 1) for _ in range(3)]
        if i % 3 == 1 and layout == "octahedral":  # next to the fold (z or x ~ 0 below the equator)
            d[1] = -abs(d[1])
            d[rng.choice((0, 2))] *= rng.choice((1e-1, 1e-3, 1e-6, 0.0))
        elif i % 3 == 1:  # below the horizon: shown as the nearest frame on it
            d[1] = -abs(d[1])
        out.append(unit((d[0], d[1], d[2])))
    return out


def check_nearest_in_python() -> None:
    rng = random.Random(20240617)
    for layout in LAYOUTS:
        for frames in (2, 3, 4, 5, 8, 12):
            all_frames = frame_directions(layout, frames)
            tests = directions(layout, rng) + list(all_frames.values())
            misses, rounding_misses, rounding_worst = [], 0, 0.0
            for d in tests:
                best = max(dot(d, f) for f in all_frames.values())
                if dot(d, all_frames[picked(layout, frames, d)]) < best - DOT_EPS:
                    misses.append(d)
                extra = angle_deg(dot(d, all_frames[rounded(layout, frames, d)])) - angle_deg(best)
                if extra > 1e-6:
                    rounding_misses += 1
                    rounding_worst = max(rounding_worst, extra)
            check(not misses, f"{layout} {frames}x{frames}: the nearest frame in all {len(tests)} directions "
                  f"(rounding would miss {100 * rounding_misses / len(tests):.1f} %, up to "
                  f"{rounding_worst:.2f} deg farther); misses: {misses[:3]}")
            if frames == RENDER_FRAMES:
                check(rounding_misses > 0.02 * len(tests), "so rounding is told apart from the nearest frame")


def check_frame_directions(manifest: Dict[str, Any]) -> None:
    """decode() gives the directions the farm baked (the manifest's views)."""
    layout, frames = manifest["layout"], int(manifest["frames"])
    ours = frame_directions(layout, frames)
    worst = max(math.dist(ours[(v["index"] % frames, v["index"] // frames)], v["direction"])
                for v in manifest["views"])
    check(worst < 1e-5, f"{layout} {frames}x{frames}: decode gives the baked view directions (off by {worst:.1e})")


def render_directions(layout: str, frames: int, rng: random.Random) -> List[Vec]:
    """Directions where rounding and the nearest frame differ, with margins
    that float32 in Cycles cannot cross: the best frame leads the other
    candidates, the grid position is off cell and rounding boundaries, and
    the view is off the poles (where Track To has no up)."""
    all_frames = frame_directions(layout, frames)
    out: List[Vec] = []
    while len(out) < RENDERS_PER_LAYOUT:
        d = unit((rng.gauss(0, 1), rng.gauss(0, 1), rng.gauss(0, 1)))
        if abs(d[1]) > 0.95:
            continue
        best = picked(layout, frames, d)
        dots = sorted((dot(d, f) for f in all_frames.values()), reverse=True)
        grid = octahedral_frame.grid_position(F, layout, frames, d)
        near_boundary = any(abs(g * 2 - round(g * 2)) < 2e-3 for g in grid)
        if rounded(layout, frames, d) == best or dots[0] - dots[1] < 1e-4 or near_boundary:
            continue
        out.append(d)
    return out


def atlas_image(folder: Path, frames: int, tile: int) -> Path:
    path = folder / "albedo_alpha.png"
    image = bpy.data.images.new("atlas_material_test", frames * tile, frames * tile, alpha=True)
    image.filepath_raw = str(path)
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)
    return path


def render_uv(scene: bpy.types.Scene, path: Path) -> Tuple[float, float]:
    """The atlas (u, v) seen at the centre of the camera's view."""
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))
    px = list(image.pixels)
    w, h = image.size
    bpy.data.images.remove(image)
    i = 4 * ((h // 2) * w + w // 2)
    return px[i], px[i + 1]


def check_nodes_by_rendering() -> None:
    previous = bpy.context.window.scene
    scene = bpy.data.scenes.new("atlas_material_test")
    bpy.context.window.scene = scene
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 1
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    scene.cycles.filter_width = 0.01  # the centre pixel sees the centre of the quad only
    scene.render.resolution_x = scene.render.resolution_y = 5
    scene.render.image_settings.file_format = "OPEN_EXR"  # linear floats: the UV as rendered
    scene.render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    camera_data = bpy.data.cameras.new("atlas_material_test")
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = 0.2  # the middle tenth of the quad: the middle of the tile
    camera = bpy.data.objects.new("atlas_material_test", camera_data)
    scene.collection.objects.link(camera)
    scene.camera = camera
    rng = random.Random(7)
    frames, tile = RENDER_FRAMES, 16
    with tempfile.TemporaryDirectory(prefix="impostor-atlas-material-") as tmp:
        folder = Path(tmp)
        atlas_image(folder, frames, tile)
        made = []
        for layout in LAYOUTS:
            manifest = {"frames": frames, "tile_size": tile, "resolution": frames * tile, "layout": layout,
                        "bounding_sphere": {"center": [0.0, 0.0, 0.0], "radius": 1.0},
                        "maps": [{"semantic": "albedo_alpha", "file": "albedo_alpha.png"}]}
            quad, _ = create_atlas_impostor(bpy.context, manifest, folder, f"atlas_material_{layout}", None)
            made.append(quad)
            _show_uv(quad.active_material)
            for n, d in enumerate(render_directions(layout, frames, rng)):
                toward = Vector((d[0], -d[2], d[1]))  # glTF (x, y, z) -> Blender (x, -z, y)
                camera.location = toward * 5.0
                # Set, not a Track To: the quad already tracks the camera, and two would be a cycle.
                camera.rotation_euler = (-toward).to_track_quat("-Z", "Y").to_euler()
                u, v = render_uv(scene, folder / f"{layout}_{n}.exr")
                got = (math.floor(u * frames), math.floor((1.0 - v) * frames))
                want, old = picked(layout, frames, d), rounded(layout, frames, d)
                check(got == want, f"{layout}: the material shows frame {got} from {tuple(round(c, 4) for c in d)}: "
                      f"the nearest {want}, not rounding's {old}")
            quad.hide_render = True  # the next layout's quad is at the same place
    bpy.context.window.scene = previous
    _remove(scene, made, camera)


def _remove(scene: bpy.types.Scene, quads: List[bpy.types.Object], camera: bpy.types.Object) -> None:
    """Leaves the file as it was for the tests that follow."""
    materials = [q.active_material for q in quads]
    images = {n.image for m in materials for n in m.node_tree.nodes if n.type == "TEX_IMAGE"}
    data = [q.data for q in quads]
    camera_data = camera.data
    for o in [*quads, camera]:
        bpy.data.objects.remove(o, do_unlink=True)
    for mesh in data:
        bpy.data.meshes.remove(mesh)
    bpy.data.cameras.remove(camera_data)
    for material in materials:
        bpy.data.materials.remove(material)
    for image in images:
        bpy.data.images.remove(image)
    bpy.data.scenes.remove(scene)


def _show_uv(material: bpy.types.Material) -> None:
    """Draws the atlas UV the nodes compute as the quad's emitted colour."""
    tree = material.node_tree
    image_node = next(n for n in tree.nodes if n.type == "TEX_IMAGE")
    uv = image_node.inputs["Vector"].links[0].from_socket
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(uv, emission.inputs["Color"])
    output = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
    tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])


def main() -> None:
    check_nearest_in_python()
    check_nodes_by_rendering()
    print("ATLAS MATERIAL CHECKS PASSED")


if __name__ == "__main__":
    main()
