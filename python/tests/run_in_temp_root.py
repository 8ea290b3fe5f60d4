"""CTest wrapper of the Python and Blender tests (python/CMakeLists.txt): runs
one command with a temporary root of its own, so a passing test leaves
nothing in /tmp (the Python twin of ScratchRoot() in
tests/support/server_process.cc).

The root is a new folder under $TMPDIR (else /tmp), made like /tmp itself
(mode 1777: the throwaway PostgreSQL server runs as the `postgres` user and
keeps its folder in it). The command and every process it starts get it as
TMPDIR (and TMP, TEMP: Blender reads TMP before TMPDIR), so pytest's
tmp_path, Blender's temp files (quit.blend), xvfb-run's folder and the
scratch folders of impostor-worker processes (default
$TMPDIR/impostor-worker-<pid>; SIGKILLed workers never remove theirs) all
land inside it. The text {root} in an argument is replaced by the root's
path (pytest --basetemp={root}/pytest).

The root is removed when the command exits 0 or 77 (CTest SKIP); otherwise
it is kept and its path printed, with the logs and data of the failed run.

Usage: run_in_temp_root.py NAME -- COMMAND [ARG...]
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import FrameType
from typing import List, Optional

SKIP = 77


def remove(root: Path) -> None:
    # A process SIGKILLed just before the command exited may still finish a
    # write already under way: a second pass takes what it made.
    for attempt in range(3):
        shutil.rmtree(root, ignore_errors=True)
        if not root.exists():
            return
        time.sleep(0.2 * (attempt + 1))
    print(f"run_in_temp_root: could not remove {root}", file=sys.stderr)


def main(argv: List[str]) -> int:
    if len(argv) < 3 or argv[1] != "--":
        print(__doc__, file=sys.stderr)
        return 2
    name, command = argv[0], argv[2:]
    root = Path(tempfile.mkdtemp(prefix=f"impostor-{name}-"))
    os.chmod(root, 0o1777)
    env = dict(os.environ, TMPDIR=str(root), TMP=str(root), TEMP=str(root))
    command = [arg.replace("{root}", str(root)) for arg in command]

    child: Optional["subprocess.Popen[bytes]"] = None

    def forward(signum: int, _frame: Optional[FrameType]) -> None:
        # CTest (a timeout) or a user (Ctrl-C) ends the wrapper: end the test
        # too; it fails, so the root is kept.
        if child is not None and child.poll() is None:
            child.send_signal(signum)

    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
        signal.signal(sig, forward)
    try:
        child = subprocess.Popen(command, env=env)
    except OSError as e:
        print(f"run_in_temp_root: cannot run {command[0]}: {e}", file=sys.stderr)
        remove(root)
        return 1
    status = child.wait()
    sys.stdout.flush()
    if status in (0, SKIP):
        remove(root)
    else:
        print(f"run_in_temp_root: {name} failed (exit status {status}); its temporary files, logs and "
              f"data are kept in {root}", flush=True)
    # A signal's death reads as a failure to CTest, not as success.
    return status if status >= 0 else 128 - status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
