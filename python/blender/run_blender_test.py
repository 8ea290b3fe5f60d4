"""CTest driver of the Blender add-on's headless test (python/CMakeLists.txt):
starts a real impostor-server with one local worker, runs
`blender -b --factory-startup --python test_addon.py` against it and passes
its exit code on. Exit 77 (CTest SKIP) only when no Blender is installed:
deploy/install-deps.sh installs it, so CI always runs this test.

Usage: run_blender_test.py BLENDER
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
    blender = shutil.which(sys.argv[1] if len(sys.argv) > 1 else "blender")
    if blender is None:
        print("SKIP: blender is not installed (apt-get install blender, or deploy/install-deps.sh); "
              "the add-on's headless test needs it")
        return SKIP
    artefacts = Path(os.environ.get("IMPOSTOR_ARTEFACT_DIR", tempfile.mkdtemp(prefix="impostor-blender-")))
    artefacts.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="impostor-blender-farm-") as tmp:
        server = FarmServer(Path(tmp) / "data")
        try:
            env = dict(os.environ, IMPOSTOR_TEST_SERVER=server.address, IMPOSTOR_ARTEFACT_DIR=str(artefacts),
                       IMPOSTOR_TEST_WORK=str(Path(tmp) / "work"))
            run = subprocess.run(
                [blender, "-b", "--factory-startup", "--python-exit-code", "1",
                 "--python", str(HERE / "test_addon.py")],
                env=env, stdin=subprocess.DEVNULL, timeout=BLENDER_DEADLINE_S)
            if run.returncode != 0:
                print(f"blender exited with {run.returncode}; server log tail:\n{server.log_tail()}")
            return 1 if run.returncode != 0 else 0
        finally:
            server.stop()


if __name__ == "__main__":
    sys.exit(main())
