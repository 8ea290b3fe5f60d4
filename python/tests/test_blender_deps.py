"""The Blender add-on's dependency finder (python/blender/impostor_farm/deps.py,
plain Python, no bpy): the system's dist-packages are offered only to an
interpreter of the same major.minor version."""
from __future__ import annotations

import importlib.util
import os
import stat
import sys
from pathlib import Path

import pytest

DEPS = Path(__file__).resolve().parents[1] / "blender" / "impostor_farm" / "deps.py"


@pytest.fixture(scope="module")
def deps():
    spec = importlib.util.spec_from_file_location("impostor_farm_deps", DEPS)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def fake_python(tmp_path: Path, version: str, site: Path) -> str:
    """A stand-in `python3` printing `version` and `site` as the real one would."""
    site.mkdir(parents=True, exist_ok=True)
    script = tmp_path / f"python{version}"
    script.write_text(f"#!/bin/sh\nprintf '%s\\n%s\\n' '{version}' '{site}'\n")
    script.chmod(script.stat().st_mode | stat.S_IEXEC)
    return str(script)


def test_same_version_offers_its_site_packages(deps, tmp_path) -> None:
    ours = "%d.%d" % sys.version_info[:2]
    site = tmp_path / "dist-packages"
    assert deps.system_site_dirs(fake_python(tmp_path, ours, site)) == [str(site)]


def test_other_version_offers_nothing(deps, tmp_path) -> None:
    other = "%d.%d" % (sys.version_info[0], sys.version_info[1] + 1)
    assert deps.system_site_dirs(fake_python(tmp_path, other, tmp_path / "dist-packages")) == []


def test_missing_system_python_offers_nothing(deps, tmp_path) -> None:
    assert deps.system_site_dirs(str(tmp_path / "no-python")) == []


def test_the_client_is_found_next_to_the_addon(tmp_path) -> None:
    """With no PYTHONPATH, the add-on in the build tree finds build/python."""
    import subprocess

    code = ("import importlib.util, sys; "
            f"spec = importlib.util.spec_from_file_location('d', {str(DEPS)!r}); "
            "m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m); "
            "assert importlib.util.find_spec('impostor') is None, 'impostor already importable'; "
            "problem = m.ensure_client(); print(problem); "
            "import impostor.client; print(impostor.client.__file__)")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "IMPOSTOR_PYTHONPATH")}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0] == "None"
    assert lines[1] == str(DEPS.parents[2] / "impostor" / "client.py")


def test_a_folder_without_the_client_is_reported(tmp_path) -> None:
    import subprocess

    code = ("import importlib.util; "
            f"spec = importlib.util.spec_from_file_location('d', {str(tmp_path / 'addon' / 'x' / 'deps.py')!r}); "
            "m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m); "
            "print(m.ensure_client('/nonexistent'))")
    (tmp_path / "addon" / "x").mkdir(parents=True)
    (tmp_path / "addon" / "x" / "deps.py").write_text(DEPS.read_text())
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "IMPOSTOR_PYTHONPATH")}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert run.returncode == 0, run.stderr
    assert "the impostor Python client is not importable" in run.stdout
    assert "Python client folder" in run.stdout


def test_real_system_python_matches_debian_blender(deps) -> None:
    """Debian's Blender runs on /usr/bin/python3's version: its dist-packages are offered."""
    if not os.path.exists("/usr/bin/python3") or sys.executable != "/usr/bin/python3":
        pytest.skip("not running on /usr/bin/python3")
    assert any(d.endswith("dist-packages") for d in deps.system_site_dirs())
