"""The material of an imported atlas impostor: a node setup that picks, per
object, the atlas frame nearest the direction toward the camera and maps the
quad's UVs into that frame's tile. No custom engine code: Cycles and Eevee
both draw it.

The object is a quad whose local +Z tracks the camera (a Track To
constraint, up = world Z), so its +Z axis in world space (a Vector Transform
of (0, 0, 1), object to world) is the direction from the impostor toward the
camera. In glTF space (Y up; x, y, z = Blender x, z, -y) the frame whose
baked direction is nearest to it is the one the runtime shows
(octahedral_frame.py). The tile's up is the view's up (world up projected),
which is the quad's local +Y under the constraint.

Layouts other than octahedral and hemi-octahedral get a fixed frame (the one
nearest the camera at import time); the caller warns about it.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict

import bpy

from . import octahedral_frame
from .node_math import NodeMath

GRID_LAYOUTS = ("octahedral", "hemi-octahedral")


def build_atlas_material(name: str, manifest: Dict[str, Any], albedo: Path,
                         fixed_frame: int = 0) -> bpy.types.Material:
    """A material drawing the atlas `albedo` (albedo_alpha.png) on a unit-UV
    quad. fixed_frame: the frame shown for layouts the nodes do not encode."""
    frames = int(manifest["frames"])
    tile = float(manifest["tile_size"])
    width = height = float(manifest["resolution"])
    layout = manifest.get("layout", "octahedral")

    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat.blend_method = "CLIP"
    mat.shadow_method = "CLIP"
    tree = mat.node_tree
    tree.nodes.clear()
    g = NodeMath(tree)

    texcoord = tree.nodes.new("ShaderNodeTexCoord")
    s, t, _ = g.separate(texcoord.outputs["UV"])
    if layout in GRID_LAYOUTS:
        toward = tree.nodes.new("ShaderNodeVectorTransform")
        toward.vector_type = "VECTOR"
        toward.convert_from = "OBJECT"
        toward.convert_to = "WORLD"
        toward.inputs["Vector"].default_value = (0.0, 0.0, 1.0)
        bx, by, bz = g.separate(toward.outputs["Vector"])
        dx, dy, dz = bx, bz, g.math("MULTIPLY", by, -1.0)  # Blender Z-up -> glTF Y-up
        col, row = octahedral_frame.nearest_frame(g, layout, frames, (dx, dy, dz))
    else:
        col, row = float(fixed_frame % frames), float(fixed_frame // frames)
    # Tile (col, row) spans [col, col + 1] x [row, row + 1] tiles from the
    # image's top-left; Blender's v grows upward.
    u = g.math("DIVIDE", g.math("MULTIPLY", g.math("ADD", col, s), tile), width)
    v_from_top = g.math("DIVIDE", g.math("MULTIPLY", g.math("SUBTRACT", g.math("ADD", row, 1.0), t), tile), height)
    v = g.math("SUBTRACT", 1.0, v_from_top)

    image_node = tree.nodes.new("ShaderNodeTexImage")
    image = bpy.data.images.load(str(albedo), check_existing=True)
    image.alpha_mode = "STRAIGHT"
    image_node.image = image
    image_node.interpolation = "Linear"
    image_node.extension = "CLIP"
    tree.links.new(g.combine(u, v), image_node.inputs["Vector"])
    image_node.location = (g.x + 200, 0)

    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.location = (g.x + 500, 0)
    tree.links.new(image_node.outputs["Color"], bsdf.inputs["Base Color"])
    tree.links.new(image_node.outputs["Alpha"], bsdf.inputs["Alpha"])
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    out.location = (g.x + 800, 0)
    tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return mat
