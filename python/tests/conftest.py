"""Fixtures: a real impostor-server with one local worker, shared by the
tests of a session, a throwaway PKI, and helpers to check downloaded files."""
from __future__ import annotations

import hashlib
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any, Iterator, List, Union

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
