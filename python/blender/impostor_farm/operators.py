"""IMPOSTOR_OT_bake_selected: export the selection, bake it on the farm,
import the result. From the UI (invoke) the farm round trip runs on a thread
while a modal timer shows progress in the status bar; from scripts and in
background mode (execute) it runs to completion before returning. Farm
errors become Blender error reports carrying the farm's message."""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any, Dict, List, Optional, Set

import bpy

from . import deps
from .bake_job import BakeJob, default_out_dir, export_selection
from .import_result import UnsupportedResult, import_result
from .properties import settings_of


def _bake_settings(s: Any) -> Dict[str, Any]:
    # PNG explicitly: Blender cannot load the KTX2 maps a farm could make.
    settings: Dict[str, Any] = {"product": s.product, "resolution": s.resolution, "texture_format": "png"}
    if s.product != "cards":
        settings["layout"] = s.layout
        if s.layout == "ring-top":
            settings["ring_views"] = s.ring_views  # the grid follows from it
        elif s.layout != "billboard":
            settings["frames"] = s.frames
    return settings


# Object types the glTF exporter turns into triangles.
_GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


def _local_problem(context: bpy.types.Context, s: Any) -> Optional[str]:
    """What the farm would refuse after the export and upload, said at once."""
    if not any(o.type in _GEOMETRY_TYPES for o in context.selected_objects):
        return "Impostor farm: nothing to bake: the selection has no mesh (select the objects to bake)"
    if s.product != "cards" and s.layout == "azimuth-elevation" and s.frames and s.frames % 2 == 0:
        return (f"Impostor farm: azimuth-elevation needs an odd Frames (a row at 0 degrees), got {s.frames}; "
                f"try {s.frames - 1} or {s.frames + 1}")
    return None


def _remove_scratch(job: "BakeJob") -> None:
    """The exported .glb's folder goes once the bake is over; a result folder
    that stayed empty (the bake failed) goes too."""
    shutil.rmtree(job.model.parent, ignore_errors=True)
    try:
        job.out_dir.rmdir()  # only when empty
    except OSError:
        pass


def _error_text(e: BaseException) -> str:
    message = getattr(e, "message", None)
    code = getattr(e, "code", None)
    if message is not None and code is not None:
        return f"Impostor farm: {code.name}: {message}"
    return f"Impostor farm: {type(e).__name__}: {e}"


class IMPOSTOR_OT_bake_selected(bpy.types.Operator):
    """Bake the selected objects into an impostor on the farm and import it"""

    bl_idname = "impostor.bake_selected"
    bl_label = "Bake selected"
    bl_options = {"REGISTER", "UNDO"}

    _job: Optional[BakeJob] = None
    _timer: Any = None
    _original_name: str = ""
    _selection: List[str] = []
    active: Optional[BakeJob] = None  # the bake the cancel operator stops

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        return bool(context.selected_objects) and cls.active is None

    def _prepare(self, context: bpy.types.Context) -> Optional[BakeJob]:
        s = settings_of(context)
        prefs = context.preferences.addons.get(__package__)
        problem = deps.ensure_client(prefs.preferences.client_folder if prefs else "")
        if problem:
            self.report({"ERROR"}, problem)
            return None
        problem = _local_problem(context, s)
        if problem:
            self.report({"ERROR"}, problem)
            return None
        original = context.active_object if context.active_object in context.selected_objects \
            else context.selected_objects[0]
        self._original_name = original.name
        self._selection = [o.name for o in context.selected_objects]
        export_dir = Path(tempfile.mkdtemp(prefix="impostor-export-"))
        try:
            model = export_selection(export_dir)
        except RuntimeError as e:
            shutil.rmtree(export_dir, ignore_errors=True)
            self.report({"ERROR"}, f"glTF export of the selection failed: {e}")
            return None
        return BakeJob(server=s.server, token_file=bpy.path.abspath(s.token_file) if s.token_file else "",
                       tls_ca=bpy.path.abspath(s.tls_ca) if s.tls_ca else "", model=model,
                       out_dir=default_out_dir(s.output_dir), settings=_bake_settings(s))

    def _finish(self, context: bpy.types.Context, job: BakeJob) -> Set[str]:
        _remove_scratch(job)
        s = settings_of(context)
        if job.error is not None:
            if getattr(getattr(job.error, "code", None), "name", "") == "CANCELLED":
                s.status = "cancelled"
                self.report({"WARNING"}, "Impostor farm: the bake was cancelled")
            else:
                s.status = "failed"
                self.report({"ERROR"}, _error_text(job.error))
            return {"CANCELLED"}
        original = bpy.data.objects.get(self._original_name)
        try:
            objects, warnings = import_result(context, job.result.dir, self._original_name, original)
        except UnsupportedResult as e:
            s.status = "not imported (KTX2)"
            self.report({"ERROR"}, f"Impostor farm: {e}")
            return {"CANCELLED"}
        # The glTF importer selects what it imported; the user's selection
        # (what the next bake exports) comes back.
        for o in context.selected_objects:
            o.select_set(False)
        for name in self._selection:
            if name in bpy.data.objects:
                bpy.data.objects[name].select_set(True)
        if original is not None:
            context.view_layer.objects.active = original
        for w in warnings:
            self.report({"WARNING"}, w)
        quality = job.result.quality or {}
        iou = quality.get("silhouette_iou_mean")
        good = quality.get("good_up_to_pixels")  # issue 43; absent before baker 0.2.0-bake6
        s.status = (f"{'cached' if job.result.cached else 'baked'} {job.result.cache_key[:12]}"
                    + (f", IoU {iou:.3f}" if iou is not None else "")
                    + (f", good up to {good} px on screen" if good else ""))
        self.report({"INFO"}, f"Impostor: {s.status}; imported {', '.join(o.name for o in objects)}")
        return {"FINISHED"}

    def execute(self, context: bpy.types.Context) -> Set[str]:
        job = self._prepare(context)
        if job is None:
            return {"CANCELLED"}
        job.run()
        return self._finish(context, job)

    def invoke(self, context: bpy.types.Context, event: Any) -> Set[str]:
        job = self._prepare(context)
        if job is None:
            return {"CANCELLED"}
        self._job = job
        type(self).active = job
        settings_of(context).running = True
        job.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context: bpy.types.Context, event: Any) -> Set[str]:
        if event.type != "TIMER" or self._job is None:
            return {"PASS_THROUGH"}
        status, progress = self._job.snapshot()
        s = settings_of(context)
        s.status = f"Impostor: {status}"
        context.workspace.status_text_set(s.status)
        context.window_manager.progress_update(int(progress * 100))
        for area in context.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()
        if not self._job.done.is_set():
            return {"PASS_THROUGH"}
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        s.running = False
        type(self).active = None
        return self._finish(context, self._job)


class IMPOSTOR_OT_cancel_bake(bpy.types.Operator):
    """Cancel the running farm bake"""

    bl_idname = "impostor.cancel_bake"
    bl_label = "Cancel bake"

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        return IMPOSTOR_OT_bake_selected.active is not None

    def execute(self, context: bpy.types.Context) -> Set[str]:
        job = IMPOSTOR_OT_bake_selected.active
        if job is not None:
            job.cancel()
        return {"FINISHED"}
