"""The "Impostor" tab of the 3D view's sidebar (N panel)."""
from __future__ import annotations

import bpy

from .properties import settings_of


class VIEW3D_PT_impostor_farm(bpy.types.Panel):
    bl_label = "Impostor Farm"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Impostor"

    def draw(self, context: bpy.types.Context) -> None:
        s = settings_of(context)
        col = self.layout.column()
        col.prop(s, "server")
        col.prop(s, "token_file")
        col.prop(s, "tls_ca")
        col.separator()
        col.prop(s, "product")
        row = col.row()
        row.enabled = s.product in ("atlas", "lod-chain", "surfels")
        row.prop(s, "layout")
        sub = col.row(align=True)
        if s.layout == "ring-top" and s.product != "cards":
            sub.prop(s, "ring_views")
        else:
            # Ring + top and billboard derive their grid; cards have none.
            sub.enabled = s.product != "cards" and s.layout != "billboard"
            sub.prop(s, "frames")
        col.prop(s, "resolution")
        col.prop(s, "output_dir")
        col.separator()
        if s.running:
            col.label(text=s.status or "Baking...", icon="TIME")
            col.operator("impostor.cancel_bake", icon="CANCEL")
        else:
            col.operator("impostor.bake_selected", icon="RENDER_STILL")
            if s.status:
                col.label(text=s.status)
