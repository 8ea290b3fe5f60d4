"""Brings a downloaded farm result into the scene, next to the object it was
baked from:

- atlas: a camera-facing quad ("<name>_impostor") with the atlas material
  (atlas_material.py), at the bounding sphere's centre, parented to the
  original without moving;
- cards: cards.glb through Blender's glTF importer;
- lod-chain: every mesh level (lodN.glb) through the glTF importer, and the
  impostor level as an atlas quad;
- surfels: surfels.ply through Blender's PLY importer;
each parented to the original (world placement kept), replacing what an
earlier bake of the same original imported under the same name.

The exported selection was in world space (the glTF exporter applies object
transforms and turns Z-up into Y-up), so the manifest's coordinates are
world coordinates in glTF's axes: Blender (x, y, z) = glTF (x, -z, y).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple

import bpy
from mathutils import Vector

from .atlas_material import GRID_LAYOUTS, build_atlas_material


def gltf_to_blender(p: List[float]) -> Vector:
    return Vector((p[0], -p[2], p[1]))


def _parent_keep_world(child: bpy.types.Object, parent: Optional[bpy.types.Object]) -> None:
    if parent is None or child.parent is not None:
        return
    world = child.matrix_world.copy()
    child.parent = parent
    child.matrix_parent_inverse = parent.matrix_world.inverted()
    child.matrix_world = world


def _link_like(obj: bpy.types.Object, original: Optional[bpy.types.Object], context: bpy.types.Context) -> None:
    collections = list(original.users_collection) if original is not None else []
    for c in collections or [context.scene.collection]:
        c.objects.link(obj)


def replace_previous(name: str, original: Optional[bpy.types.Object]) -> None:
    """Removes the result an earlier bake imported under `original` as `name`
    (with everything below it), so baking again replaces it."""
    old = bpy.data.objects.get(name)
    if old is None or original is None or old.parent != original:
        return
    for o in [*old.children_recursive, old]:
        bpy.data.objects.remove(o, do_unlink=True)


def nearest_frame(manifest: Dict[str, Any], toward_camera: Vector) -> int:
    """Index of the baked view whose direction is nearest `toward_camera` (Blender axes)."""
    d = Vector((toward_camera.x, toward_camera.z, -toward_camera.y)).normalized()
    return max(manifest["views"], key=lambda v: d.dot(Vector(v["direction"])))["index"]


def create_atlas_impostor(context: bpy.types.Context, manifest: Dict[str, Any], folder: Path, name: str,
                          original: Optional[bpy.types.Object]) -> Tuple[bpy.types.Object, List[str]]:
    """The camera-facing impostor quad of an atlas result; returns it and warnings."""
    warnings: List[str] = []
    sphere = manifest["bounding_sphere"]
    r = float(sphere["radius"])
    centre = gltf_to_blender(sphere["center"])
    albedo = next(folder / m["file"] for m in manifest["maps"] if m["semantic"] == "albedo_alpha")
    camera = context.scene.camera
    fixed = 0
    if manifest.get("layout") not in GRID_LAYOUTS:
        toward = (camera.matrix_world.translation - centre) if camera is not None else Vector((0, -1, 0))
        fixed = nearest_frame(manifest, toward)
        warnings.append(f"layout {manifest.get('layout')}: the impostor shows the frame nearest the camera "
                        f"at import time ({fixed}); use octahedral or hemi-octahedral for a frame per view")

    replace_previous(name, original)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-r, -r, 0), (r, -r, 0), (r, r, 0), (-r, r, 0)], [], [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    for loop, coord in zip(mesh.loops, [(0, 0), (1, 0), (1, 1), (0, 1)]):
        uv.data[loop.index].uv = coord
    mesh.materials.append(build_atlas_material(name, manifest, albedo, fixed))
    obj = bpy.data.objects.new(name, mesh)
    _link_like(obj, original, context)
    obj.location = centre
    if camera is not None:
        track = obj.constraints.new("TRACK_TO")
        track.target = camera
        track.track_axis = "TRACK_Z"
        track.up_axis = "UP_Y"
    else:
        warnings.append("the scene has no camera: the impostor does not turn to face it")
    obj["impostor_cache_key"] = manifest.get("cache_key", "")
    obj["impostor_result_dir"] = str(folder)
    context.view_layer.update()
    _parent_keep_world(obj, original)
    return obj, warnings


def _numpy_bool_alias() -> None:
    """Blender 3.4's glTF importer uses `numpy.bool`, which NumPy 1.24 (Debian
    12's) removed; the alias it stood for is the builtin bool. Restored only
    when missing, so newer Blenders and older NumPys are untouched."""
    import numpy

    if "bool" not in numpy.__dict__:
        numpy.bool = bool  # type: ignore[attr-defined]


def import_glb(context: bpy.types.Context, path: Path, name: str,
               original: Optional[bpy.types.Object]) -> List[bpy.types.Object]:
    """The objects of a .glb, through Blender's glTF importer, under one object
    called `name` (the .glb's root node, or an empty holding its roots),
    parented to `original`."""
    _numpy_bool_alias()
    replace_previous(name, original)
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=str(path))
    new = [o for o in bpy.data.objects if o not in before]
    roots = [o for o in new if o.parent is None]
    context.view_layer.update()
    if len(roots) == 1:
        roots[0].name = name
        top = roots[0]
    else:  # several nodes: one empty named after the level holds them
        top = bpy.data.objects.new(name, None)
        _link_like(top, original, context)
        for o in roots:
            _parent_keep_world(o, top)
        new.append(top)
    _parent_keep_world(top, original)
    return new


class UnsupportedResult(Exception):
    """A result this Blender cannot show; the message says why and what to bake instead."""


def ktx2_problem(manifest: Dict[str, Any]) -> Optional[str]:
    """Why a KTX2 result cannot be imported, or None for PNG maps. Blender
    (3.4 and later alike) has no KTX2 image loader, so the material would
    show a missing texture: say so instead."""
    ktx2 = [m["file"] for m in manifest.get("maps", []) if str(m.get("file", "")).endswith(".ktx2")]
    if not ktx2:
        return None
    return (f"texture_format ktx2: Blender cannot load KTX2 images ({', '.join(ktx2)}); "
            "bake with texture_format png (the add-on's default, or --texture-format png) to import it")


def import_result(context: bpy.types.Context, folder: Path, base_name: str,
                  original: Optional[bpy.types.Object]) -> Tuple[List[bpy.types.Object], List[str]]:
    """Imports the result in `folder` (manifest.json and its files); returns
    the new objects and warnings for the user."""
    manifest = json.loads((folder / "manifest.json").read_text())
    problem = ktx2_problem(manifest)
    if problem is not None:
        raise UnsupportedResult(f"{problem}; its files are in {folder}")
    product = manifest.get("product", "atlas")
    objects: List[bpy.types.Object] = []
    warnings: List[str] = []
    if product in ("atlas", "", "unspecified"):
        obj, warnings = create_atlas_impostor(context, manifest, folder, f"{base_name}_impostor", original)
        objects.append(obj)
    elif product == "cards":
        objects += import_glb(context, folder / manifest["cards"]["file"], f"{base_name}_cards", original)
    elif product == "lod-chain":
        for level in manifest["lods"]:
            if level["kind"] == "mesh":
                objects += import_glb(context, folder / level["file"], f"{base_name}_LOD{level['level']}", original)
            else:
                atlas = json.loads((folder / level["file"]).read_text())
                obj, w = create_atlas_impostor(context, atlas, folder, f"{base_name}_LOD{level['level']}_impostor",
                                               original)
                objects.append(obj)
                warnings += w
    elif product == "surfels":
        replace_previous(f"{base_name}_surfels", original)
        before = set(bpy.data.objects)
        bpy.ops.import_mesh.ply(filepath=str(folder / manifest["surfels"]["ply_file"]))
        for o in (o for o in bpy.data.objects if o not in before):
            o.name = f"{base_name}_surfels"
            o.rotation_euler = (math.pi / 2, 0.0, 0.0)  # PLY points are in glTF's Y-up axes
            context.view_layer.update()
            _parent_keep_world(o, original)
            objects.append(o)
    else:
        warnings.append(f"product {product!r} is not imported; its files are in {folder}")
    return objects, warnings
