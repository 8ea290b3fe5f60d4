"""Several server addresses in one Client ("host1:port,host2:port", the C++
SDK's --server lists): a dead first address is skipped at connect time, a
replica killed between calls costs its caller a move to the next address
(the upload, submit and watch of a whole bake land there), and malformed
lists fail at once naming `server`; and with two replicas on one PostgreSQL
database, a watch through a replica SIGKILLed mid-bake resumes on the other.
Real impostor-server processes; the failover is driven by SIGKILL and a
pause file, not by timing."""
from __future__ import annotations

import socket
from pathlib import Path
from typing import List

import grpc
import pytest

import impostor
from conftest import BakeInBackground, sha256_file
import postgres_process
from farm_process import FarmServer

BOX = "props_pbr/Box/glTF-Binary/Box.glb"
# A bound on one step on a loaded machine; reaching it is a failure (a hang).
STEP_DEADLINE_S = 120


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
        looked = client.lookup(assets / BOX, frames=3, resolution=64, quality_views=0)
        assert len(looked.cache_key) == 64


def test_a_bake_moves_to_the_other_replica_when_the_first_is_killed(
    farm: FarmServer, assets: Path, tmp_path: Path
) -> None:
    first = FarmServer(tmp_path / "first", local_workers=0)
    try:
        events: List[impostor.ConnectionEvent] = []
        with impostor.Client(f"{first.address},{farm.address}", on_connection_change=events.append) as client:
            # The first replica answers while it lives.
            assert not client.lookup(assets / BOX, frames=3, resolution=72, quality_views=0).found
            first.kill9()
            # Every call of the bake (FindMissingBlobs, UploadBlob, SubmitBake,
            # WatchJob, GetResult, ReadBlob) now goes to the second replica.
            result = client.bake(assets / BOX, tmp_path / "out", frames=3, resolution=72, quality_views=0)
        assert result.cache_key
        for m in result.manifest["maps"]:
            assert sha256_file(tmp_path / "out" / m["file"]) == m["digest"]["hash"]
        assert [e.kind for e in events][:1] == ["lost"], events
        assert events[0].error is not None and first.address in events[0].error.message
    finally:
        first.stop()


def test_a_replica_that_stops_answering_is_left_on_deadline_exceeded(
    farm: FarmServer, assets: Path, tmp_path: Path
) -> None:
    """A replica that accepts connections but never answers (SIGSTOPped: a hung
    process, a host swapping) gives no UNAVAILABLE, only DEADLINE_EXCEEDED;
    with several addresses that moves the call to the next one."""
    first = FarmServer(tmp_path / "first", local_workers=0)
    try:
        with impostor.Client(f"{first.address},{farm.address}", rpc_timeout_seconds=2, max_attempts=2) as client:
            assert not client.lookup(assets / BOX, frames=3, resolution=76, quality_views=0).found
            assert client._transport.current_target == first.address
            first.freeze()
            # One attempt runs into the deadline on the frozen replica; the
            # retry goes to the other one at once. (With only UNAVAILABLE as a
            # reason to move, both attempts went to the frozen one.)
            assert not client.lookup(assets / BOX, frames=3, resolution=76, quality_views=0).found
            assert client._transport.current_target == farm.address
    finally:
        first.freeze(False)
        first.stop()


@pytest.mark.parametrize("keepalive", [0, -1, 7201, 2.5, True])
def test_keepalive_seconds_out_of_range_is_refused_naming_it(farm: FarmServer, keepalive: object) -> None:
    with pytest.raises(impostor.ImpostorError) as e:
        impostor.Client(farm.address, keepalive_seconds=keepalive)  # type: ignore[arg-type]
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert e.value.message.startswith("keepalive_seconds:") and "1..7200" in e.value.message, e.value.message


@pytest.mark.skipif(not postgres_process.available(), reason="no PostgreSQL binaries (postgresql-15)")
def test_a_watch_resumes_on_the_other_replica_of_one_database(assets: Path, tmp_path: Path) -> None:
    """Two replicas on one PostgreSQL database and one blob folder: the bake is
    submitted and watched through A, baked by B's worker (held at its render
    stage by a file), A is SIGKILLed mid-watch, and the watch resumes on B
    (GetJob, then a new stream) to the finished bake."""
    pg = postgres_process.PostgresServer()
    servers: List[FarmServer] = []
    try:
        pause = tmp_path / "pause"
        pause.write_text("pause")
        shared = ["--database=" + pg.url(), f"--blob-dir={tmp_path / 'blobs'}"]
        servers.append(FarmServer(tmp_path / "a", local_workers=0, extra_args=shared))
        servers.append(FarmServer(tmp_path / "b", local_workers=1, extra_args=shared,
                                  env={"IMPOSTOR_WORKER_TEST_PAUSE_FILE": str(pause)}))
        a, b = servers
        events: List[impostor.ConnectionEvent] = []
        client = impostor.Client(f"{a.address},{b.address}", on_connection_change=events.append)
        bake = BakeInBackground(client, assets / BOX, tmp_path / "out", frames=3, resolution=80, quality_views=0)
        assert bake.at_render.wait(STEP_DEADLINE_S), "the bake never reached B's worker's render stage"
        a.kill9()
        pause.unlink()
        result: impostor.BakeResult = bake.result(STEP_DEADLINE_S)
        client.close()
        for m in result.manifest["maps"]:
            assert sha256_file(tmp_path / "out" / m["file"]) == m["digest"]["hash"]
        assert events and events[0].kind == "lost" and events[0].error is not None
        assert a.address in events[0].error.message, events[0].error.message
    finally:
        for s in servers:
            s.stop()
        pg.stop()
