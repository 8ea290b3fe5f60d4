"""Fixtures: a real impostor-server with one local worker, shared by the
tests of a session, and helpers to check downloaded files."""
from __future__ import annotations

import hashlib
import sys
from pathlib import Path
from typing import Iterator

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


def sha256_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()
