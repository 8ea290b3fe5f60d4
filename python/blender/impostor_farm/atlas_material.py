"""The material of an imported atlas impostor: a node setup that picks, per
object, the atlas frame nearest the direction toward the camera and maps the
quad's UVs into that frame's tile. No custom engine code: Cycles and Eevee
both draw it.

The object is a quad whose local +Z tracks the camera (a Track To
constraint, up = world Z), so its +Z axis in world space (a Vector Transform
of (0, 0, 1), object to world) is the direction from the impostor toward the
camera. In glTF space (Y up; x, y, z = Blender x, z, -y) that direction is
encoded into the atlas grid exactly as the baker's EncodeFrame does
(common/atlas_layout.cc): octahedral or hemi-octahedral coordinates,
scaled to 0..frames-1 and rounded half up. The tile's up is the view's up
(world up projected), which is the quad's local +Y under the constraint.

Layouts other than octahedral and hemi-octahedral get a fixed frame (the one
nearest the camera at import time); the caller warns about it.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, Tuple, Union

import bpy

Socket = Union[bpy.types.NodeSocket, float]
GRID_LAYOUTS = ("octahedral", "hemi-octahedral")


class _Graph:
    """Small helpers that add math nodes and link them."""

    def __init__(self, tree: bpy.types.NodeTree) -> None:
        self.tree = tree
        self.x = -1800

    def _input(self, node: bpy.types.Node, index: int, value: Socket) -> None:
        if isinstance(value, (int, float)):
            node.inputs[index].default_value = float(value)
        else:
            self.tree.links.new(value, node.inputs[index])

    def math(self, op: str, a: Socket, b: Socket = 0.0, clamp: bool = False) -> bpy.types.NodeSocket:
        node = self.tree.nodes.new("ShaderNodeMath")
        node.operation = op
        node.use_clamp = clamp
        node.location = (self.x, 0)
        self.x += 20
        self._input(node, 0, a)
        self._input(node, 1, b)
        return node.outputs[0]

    def separate(self, vector: bpy.types.NodeSocket) -> Tuple[bpy.types.NodeSocket, ...]:
        node = self.tree.nodes.new("ShaderNodeSeparateXYZ")
        self.tree.links.new(vector, node.inputs[0])
        return node.outputs[0], node.outputs[1], node.outputs[2]

    def combine(self, x: Socket, y: Socket, z: Socket = 0.0) -> bpy.types.NodeSocket:
        node = self.tree.nodes.new("ShaderNodeCombineXYZ")
        for i, v in enumerate((x, y, z)):
            self._input(node, i, v)
        return node.outputs[0]

    def lerp(self, a: Socket, b: Socket, t: Socket) -> bpy.types.NodeSocket:
        return self.math("ADD", a, self.math("MULTIPLY", t, self.math("SUBTRACT", b, a)))

    def sign_not_zero(self, v: Socket) -> bpy.types.NodeSocket:
        return self.math("SUBTRACT", 1.0, self.math("MULTIPLY", 2.0, self.math("LESS_THAN", v, 0.0)))


def _octahedral(g: _Graph, dx: Socket, dy: Socket, dz: Socket) -> Tuple[Socket, Socket]:
    total = g.math("ADD", g.math("ADD", g.math("ABSOLUTE", dx), g.math("ABSOLUTE", dy)), g.math("ABSOLUTE", dz))
    px, py, pz = (g.math("DIVIDE", v, total) for v in (dx, dy, dz))
    lower_x = g.math("MULTIPLY", g.math("SUBTRACT", 1.0, g.math("ABSOLUTE", pz)), g.sign_not_zero(px))
    lower_y = g.math("MULTIPLY", g.math("SUBTRACT", 1.0, g.math("ABSOLUTE", px)), g.sign_not_zero(pz))
    below = g.math("LESS_THAN", py, 0.0)
    return g.lerp(px, lower_x, below), g.lerp(pz, lower_y, below)


def _hemi_octahedral(g: _Graph, dx: Socket, dy: Socket, dz: Socket) -> Tuple[Socket, Socket]:
    up = g.math("MAXIMUM", dy, 0.0)
    total = g.math("ADD", g.math("ADD", g.math("ABSOLUTE", dx), up), g.math("ABSOLUTE", dz))
    total = g.math("MAXIMUM", total, 1e-6)
    return (g.math("DIVIDE", g.math("ADD", dx, dz), total), g.math("DIVIDE", g.math("SUBTRACT", dx, dz), total))


def _grid_cell(g: _Graph, o: Socket, frames: int) -> Socket:
    last = float(frames - 1)
    scaled = g.math("MULTIPLY", g.math("ADD", g.math("MULTIPLY", o, 0.5), 0.5), last)
    clamped = g.math("MINIMUM", g.math("MAXIMUM", scaled, 0.0), last)
    return g.math("FLOOR", g.math("ADD", clamped, 0.5))


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
    g = _Graph(tree)

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
        ox, oy = (_octahedral if layout == "octahedral" else _hemi_octahedral)(g, dx, dy, dz)
        col, row = _grid_cell(g, ox, frames), _grid_cell(g, oy, frames)
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
