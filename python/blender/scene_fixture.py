"""The scene both Blender tests bake: a red cone on a blue cube away from the
origin (the only selection, the cone active) and a camera looking at it."""
from __future__ import annotations

import bpy


def make_subject() -> bpy.types.Object:
    """A red cone on a blue cube, away from the origin, the only selection."""
    bpy.ops.object.select_all(action="SELECT")
    bpy.ops.object.delete()  # the factory cube, light and camera
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(2.0, 1.0, 0.5))
    cube = bpy.context.active_object
    bpy.ops.mesh.primitive_cone_add(radius1=0.6, depth=1.5, location=(2.0, 1.0, 1.75))
    cone = bpy.context.active_object
    for obj, colour in ((cube, (0.1, 0.2, 0.9, 1.0)), (cone, (0.9, 0.1, 0.05, 1.0))):
        mat = bpy.data.materials.new(f"{obj.name}_paint")
        mat.use_nodes = True
        mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = colour
        obj.data.materials.append(mat)
    bpy.ops.object.select_all(action="DESELECT")
    cube.select_set(True)
    cone.select_set(True)
    cone.name = "Subject"
    bpy.context.view_layer.objects.active = cone
    bpy.ops.object.camera_add(location=(2.0, -6.0, 2.0), rotation=(1.45, 0.0, 0.0))
    bpy.context.scene.camera = bpy.context.active_object
    bpy.ops.object.select_all(action="DESELECT")
    cube.select_set(True)
    cone.select_set(True)
    bpy.context.view_layer.objects.active = cone
    return cone
