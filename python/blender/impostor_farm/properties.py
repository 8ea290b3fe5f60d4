"""The sidebar's settings (stored in the .blend, per scene) and the add-on
preferences."""
from __future__ import annotations

import bpy

PRODUCTS = [
    ("atlas", "Atlas", "Octahedral impostor atlas: a camera-facing quad picking the nearest frame"),
    ("cards", "Cards", "A few textured quads fitted to the mesh (cards.glb)"),
    ("lod-chain", "LOD chain", "Simplified meshes (lodN.glb) and an atlas impostor as the last level"),
    ("surfels", "Surfels", "A point cloud for dense foliage at extreme distance (surfels.ply)"),
]
LAYOUTS = [
    ("octahedral", "Octahedral", "The full sphere of view directions"),
    ("hemi-octahedral", "Hemi-octahedral", "The upper hemisphere only (objects seen from above)"),
    ("azimuth-elevation", "Azimuth-elevation", "Columns = azimuth, rows = elevation"),
    ("ring-top", "Ring + top", "Horizontal views and one from above"),
    ("billboard", "Billboard 3x3", "8 side views and a top view"),
]


class ImpostorFarmSettings(bpy.types.PropertyGroup):
    server: bpy.props.StringProperty(
        name="Farm", description="Address of the impostor-server, host:port", default="localhost:50051")
    token_file: bpy.props.StringProperty(
        name="Token file", description="File holding the bearer token (empty: $IMPOSTOR_TOKEN or none)",
        subtype="FILE_PATH")
    tls_ca: bpy.props.StringProperty(
        name="TLS CA", description="CA certificate (PEM) of a TLS server (empty: plaintext)", subtype="FILE_PATH")
    layout: bpy.props.EnumProperty(name="Layout", items=LAYOUTS, default="octahedral")
    frames: bpy.props.IntProperty(
        name="Frames",
        description="Frames per atlas axis (0 = the farm's default: 12, azimuth-elevation 11; odd for "
                    "azimuth-elevation; ring-top and billboard derive it)",
        default=0, min=0, max=64)
    ring_views: bpy.props.IntProperty(
        name="Ring views", description="Ring + top: horizontal views around the object (0 = the farm's default, 24)",
        default=0, min=0, max=64)
    resolution: bpy.props.IntProperty(
        name="Resolution", description="Atlas side in pixels (0 = the farm's default, 2048)",
        default=0, min=0, max=16384)
    product: bpy.props.EnumProperty(name="Product", items=PRODUCTS, default="atlas")
    output_dir: bpy.props.StringProperty(
        name="Output", description="Folder for downloaded results (empty: a temporary folder)",
        subtype="DIR_PATH")
    # Shown while a bake runs (written by the modal operator only).
    status: bpy.props.StringProperty(name="Status", default="")
    running: bpy.props.BoolProperty(default=False)


class ImpostorFarmPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    client_folder: bpy.props.StringProperty(
        name="Python client folder",
        description="Folder holding the `impostor` package (e.g. the build tree's build/python); "
                    "empty when it is installed",
        subtype="DIR_PATH")

    def draw(self, context: bpy.types.Context) -> None:
        self.layout.prop(self, "client_folder")


def settings_of(context: bpy.types.Context) -> ImpostorFarmSettings:
    return context.scene.impostor_farm
