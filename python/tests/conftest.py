"""Fixtures: a real impostor-server with one local worker, shared by the
tests of a session, a throwaway PKI, and helpers to check downloaded files."""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any, Dict, Iterator, List, Sequence, Union

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from farm_process import FarmServer, assets_dir  # noqa: E402


@pytest.fixture(scope="session")
def assets() -> Path:
    return assets_dir()


@pytest.fixture(scope="session")
def farm(tmp_path_factory: pytest.TempPathFactory) -> Iterator[FarmServer]:
    server = FarmServer(tmp_path_factory.mktemp("farm") / "data")
    yield server
    server.stop()


class BakeInBackground:
    """client.bake(model, out, **settings) on a thread of its own, for tests
    that break the farm under a running bake. `at_render` is set when the job
    reaches the worker's render stage (where $IMPOSTOR_WORKER_TEST_PAUSE_FILE
    holds a worker), an event rather than a sleep."""

    def __init__(self, client: Any, model: Path, out: Path, **settings: Any) -> None:
        self.at_render = threading.Event()
        self._outcome: List[Union[Any, BaseException]] = []
        self._thread = threading.Thread(target=self._run, args=(client, model, out, settings))
        self._thread.start()

    def _progress(self, update: Any) -> None:
        if update.state == "running" and update.stage == "render":
            self.at_render.set()

    def _run(self, client: Any, model: Path, out: Path, settings: Any) -> None:
        try:
            self._outcome.append(client.bake(model, out, progress=self._progress, **settings))
        except BaseException as e:  # handed to the test thread
            self._outcome.append(e)

    def result(self, timeout: float) -> Any:
        """The BakeResult; the bake's exception is raised; a bake still running
        after `timeout` fails the test (a hang)."""
        self._thread.join(timeout)
        assert not self._thread.is_alive(), f"the bake did not finish within {timeout} s"
        if isinstance(self._outcome[0], BaseException):
            raise self._outcome[0]
        return self._outcome[0]


def sha256_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_triangle_gltf(folder: Path, buffer_bytes: int, image_sizes: Sequence[int] = ()) -> Path:
    """A valid glTF, one triangle in a .bin of `buffer_bytes` (the rest
    random) and an image file of each of `image_sizes` random bytes, so that
    no server has them yet. Returns the .gltf's path."""
    folder.mkdir(parents=True, exist_ok=True)
    triangle = b"".join(v.to_bytes(4, "little") for v in
                        (0, 0, 0, 0x3F800000, 0, 0, 0, 0x3F800000, 0))  # floats 0/1
    (folder / "mesh.bin").write_bytes(triangle + os.urandom(buffer_bytes - len(triangle)))
    for i, size in enumerate(image_sizes):
        (folder / f"tex_{i}.png").write_bytes(os.urandom(size))
    gltf: Dict[str, Any] = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "buffers": [{"uri": "mesh.bin", "byteLength": buffer_bytes}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(triangle)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
    }
    if image_sizes:
        gltf["images"] = [{"uri": f"tex_{i}.png"} for i in range(len(image_sizes))]
    path = folder / "mesh.gltf"
    path.write_text(json.dumps(gltf))
    return path


def openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True)


@pytest.fixture(scope="session")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A CA made with the openssl CLI (ca.pem), server and client
    certificates it signed for localhost and 127.0.0.1 (server.pem/.key,
    client.pem/.key), and a second CA that signed nothing (other.pem)."""
    d = tmp_path_factory.mktemp("pki")
    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", "/CN=test CA",
            "-keyout", "ca.key", "-out", "ca.pem", cwd=d)
    for name in ("server", "client"):
        openssl("req", "-newkey", "rsa:2048", "-nodes", "-subj", f"/CN={name}", "-keyout", f"{name}.key",
                "-out", f"{name}.csr", cwd=d)
        (d / f"{name}.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
        openssl("x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
                "-days", "2", "-extfile", f"{name}.ext", "-out", f"{name}.pem", cwd=d)
    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", "/CN=other CA",
            "-keyout", "other.key", "-out", "other.pem", cwd=d)
    return d
