"""CTest python_types: `mypy impostor` (strict, as pyproject.toml sets) in the
build tree, where the generated stubs and their .pyi are. Exit 77 (CTest
SKIP) when mypy is not installed; deploy/install-deps.sh installs it."""
import importlib.util
import os
import sys
from pathlib import Path

if importlib.util.find_spec("mypy") is None:
    print("SKIP: mypy is not installed (apt-get install python3-mypy, or deploy/install-deps.sh)")
    sys.exit(77)

from mypy import api  # noqa: E402

os.chdir(Path(__file__).resolve().parents[1])
out, err, status = api.run(["--cache-dir=/dev/null", "impostor"])
print(out + err)
sys.exit(status)
