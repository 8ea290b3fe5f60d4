"""CTest driver of the Blender add-on's headless test (python/CMakeLists.txt):
starts a real impostor-server with one local worker, runs
`blender -b --factory-startup --python test_addon.py` against it and passes
its exit code on. Exit 77 (CTest SKIP) only when no Blender is installed:
deploy/install-deps.sh installs it, so CI always runs this test.

With --ui it runs test_addon_ui.py instead, in Blender's real UI under
Xvfb (xvfb-run), with the worker pause switch the UI test needs; exit 77
when xvfb-run is missing too.

Everything it makes goes into one temporary folder (impostor-blender-*
under $TMPDIR): the farm's data and log, the test's work files, Blender's
own temp files (its TMPDIR: quit.blend) and, when IMPOSTOR_ARTEFACT_DIR is
not set, the artefacts (screenshots). It is removed when the test passes and
kept, its path printed, when it fails; set IMPOSTOR_ARTEFACT_DIR to keep the
artefacts of a passing run.

Usage: run_blender_test.py BLENDER [--ui]
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from farm_process import FarmServer  # noqa: E402

SKIP = 77
# A bound on the whole Blender run (a hang is a failure, not a measurement).
BLENDER_DEADLINE_S = 600


def main() -> int:
    ui = "--ui" in sys.argv[2:]
    blender = shutil.which(sys.argv[1] if len(sys.argv) > 1 else "blender")
    if blender is None:
        print("SKIP: blender is not installed (apt-get install blender, or deploy/install-deps.sh); "
              "the add-on's headless test needs it")
        return SKIP
    xvfb = shutil.which("xvfb-run")
    if ui and xvfb is None:
        print("SKIP: xvfb-run is not installed (apt-get install xvfb xauth, or deploy/install-deps.sh); "
              "the add-on's UI test needs it")
        return SKIP
    root = Path(tempfile.mkdtemp(prefix="impostor-blender-"))
    artefacts = Path(os.environ.get("IMPOSTOR_ARTEFACT_DIR") or root / "artefacts")
    artefacts.mkdir(parents=True, exist_ok=True)
    blender_tmp = root / "tmp"
    blender_tmp.mkdir()
    failed = True
    try:
        pause = root / "pause"
        server = FarmServer(root / "data", env={"IMPOSTOR_WORKER_TEST_PAUSE_FILE": str(pause)})
        try:
            # Blender reads TMP before TMPDIR for its temp folder.
            env = dict(os.environ, IMPOSTOR_TEST_SERVER=server.address, IMPOSTOR_ARTEFACT_DIR=str(artefacts),
                       IMPOSTOR_TEST_WORK=str(root / "work"), IMPOSTOR_TEST_PAUSE_FILE=str(pause),
                       TMPDIR=str(blender_tmp), TMP=str(blender_tmp), TEMP=str(blender_tmp))
            if ui:
                # A .blend on the command line: no splash screen over the UI.
                start_file = root / "start.blend"
                subprocess.run([blender, "-b", "--factory-startup", "--python-expr",
                                f"import bpy; bpy.ops.wm.save_as_mainfile(filepath={str(start_file)!r})"],
                               env=env, stdin=subprocess.DEVNULL, check=True, timeout=BLENDER_DEADLINE_S,
                               stdout=subprocess.DEVNULL)
                argv = [xvfb, "-a", "-s", "-screen 0 1280x800x24", blender, "--factory-startup",
                        "--enable-event-simulate", str(start_file), "--python", str(HERE / "test_addon_ui.py")]
            else:
                argv = [blender, "-b", "--factory-startup", "--python-exit-code", "1",
                        "--python", str(HERE / "test_addon.py")]
            run = subprocess.run(argv, env=env, stdin=subprocess.DEVNULL, timeout=BLENDER_DEADLINE_S)
            failed = run.returncode != 0
            if ui:
                outcome = (artefacts / "ui_result.txt")
                text = outcome.read_text() if outcome.exists() else "no ui_result.txt written"
                print(text)
                failed = failed or not text.startswith("PASS")
            if failed:
                print(f"blender exited with {run.returncode}; server log tail:\n{server.log_tail()}")
            return 1 if failed else 0
        finally:
            server.stop()
    finally:
        if failed:
            print(f"the farm's data and log, the work files and Blender's temp files are kept in {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
