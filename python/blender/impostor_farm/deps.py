"""Makes the `impostor` Python client and grpcio importable inside Blender.

Blender from Debian (3.4) runs on the system Python 3.11, so Debian's
python3-grpcio and python3-protobuf import as they are. Blender from
blender.org bundles its own Python: when its major.minor version equals the
system python3's, the system's dist-packages folders are added to sys.path
(the compiled grpc module then matches). Otherwise install grpcio and
protobuf into Blender's Python (`<blender>/3.x/python/bin/python3.x -m pip
install grpcio protobuf`).

The `impostor` package itself is found, in this order: already importable;
the add-on preference "Python client folder" / $IMPOSTOR_PYTHONPATH (a folder
holding the `impostor` package, e.g. the build tree's build/python); the
folder next to this add-on (python/, when the add-on is used from the
repository's build tree).
"""
from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path
from typing import List, Optional

_SYSTEM_PYTHON = "/usr/bin/python3"


def system_site_dirs(system_python: str = _SYSTEM_PYTHON) -> List[str]:
    """The site-packages folders of `system_python` when its major.minor
    version is ours (compiled modules such as grpc's then load); else []."""
    if not os.path.exists(system_python):
        return []
    try:
        out = subprocess.run(
            [system_python, "-c",
             "import sys, site; print('%d.%d' % sys.version_info[:2]); print('\\n'.join(site.getsitepackages()))"],
            capture_output=True, text=True, timeout=10, check=True,
        ).stdout.splitlines()
    except (OSError, subprocess.SubprocessError):
        return []
    if not out or out[0] != "%d.%d" % sys.version_info[:2]:
        return []
    return [d for d in out[1:] if os.path.isdir(d)]


def _add_path(path: str) -> None:
    if path and path not in sys.path:
        sys.path.append(path)


def ensure_client(client_folder: str = "") -> Optional[str]:
    """Imports grpc and impostor, extending sys.path as described above.
    Returns None when they import, else a message for the user saying what
    is missing and how to get it."""
    try:
        importlib.import_module("grpc")
    except ImportError:
        for d in system_site_dirs():
            _add_path(d)
        try:
            importlib.import_module("grpc")
        except ImportError:
            return ("grpcio is not importable from Blender's Python %d.%d; install python3-grpcio and "
                    "python3-protobuf (Debian) or pip-install grpcio and protobuf into Blender's Python"
                    % sys.version_info[:2])
    try:
        importlib.import_module("impostor.client")
        return None
    except ImportError:
        pass
    candidates = [client_folder, os.environ.get("IMPOSTOR_PYTHONPATH", ""),
                  str(Path(__file__).resolve().parents[2])]
    for c in candidates:
        if c and (Path(c) / "impostor" / "v1" / "bake_service_pb2.py").exists():
            _add_path(c)
            break
    try:
        importlib.import_module("impostor.client")
    except ImportError as e:
        return ("the impostor Python client is not importable (%s); pip-install it (pip install ./python) or "
                "set the add-on's 'Python client folder' to the build tree's build/python" % e)
    return None
