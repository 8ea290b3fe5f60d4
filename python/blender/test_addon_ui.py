"""The add-on in Blender's real UI (under Xvfb, run by run_blender_test.py
--ui): "Bake selected" invoked as a click would (INVOKE_DEFAULT) runs modal,
the farm round trip on a thread. The worker is held at its render stage by
a pause file ($IMPOSTOR_TEST_PAUSE_FILE, which the server's workers read as
$IMPOSTOR_WORKER_TEST_PAUSE_FILE) so the test sees, deterministically, that
the UI keeps running during the bake and the status shows the stage; then
the file goes, the bake finishes and the impostor is imported.

Screenshots (kept in $IMPOSTOR_ARTEFACT_DIR): blender_ui_baking.png (the
panel and status bar mid-bake) and blender_ui_result.png (the imported
impostor in material preview). The outcome goes to ui_result.txt ("PASS" or
the failed check), which the runner reads: a timer's exception does not
change Blender's exit code.
"""
from __future__ import annotations

import os
import sys
import time
import traceback
from pathlib import Path

import bpy

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import impostor_farm  # noqa: E402
from impostor_farm.operators import IMPOSTOR_OT_bake_selected  # noqa: E402
from scene_fixture import make_subject  # noqa: E402

SERVER = os.environ["IMPOSTOR_TEST_SERVER"]
ARTEFACTS = Path(os.environ["IMPOSTOR_ARTEFACT_DIR"])
WORK = Path(os.environ["IMPOSTOR_TEST_WORK"])
PAUSE = Path(os.environ["IMPOSTOR_TEST_PAUSE_FILE"])
RESULT = ARTEFACTS / "ui_result.txt"
# Bound on each wait (a hang is a failure, not a measurement).
STEP_DEADLINE_S = 240
POLL_S = 0.2


def check(condition: bool, what: str) -> None:
    if not condition:
        raise AssertionError(what)
    print(f"ok: {what}")


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    region = next(r for r in area.regions if r.type == "WINDOW")
    sidebar = next(r for r in area.regions if r.type == "UI")
    return window, area, region, sidebar


def screenshot(name: str) -> None:
    window, area, region, _ = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.screen.screenshot(filepath=str(ARTEFACTS / name))
    check((ARTEFACTS / name).exists(), f"screenshot {name} written")


class Steps:
    """The test as a sequence of timer callbacks, each returning the seconds
    until it runs again, or moving to the next step."""

    def __init__(self) -> None:
        self.step = self.setup
        self.deadline = 0.0
        self.statuses: list = []

    def __call__(self):
        try:
            if self.deadline and time.monotonic() > self.deadline:
                raise AssertionError(f"step {self.step.__name__} did not finish within {STEP_DEADLINE_S} s")
            done = self.step()
            return POLL_S if not done else self.advance(done)
        except Exception:
            RESULT.write_text("FAIL\n" + traceback.format_exc())
            traceback.print_exc()
            bpy.ops.wm.quit_blender()
            return None

    def advance(self, next_step):
        if next_step is True:
            RESULT.write_text("PASS\n")
            bpy.ops.wm.quit_blender()
            return None
        self.step = next_step
        self.deadline = time.monotonic() + STEP_DEADLINE_S
        return POLL_S

    def setup(self):
        impostor_farm.register()
        original = make_subject()
        s = bpy.context.scene.impostor_farm
        s.server, s.frames, s.resolution, s.output_dir = SERVER, 8, 256, str(WORK / "results")
        window, area, region, sidebar = view3d()
        space = area.spaces.active
        space.show_region_ui = True
        space.shading.type = "MATERIAL"
        with bpy.context.temp_override(window=window, area=area, region=region):
            bpy.ops.view3d.view_selected()
        # The sidebar opens on its first tab (Blender 3.4 has no API to pick
        # one): a click on ours, the fourth of the tab strip at its right edge.
        x = sidebar.x + sidebar.width - 10
        y = sidebar.y + sidebar.height - 167
        window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
        window.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y)
        window.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y)
        PAUSE.write_text("pause")
        self.original = original.name
        return self.invoke

    def invoke(self):
        window, area, region, _ = view3d()
        with bpy.context.temp_override(window=window, area=area, region=region):
            result = bpy.ops.impostor.bake_selected("INVOKE_DEFAULT")
        check(result == {"RUNNING_MODAL"}, f"Bake selected runs modal ({result})")
        return self.wait_for_render

    def wait_for_render(self):
        s = bpy.context.scene.impostor_farm
        self.statuses.append(s.status)
        if not (s.running and "render" in s.status):
            return False
        check(IMPOSTOR_OT_bake_selected.active is not None, "the bake is the active one (cancellable)")
        screenshot("blender_ui_baking.png")
        PAUSE.unlink()
        return self.wait_for_import

    def wait_for_import(self):
        s = bpy.context.scene.impostor_farm
        self.statuses.append(s.status)
        if s.running:
            return False
        impostor = bpy.data.objects.get(f"{self.original}_impostor")
        check(impostor is not None, f"the impostor was imported (status {s.status!r})")
        check(any(t.startswith("Impostor: render") for t in self.statuses),
              "the status showed the render stage while the UI kept running")
        check(s.status.startswith("baked "), f"the panel shows the outcome: {s.status}")
        check(IMPOSTOR_OT_bake_selected.active is None, "no bake is active any more")
        return self.final_screenshot

    def final_screenshot(self):
        # The impostor alone, seen through the camera it faces. An Eevee
        # render first compiles its shader, so the viewport draws it at once.
        original = bpy.data.objects[self.original]
        for o in (original, bpy.data.objects["Cube"]):
            o.hide_set(True)
        scene = bpy.context.scene
        scene.render.engine = "BLENDER_EEVEE"
        scene.render.resolution_x, scene.render.resolution_y = 400, 300
        scene.render.filepath = str(ARTEFACTS / "blender_ui_eevee.png")
        bpy.ops.render.render(write_still=True)
        window, area, region, _ = view3d()
        with bpy.context.temp_override(window=window, area=area, region=region):
            bpy.ops.view3d.view_camera()
        return self.screenshot_after_redraw

    def screenshot_after_redraw(self):
        # One timer tick later: the viewport has redrawn in camera view.
        screenshot("blender_ui_result.png")
        return self.start_cancelled_bake

    def start_cancelled_bake(self):
        """Cancel bake: a second bake (other settings, so no cache hit), held
        at render, is cancelled from the panel's button."""
        for name in (self.original, "Cube"):
            bpy.data.objects[name].hide_set(False)
            bpy.data.objects[name].select_set(True)
        bpy.context.view_layer.objects.active = bpy.data.objects[self.original]
        self.objects_before = set(bpy.data.objects.keys())
        bpy.context.scene.impostor_farm.frames = 6
        PAUSE.write_text("pause")
        return self.invoke_again

    def invoke_again(self):
        window, area, region, _ = view3d()
        with bpy.context.temp_override(window=window, area=area, region=region):
            check(bpy.ops.impostor.bake_selected("INVOKE_DEFAULT") == {"RUNNING_MODAL"}, "the second bake runs")
        return self.cancel_at_render

    def cancel_at_render(self):
        s = bpy.context.scene.impostor_farm
        if not (s.running and "render" in s.status):
            return False
        with bpy.context.temp_override(window=bpy.context.window_manager.windows[0]):
            check(not bpy.ops.impostor.bake_selected.poll(), "Bake selected is disabled while a bake runs")
            check(bpy.ops.impostor.cancel_bake() == {"FINISHED"}, "Cancel bake clicked")
        return self.wait_for_cancelled

    def wait_for_cancelled(self):
        s = bpy.context.scene.impostor_farm
        if s.running:
            return False
        PAUSE.unlink()
        check(s.status == "cancelled", f"the panel says the bake was cancelled ({s.status!r})")
        check(set(bpy.data.objects.keys()) == self.objects_before, "nothing was imported")
        check(IMPOSTOR_OT_bake_selected.active is None, "no bake is active any more")
        return True


RESULT.unlink(missing_ok=True)
bpy.app.timers.register(Steps(), first_interval=1.0)
