"""Several server addresses in one Client ("host1:port,host2:port", the C++
SDK's --server lists): a dead first address is skipped at connect time, a
replica killed between calls costs its caller a move to the next address
(the upload, submit and watch of a whole bake land there), and malformed
lists fail at once naming `server`. Real impostor-server processes; the
failover is driven by SIGKILL, not by timing."""
from __future__ import annotations

import socket
from pathlib import Path
from typing import List

import grpc
import pytest

import impostor
from conftest import sha256_file
from farm_process import FarmServer

BOX = "props_pbr/Box/glTF-Binary/Box.glb"


def dead_address() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"127.0.0.1:{s.getsockname()[1]}"


@pytest.mark.parametrize("server", ["127.0.0.1:1,,127.0.0.1:2", ",", "127.0.0.1:1, ", "   "])
def test_malformed_lists_fail_at_once_naming_server(server: str) -> None:
    with pytest.raises(impostor.ImpostorError) as e:
        impostor.Client(server)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert e.value.message.startswith("server:"), e.value.message


def test_no_live_address_is_unavailable_naming_each(tmp_path: Path) -> None:
    a, b = dead_address(), dead_address()
    with pytest.raises(impostor.ImpostorError) as e:
        impostor.Client(f"{a},{b}", connect_timeout_seconds=5)
    assert e.value.code == grpc.StatusCode.UNAVAILABLE
    assert "no address answered" in e.value.message, e.value.message


def test_a_dead_first_address_is_skipped(farm: FarmServer, assets: Path) -> None:
    with impostor.Client(f"{dead_address()},{farm.address}") as client:
        looked = client.lookup(assets / BOX, frames=2, resolution=64, quality_views=0)
        assert len(looked.cache_key) == 64


def test_a_bake_moves_to_the_other_replica_when_the_first_is_killed(
    farm: FarmServer, assets: Path, tmp_path: Path
) -> None:
    first = FarmServer(tmp_path / "first", local_workers=0)
    try:
        events: List[impostor.ConnectionEvent] = []
        with impostor.Client(f"{first.address},{farm.address}", on_connection_change=events.append) as client:
            # The first replica answers while it lives.
            assert not client.lookup(assets / BOX, frames=2, resolution=72, quality_views=0).found
            first.kill9()
            # Every call of the bake (FindMissingBlobs, UploadBlob, SubmitBake,
            # WatchJob, GetResult, ReadBlob) now goes to the second replica.
            result = client.bake(assets / BOX, tmp_path / "out", frames=2, resolution=72, quality_views=0)
        assert result.cache_key
        for m in result.manifest["maps"]:
            assert sha256_file(tmp_path / "out" / m["file"]) == m["digest"]["hash"]
        assert [e.kind for e in events][:1] == ["lost"], events
        assert events[0].error is not None and first.address in events[0].error.message
    finally:
        first.stop()
