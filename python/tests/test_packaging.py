"""`pip install` works offline, from the source tree (setup.py generates the
stubs from proto/) and from the build tree (stubs already generated), and
the installed package carries its stubs and py.typed."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

BUILD_TREE = Path(__file__).resolve().parents[1]  # build/python


def source_tree() -> Path:
    value = os.environ.get("IMPOSTOR_SOURCE_DIR")
    if not value:
        raise RuntimeError("IMPOSTOR_SOURCE_DIR is not set (ctest sets it to the repository)")
    return Path(value)


def pip_install(project: Path, target: Path, env: dict) -> None:
    run = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-build-isolation", "--no-index", "--no-deps",
         "--disable-pip-version-check", "--quiet", "--target", str(target), str(project)],
        capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stdout + run.stderr


def check_installed(target: Path) -> None:
    assert (target / "impostor" / "py.typed").exists()
    for name in ("types_pb2", "bake_service_pb2", "bake_service_pb2_grpc", "asset_service_pb2_grpc"):
        assert (target / "impostor" / "v1" / f"{name}.py").exists(), name
    run = subprocess.run(
        [sys.executable, "-c", "import impostor, impostor.v1.bake_service_pb2_grpc as g; "
                               "print(impostor.__file__, g.BakeServiceStub.__name__)"],
        capture_output=True, text=True, cwd=target, env=dict(os.environ, PYTHONPATH=str(target)))
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith(str(target / "impostor")), run.stdout


@pytest.mark.parametrize("where", ["source", "build"])
def test_pip_install_offline(where: str, tmp_path: Path) -> None:
    env = dict(os.environ, PIP_NO_INDEX="1")
    if where == "source":
        # A copy: an in-tree build leaves build/ and *.egg-info next to setup.py.
        project = tmp_path / "python"
        shutil.copytree(source_tree() / "python", project,
                        ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
        env["IMPOSTOR_PROTO_DIR"] = str(source_tree() / "proto")
        assert not (project / "impostor" / "v1" / "types_pb2.py").exists()  # nothing generated is checked in
    else:
        project = tmp_path / "python"
        shutil.copytree(BUILD_TREE, project, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__",
                                                                           "CMakeFiles", "tests"))
    pip_install(project, tmp_path / "site", env)
    check_installed(tmp_path / "site")


def test_source_install_without_protos_names_the_fix(tmp_path: Path) -> None:
    project = tmp_path / "python"
    shutil.copytree(source_tree() / "python", project,
                    ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    env = dict(os.environ, IMPOSTOR_PROTO_DIR=str(tmp_path / "nowhere"))
    run = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-build-isolation", "--no-index", "--no-deps",
         "--target", str(tmp_path / "site"), str(project)], capture_output=True, text=True, env=env)
    assert run.returncode != 0
    assert "IMPOSTOR_PROTO_DIR" in run.stdout + run.stderr
