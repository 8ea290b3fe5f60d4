"""Impostor Farm: bake the selected objects into impostors on an impostor
bake farm and bring the result back into the scene (see the repository's
README, "Python client and Blender add-on")."""
from __future__ import annotations

bl_info = {
    "name": "Impostor Farm",
    "author": "impostor bake farm",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D View > Sidebar > Impostor",
    "description": "Bake impostor atlases, cards and LOD chains on an impostor bake farm",
    "category": "Import-Export",
}

import bpy  # noqa: E402

from . import operators, panel, properties  # noqa: E402

_CLASSES = (
    properties.ImpostorFarmSettings,
    properties.ImpostorFarmPreferences,
    operators.IMPOSTOR_OT_bake_selected,
    operators.IMPOSTOR_OT_cancel_bake,
    panel.VIEW3D_PT_impostor_farm,
)


def register() -> None:
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.impostor_farm = bpy.props.PointerProperty(type=properties.ImpostorFarmSettings)


def unregister() -> None:
    del bpy.types.Scene.impostor_farm
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
