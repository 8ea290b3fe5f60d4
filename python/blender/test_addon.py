"""Headless test of the Impostor Farm add-on, run inside Blender by
run_blender_test.py against a real impostor-server:

1. a mesh is baked through the add-on's operator (execute: synchronous);
   the imported impostor object, its material's atlas image and the result's
   files are checked, the files against the manifest's digests;
2. the same bake through the threaded path the UI uses (BakeJob.start, the
   modal operator's poll) is a cache hit;
3. cards: the .glb is imported under the original;
4. bad input (frames=1) becomes a Blender error report with the farm's message;
   a KTX2 result becomes an error report naming the format and how to bake PNG;
5. lod-chain: the mesh levels and the impostor level are imported; surfels:
   the .ply's points, in Blender's axes where the original was;
6. the impostor is rendered with Cycles (kept as impostor_render.png in
   $IMPOSTOR_ARTEFACT_DIR, next to original_render.png of the mesh) and its
   silhouette must match the mesh's;
7. a hemi-octahedral bake replaces the impostor and renders as well.
Before all that, test_atlas_material.py checks the material's frame choice
(the nearest baked frame, in Python and rendered); both bakes' manifests
check the directions it decodes frames to.

Any failed check raises, and Blender exits with 1 (--python-exit-code).
"""
from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
from pathlib import Path

import bpy

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import impostor_farm  # noqa: E402
from impostor_farm import bake_job, operators  # noqa: E402
import test_atlas_material  # noqa: E402
from scene_fixture import make_subject  # noqa: E402

SERVER = os.environ["IMPOSTOR_TEST_SERVER"]
ARTEFACTS = Path(os.environ["IMPOSTOR_ARTEFACT_DIR"])
WORK = Path(os.environ["IMPOSTOR_TEST_WORK"])
# Bound on one bake (a hang is a failure).
BAKE_DEADLINE_S = 300


def check(condition: bool, what: str) -> None:
    if not condition:
        raise AssertionError(what)
    print(f"ok: {what}")


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def configure(product: str = "atlas", frames: int = 4, resolution: int = 128) -> None:
    s = bpy.context.scene.impostor_farm
    s.server = SERVER
    s.product = product
    s.layout = "octahedral"
    s.ring_views = 0
    s.frames = frames
    s.resolution = resolution
    s.output_dir = str(WORK / "results")


def check_atlas_import(original: bpy.types.Object) -> bpy.types.Object:
    impostor = bpy.data.objects.get("Subject_impostor")
    check(impostor is not None, "the impostor object Subject_impostor exists")
    check(impostor.parent == original, "the impostor is parented to the original")
    folder = Path(impostor["impostor_result_dir"])
    manifest = json.loads((folder / "manifest.json").read_text())
    check(impostor["impostor_cache_key"] == manifest["cache_key"], "the object names its cache key")
    for m in manifest["maps"]:
        path = folder / m["file"]
        check(path.stat().st_size == m["digest"]["size_bytes"] and sha256(path) == m["digest"]["hash"],
              f"{m['file']} matches the manifest's digest")
    images = [n.image for n in impostor.active_material.node_tree.nodes if n.type == "TEX_IMAGE"]
    check(len(images) == 1, "the impostor material has one image node")
    image = images[0]
    check(Path(bpy.path.abspath(image.filepath)) == folder / "albedo_alpha.png", "it shows albedo_alpha.png")
    check(tuple(image.size) == (manifest["resolution"], manifest["resolution"]), "the atlas image loaded")
    check(any(c.type == "TRACK_TO" and c.target == bpy.context.scene.camera for c in impostor.constraints),
          "the impostor faces the scene camera")
    bpy.context.view_layer.update()
    centre = manifest["bounding_sphere"]["center"]
    expected = (centre[0], -centre[2], centre[1])
    got = impostor.matrix_world.translation
    check(all(abs(a - b) < 1e-3 for a, b in zip(got, expected)),
          f"the impostor sits at the bounding sphere's centre {expected} (got {tuple(got)})")
    check(abs(got.x - 2.0) < 0.2 and abs(got.y - 1.0) < 0.2, "which is where the original was")
    test_atlas_material.check_frame_directions(manifest)
    return impostor


def render_mask(path: Path) -> list:
    """Renders the scene camera's view to `path`; returns per-pixel coverage
    (alpha > 0.5) and the pixels."""
    bpy.context.scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    check(path.exists(), f"the render was written to {path}")
    img = bpy.data.images.load(str(path))
    px = list(img.pixels)
    bpy.data.images.remove(img)
    return [a > 0.5 for a in px[3::4]], px


def render_and_compare(impostor: bpy.types.Object, original_objects: list, others: list, tag: str) -> None:
    """Renders the original and then the impostor from the scene camera: the
    impostor's silhouette must match the mesh's (IoU over 0.75 at 4 x 4 frames
    of 32 px: about 0.9; the frame seen from below scores 0.48, a blank or
    misplaced impostor near 0) and show the red
    cone. Both renders are kept as artefacts."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 8
    scene.cycles.use_denoising = False  # Debian builds Cycles without OpenImageDenoise
    scene.cycles.device = "CPU"
    scene.render.resolution_x = scene.render.resolution_y = 160
    scene.render.film_transparent = True
    if "Sun" not in bpy.data.objects:
        bpy.ops.object.light_add(type="SUN", location=(0, -4, 6))
    for o in others:
        o.hide_render = True
    impostor.hide_render = True
    for o in original_objects:
        o.hide_render = False
    mesh_mask, _ = render_mask(ARTEFACTS / "original_render.png")
    impostor.hide_render = False
    for o in original_objects:
        o.hide_render = True
    mask, px = render_mask(ARTEFACTS / f"impostor_render{tag}.png")
    covered = sum(mask)
    check(covered > 0.01 * len(mask), f"the impostor covers {covered} of {len(mask)} rendered pixels")
    union = sum(1 for a, b in zip(mask, mesh_mask) if a or b)
    iou = sum(1 for a, b in zip(mask, mesh_mask) if a and b) / max(union, 1)
    check(iou > 0.75, f"the impostor's silhouette matches the mesh's (IoU {iou:.3f} > 0.75)")
    reds = sum(1 for i in range(0, len(px), 4) if px[i + 3] > 0.5 and px[i] > px[i + 2] and px[i] > px[i + 1])
    check(reds > 0, f"its red cone shows ({reds} red pixels)")


def main() -> None:
    impostor_farm.register()
    test_atlas_material.main()
    original = make_subject()
    originals = list(bpy.context.selected_objects)

    # 1. The operator, synchronously.
    configure()
    check(bpy.ops.impostor.bake_selected() == {"FINISHED"}, "Bake selected finished")
    impostor = check_atlas_import(original)
    first_key = impostor["impostor_cache_key"]

    # 2. The threaded path of the UI: the same bake is a cache hit.
    op_settings = operators._bake_settings(bpy.context.scene.impostor_farm)
    model = bake_job.export_selection(WORK)
    job = bake_job.BakeJob(server=SERVER, token_file="", tls_ca="", model=model, out_dir=WORK / "threaded",
                           settings=op_settings)
    job.start()
    check(job.done.wait(BAKE_DEADLINE_S), "the threaded bake ended")
    check(job.error is None, f"the threaded bake succeeded ({job.error})")
    check(job.result.cached and job.result.cache_key == first_key, "it was a cache hit of the same key")
    check(job.snapshot() == ("done", 1.0), "its last status is done")

    # 3. Cards: the .glb imported under the original.
    configure(product="cards", frames=0, resolution=128)
    check(bpy.ops.impostor.bake_selected() == {"FINISHED"}, "Bake selected (cards) finished")
    cards = [o for o in original.children if o.name.startswith("Subject_cards")]
    check(len(cards) == 1, "the cards were imported under the original")
    meshes = [o for o in [cards[0], *cards[0].children_recursive] if o.type == "MESH"]
    check(meshes and len(meshes[0].data.polygons) >= 1, "the cards object has card quads")
    check(sorted(o.name for o in bpy.context.selected_objects) == sorted(o.name for o in originals)
          and bpy.context.view_layer.objects.active == original, "the user's selection is back")

    # 4. A farm error is an error report with the farm's message.
    configure(frames=1)
    try:
        bpy.ops.impostor.bake_selected()
        raise AssertionError("frames=1 was accepted")
    except RuntimeError as e:
        check("INVALID_ARGUMENT" in str(e) and "frames" in str(e), f"the farm's error is reported: {e}")

    # A KTX2 result (Blender loads no KTX2 images) is an error report naming
    # the format and how to bake PNG; the PNG impostor already there stays.
    check(operators._bake_settings(bpy.context.scene.impostor_farm)["texture_format"] == "png",
          "the add-on asks for PNG maps")
    configure()
    png_settings = operators._bake_settings
    operators._bake_settings = lambda s: {**png_settings(s), "texture_format": "ktx2"}
    try:
        bpy.ops.impostor.bake_selected()
        raise AssertionError("a KTX2 result was imported")
    except RuntimeError as e:
        check("ktx2" in str(e) and "Blender cannot load KTX2" in str(e) and "texture_format png" in str(e),
              f"a KTX2 result is reported: {e}")
    finally:
        operators._bake_settings = png_settings
    check(bpy.data.objects["Subject_impostor"]["impostor_cache_key"] == first_key,
          "the PNG impostor was left in place")
    check(bpy.context.scene.impostor_farm.status == "not imported (KTX2)", "the panel says why")

    # Ring + top sends its ring, not Frames (the farm refuses frames with it),
    # and billboard sends neither; an even azimuth-elevation grid and a
    # selection with no mesh are refused before any export or upload.
    configure(frames=8)
    s = bpy.context.scene.impostor_farm
    s.layout, s.ring_views = "ring-top", 8
    ring = operators._bake_settings(s)
    check(ring.get("ring_views") == 8 and "frames" not in ring, f"ring-top sends ring_views only: {ring}")
    s.layout = "billboard"
    check("frames" not in operators._bake_settings(s), "billboard sends no frames")
    s.layout = "azimuth-elevation"
    exports_before = len(list(Path(tempfile.gettempdir()).glob("impostor-export-*")))
    try:
        bpy.ops.impostor.bake_selected()
        raise AssertionError("an even azimuth-elevation grid was sent")
    except RuntimeError as e:
        check("odd Frames" in str(e) and "try 7 or 9" in str(e), f"an even grid is refused locally: {e}")
    light = bpy.data.objects.new("OnlyALight", bpy.data.lights.new("OnlyALight", "POINT"))
    bpy.context.scene.collection.objects.link(light)
    saved = list(bpy.context.selected_objects)
    for o in saved:
        o.select_set(False)
    light.select_set(True)
    try:
        bpy.ops.impostor.bake_selected()
        raise AssertionError("a selection without a mesh was baked")
    except RuntimeError as e:
        check("the selection has no mesh" in str(e), f"a selection without a mesh is refused locally: {e}")
    light.select_set(False)
    for o in saved:
        o.select_set(True)
    bpy.data.objects.remove(light)
    check(len(list(Path(tempfile.gettempdir()).glob("impostor-export-*"))) == exports_before,
          "nothing was exported for either")

    # An unreachable farm is reported within about a second (connection refused).
    configure()
    bpy.context.scene.impostor_farm.server = "127.0.0.1:1"
    try:
        bpy.ops.impostor.bake_selected()
        raise AssertionError("a bake against 127.0.0.1:1 succeeded")
    except RuntimeError as e:
        check("UNAVAILABLE" in str(e) and "127.0.0.1:1" in str(e), f"an unreachable farm is reported: {e}")
    check(len(list(Path(tempfile.gettempdir()).glob("impostor-export-*"))) == exports_before,
          "the exported .glb of a failed bake is removed")

    # 5. LOD chain: the mesh levels as .glb and the impostor level as a quad.
    configure(product="lod-chain", frames=4, resolution=128)
    check(bpy.ops.impostor.bake_selected() == {"FINISHED"}, "Bake selected (lod-chain) finished")
    lods = sorted(o.name for o in original.children if o.name.startswith("Subject_LOD"))
    check(lods == ["Subject_LOD0", "Subject_LOD1", "Subject_LOD2", "Subject_LOD3_impostor"],
          f"the LOD levels were imported under the original: {lods}")
    lod0 = bpy.data.objects["Subject_LOD0"]
    check(sorted(o.type for o in lod0.children) == ["MESH", "MESH"], "LOD0 holds the cube and the cone")

    # Surfels: the point cloud's .ply as a mesh of points, in Blender's axes.
    configure(product="surfels", frames=4, resolution=128)
    check(bpy.ops.impostor.bake_selected() == {"FINISHED"}, "Bake selected (surfels) finished")
    cloud = bpy.data.objects.get("Subject_surfels")
    check(cloud is not None and cloud.parent == original, "the surfel cloud was imported under the original")
    folder = Path(bpy.context.scene.impostor_farm.output_dir)
    manifests = [json.loads(p.read_text()) for p in folder.glob("*/manifest.json")]
    surfels = next(m["surfels"] for m in manifests if m.get("product") == "surfels")
    check(len(cloud.data.vertices) == surfels["point_count"] > 0,
          f"it has the manifest's {surfels['point_count']} points")
    bpy.context.view_layer.update()
    world = [cloud.matrix_world @ v.co for v in cloud.data.vertices]
    lo, hi = surfels["bounds_min"], surfels["bounds_max"]  # glTF axes: Blender (x, -z, y)
    expected_lo = (lo[0], -hi[2], lo[1])
    expected_hi = (hi[0], -lo[2], hi[1])
    got_lo = tuple(min(p[i] for p in world) for i in range(3))
    got_hi = tuple(max(p[i] for p in world) for i in range(3))
    check(all(abs(a - b) < 1e-3 for a, b in zip(got_lo + got_hi, expected_lo + expected_hi)),
          f"the points fill the manifest's box in Blender's axes ({got_lo}..{got_hi})")
    check(abs((got_lo[0] + got_hi[0]) / 2 - 2.0) < 0.1 and abs((got_lo[1] + got_hi[1]) / 2 - 1.0) < 0.1,
          "where the original was")

    # 6. One render of the impostor (and one of the mesh), kept as artefacts.
    extra = [o for o in original.children if o.name.startswith(("Subject_cards", "Subject_LOD", "Subject_surfels"))]
    others = extra + [c for o in extra for c in o.children_recursive]
    render_and_compare(impostor, originals, others, "")

    # 7. Baking again (hemi-octahedral) replaces the impostor; its node path
    # picks frames as well (the camera looks from the upper hemisphere).
    bpy.ops.object.select_all(action="DESELECT")
    for o in originals:
        o.select_set(True)
    bpy.context.view_layer.objects.active = original
    configure()
    bpy.context.scene.impostor_farm.layout = "hemi-octahedral"
    check(bpy.ops.impostor.bake_selected() == {"FINISHED"}, "Bake selected (hemi-octahedral) finished")
    impostors = [o.name for o in bpy.data.objects if o.name.startswith("Subject_impostor")]
    check(impostors == ["Subject_impostor"], f"the new impostor replaced the old one: {impostors}")
    hemi = bpy.data.objects["Subject_impostor"]
    manifest = json.loads((Path(hemi["impostor_result_dir"]) / "manifest.json").read_text())
    check(manifest["layout"] == "hemi-octahedral", "it is the hemi-octahedral bake")
    test_atlas_material.check_frame_directions(manifest)
    render_and_compare(hemi, originals, others, "_hemi")
    print("ALL BLENDER CHECKS PASSED")


main()
