"""Renders a baked result's views with Blender Cycles, for bench/compare_blender.sh.

    blender -b --factory-startup --python bench/blender_views.py -- \
        MESH.glb manifest.json PIXELS SAMPLES OUT_DIR [LIMIT]

Every view of the manifest (direction and up in glTF scene space, the
bounding sphere's centre and radius) becomes one orthographic camera framing
the sphere, as the bake's cameras do (common/atlas/frame_camera.h), rendered
PIXELS x PIXELS with Cycles on the CPU at SAMPLES samples and written as
PNG into OUT_DIR, one file per view (the bake writes its maps too).
LIMIT > 0 renders only that many views, spread evenly over the manifest's
(compare_blender.sh's BLENDER_VIEWS extrapolates from them).
Prints one line: "blender_views: VIEWS views, import_s I, render_s R".
"""

import json
import os
import sys
import time

import bpy
from mathutils import Matrix, Vector


def _numpy_bool_alias():
    # Blender 3.4's glTF importer uses numpy.bool, which NumPy 1.24 removed.
    import numpy

    if not hasattr(numpy, "bool"):
        numpy.bool = bool


def _to_blender(v):
    # The glTF importer turns +Y up into +Z up: (x, y, z) -> (x, -z, y).
    return Vector((v[0], -v[2], v[1]))


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    mesh, manifest_path, pixels, samples, out_dir = args[0], args[1], int(args[2]), int(args[3]), args[4]
    # Optional: render only this many of the views, spread evenly (Cycles
    # needs seconds a view on two cores; the caller extrapolates).
    limit = int(args[5]) if len(args) > 5 else 0
    with open(manifest_path, encoding="utf-8") as f:
        manifest = json.load(f)
    sphere = manifest["bounding_sphere"]
    centre = _to_blender(sphere["center"])
    radius = float(sphere["radius"])
    views = manifest["views"]
    if 0 < limit < len(views):
        views = [views[i * len(views) // limit] for i in range(limit)]

    start = time.monotonic()
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    _numpy_bool_alias()
    bpy.ops.import_scene.gltf(filepath=mesh)
    import_seconds = time.monotonic() - start

    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x = pixels
    scene.render.resolution_y = pixels
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    cam_data = bpy.data.cameras.new("bake")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = 2.0 * radius
    cam_data.clip_start = radius * 0.01
    cam_data.clip_end = radius * 4.0
    camera = bpy.data.objects.new("bake", cam_data)
    scene.collection.objects.link(camera)
    scene.camera = camera

    start = time.monotonic()
    for view in views:
        d = _to_blender(view["direction"]).normalized()
        up = _to_blender(view["up"]).normalized()
        right = up.cross(d)
        # Blender cameras look down their local -Z with +Y up.
        rotation = Matrix((right, up, d)).transposed().to_4x4()
        camera.matrix_world = Matrix.Translation(centre + d * (2.0 * radius)) @ rotation
        scene.render.filepath = os.path.join(out_dir, "view_%03d.png" % int(view.get("index", 0)))
        bpy.ops.render.render(write_still=True)
    render_seconds = time.monotonic() - start
    print("blender_views: %d views, import_s %.2f, render_s %.2f" % (len(views), import_seconds, render_seconds),
          flush=True)


main()
