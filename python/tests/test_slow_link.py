"""Blob streams over slow and stopped links, through a throttling proxy
(throttled_link.py) in front of a real impostor-server: the Python twin of
tests/client/upload_link_test.cc and download_link_test.cc.

Uploads and downloads used to have a deadline on the whole stream,
rpc_timeout_seconds plus a second per 256 KiB, so a slow link cut a large
blob that was moving: an upload started over from its first byte, as
DEADLINE_EXCEEDED that read like the server's fault, until max_attempts ran
out. Now a stream has no overall deadline, only a stall watchdog: it ends
after rpc_timeout_seconds without progress (a 64 KiB message taken by the
link, or one arriving), saying "the link stalled" with the seconds and the
bytes.

Time enters only where it is the subject (how long a stall takes to be
noticed, whether a transfer outlasted the old deadline); every wait for an
event is an Event or a join.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Iterator, List, Union

import grpc
import pytest

import impostor
from impostor import _blobs
from impostor.v1 import types_pb2 as pb
from conftest import sha256_file, write_triangle_gltf
from farm_process import FarmServer
from throttled_link import ThrottledLink

KIB = 1024
MIB = 1024 * KIB
# Bounds on a step on a loaded 2-core machine; reaching one is a failure (a
# hang), not a timing measurement.
STEP_DEADLINE_S = 300


def old_deadline_seconds(rpc_timeout_seconds: float, size_bytes: int) -> float:
    """The deadline blob streams had: rpc_timeout_seconds + 1 s per 256 KiB."""
    return rpc_timeout_seconds + size_bytes / (256 * KIB)


@pytest.fixture
def server(tmp_path: Path) -> Iterator[FarmServer]:
    """A farm of its own with no worker: jobs stay queued, nothing competes
    with the link for the CPUs."""
    farm = FarmServer(tmp_path / "data", local_workers=0)
    yield farm
    farm.stop()


def submit_timed(client: impostor.Client, model: Path) -> "tuple[Union[impostor.SubmitResult, impostor.ImpostorError], float]":
    start = time.monotonic()
    try:
        outcome: Union[impostor.SubmitResult, impostor.ImpostorError] = client.submit(model)
    except impostor.ImpostorError as e:
        outcome = e
    return outcome, time.monotonic() - start


def test_a_slow_uplink_that_keeps_moving_uploads_a_mesh_in_one_stream(server: FarmServer, tmp_path: Path) -> None:
    """1 MiB at 20 KB/s takes about 53 s; the old deadline (5 s + 4 s) cut
    every stream after 9 s and gave up after max_attempts of them."""
    rate = 20_000
    rpc_timeout = 5.0
    model = write_triangle_gltf(tmp_path / "mesh", MIB)
    with ThrottledLink(server.address, up_bytes_per_second=rate) as link:
        with impostor.Client(link.address, rpc_timeout_seconds=rpc_timeout) as client:
            outcome, took = submit_timed(client, model)
        streams = link.upload_streams(at_least=64 * KIB)
        assert isinstance(outcome, impostor.SubmitResult), (
            f"{outcome} after {took:.1f} s; upload streams (bytes the client sent on each): {streams}")
        assert outcome.upload.uploaded == 2 and outcome.upload.bytes_uploaded == outcome.upload.bytes_total
        assert took > old_deadline_seconds(rpc_timeout, MIB), (
            f"took {took:.1f} s: the link was fast enough for the old deadline, the test proves nothing")
        assert len(streams) == 1 and streams[0] >= MIB, (
            f"one stream, never cut and started over; got {streams} after {took:.1f} s")
        assert link.connections == 1
        assert link.bytes_to_server < 1.1 * MIB + 64 * KIB


def test_a_stopped_uplink_ends_the_upload_after_rpc_timeout_naming_seconds_and_bytes(
        server: FarmServer, tmp_path: Path) -> None:
    """The link stops 300 kB into a 16 MiB upload (more than the client's
    kernel and gRPC take in, so the stop is seen while messages are still
    being handed over): the upload ends about rpc_timeout_seconds later,
    saying the link stalled, instead of after a deadline that grows with the
    blob (2 s + 64 s here)."""
    rpc_timeout = 2.0
    size = 16 * MIB
    model = write_triangle_gltf(tmp_path / "mesh", size)
    with ThrottledLink(server.address) as link:
        link.stop_after_upload_bytes(300_000)
        with impostor.Client(link.address, rpc_timeout_seconds=rpc_timeout, max_attempts=1,
                             max_outage_seconds=0) as client:
            outcome, took = submit_timed(client, model)
            assert link.stopped_event.is_set(), "the upload never got going"
        assert isinstance(outcome, impostor.ImpostorError), f"{outcome} after {took:.1f} s"
        assert outcome.code == grpc.StatusCode.DEADLINE_EXCEEDED, outcome
        assert outcome.rpc == "UploadBlob", outcome
        assert "the link stalled: it took nothing for 2 s (rpc_timeout_seconds), with " in outcome.message, outcome
        assert f" of the blob's {size} bytes sent" in outcome.message, outcome
        assert rpc_timeout <= took < rpc_timeout + 3, f"gave up {took:.1f} s after the start; the link stopped at once"
        assert len(link.upload_streams(at_least=64 * KIB)) == 1


def test_close_ends_an_upload_on_a_stopped_link_promptly(server: FarmServer, tmp_path: Path) -> None:
    """Client.close() from another thread (the way to give a call up) ends an
    upload stuck on a stopped link at once, long before the watchdog (30 s),
    with CANCELLED, and it is not started over."""
    model = write_triangle_gltf(tmp_path / "mesh", 16 * MIB)
    with ThrottledLink(server.address) as link:
        link.stop_after_upload_bytes(300_000)
        client = impostor.Client(link.address, rpc_timeout_seconds=30)
        outcome: List[Union[impostor.SubmitResult, BaseException]] = []
        returned_at: List[float] = []

        def upload() -> None:
            try:
                outcome.append(client.submit(model))
            except BaseException as e:  # handed to the test thread
                outcome.append(e)
            returned_at.append(time.monotonic())

        uploader = threading.Thread(target=upload)
        uploader.start()
        assert link.stopped_event.wait(STEP_DEADLINE_S), "the upload never got going"
        closed_at = time.monotonic()
        client.close()
        uploader.join(10)
        assert not uploader.is_alive(), "the upload went on after close()"
        assert isinstance(outcome[0], impostor.ImpostorError), outcome
        assert outcome[0].code == grpc.StatusCode.CANCELLED, outcome[0]
        assert returned_at[0] - closed_at < 1.0
        assert len(link.upload_streams(at_least=64 * KIB)) == 1, "a cancelled upload is not started over"


def test_a_fast_link_uploads_as_before(server: FarmServer, tmp_path: Path) -> None:
    """Through the proxy at full speed, with a watchdog far shorter than the
    upload would take at 20 KB/s: 8 MiB in one stream, promptly."""
    model = write_triangle_gltf(tmp_path / "mesh", 8 * MIB)
    with ThrottledLink(server.address) as link:
        with impostor.Client(link.address, rpc_timeout_seconds=2) as client:
            outcome, took = submit_timed(client, model)
        assert isinstance(outcome, impostor.SubmitResult), f"{outcome} after {took:.1f} s"
        assert outcome.upload.uploaded == 2 and outcome.upload.bytes_uploaded == outcome.upload.bytes_total
        streams = link.upload_streams(at_least=64 * KIB)
        assert len(streams) == 1 and streams[0] >= 8 * MIB, streams
        assert took < 30, f"8 MiB over loopback took {took:.1f} s"


def uploaded_blob(server: FarmServer, tmp_path: Path, size: int) -> "tuple[pb.Digest, Path]":
    """A blob of `size` random bytes put in the server's store directly (no
    proxy): its digest and the local file."""
    model = write_triangle_gltf(tmp_path / "source", size)
    with impostor.Client(server.address) as client:
        client.submit(model)
    blob = model.parent / "mesh.bin"
    return pb.Digest(hash=sha256_file(blob), size_bytes=size), blob


def download_timed(client: impostor.Client, digest: "pb.Digest", path: Path) -> "tuple[object, float]":
    start = time.monotonic()
    try:
        # The download under Client.fetch, for a blob of a size of our choosing.
        _blobs.download_blob_to_file(client._transport, digest, path)
        outcome: object = None
    except impostor.ImpostorError as e:
        outcome = e
    return outcome, time.monotonic() - start


def test_a_slow_downlink_that_keeps_moving_downloads_in_one_stream(server: FarmServer, tmp_path: Path) -> None:
    """1 MiB at 64 KiB/s takes 16 s; the old deadline (2 s + 4 s) cut the
    stream every 6 s, resumed at the byte offset each time."""
    rpc_timeout = 2.0
    digest, source = uploaded_blob(server, tmp_path, MIB)
    out = tmp_path / "out.bin"
    with ThrottledLink(server.address, down_bytes_per_second=64 * KIB) as link:
        with impostor.Client(link.address, rpc_timeout_seconds=rpc_timeout) as client:
            outcome, took = download_timed(client, digest, out)
        streams = link.download_streams(at_least=64 * KIB)
        assert outcome is None, f"{outcome} after {took:.1f} s; download streams: {streams}"
        assert out.read_bytes() == source.read_bytes()
        assert took > old_deadline_seconds(rpc_timeout, MIB), (
            f"took {took:.1f} s: the link was fast enough for the old deadline, the test proves nothing")
        assert len(streams) == 1 and streams[0] >= MIB, (
            f"one stream, never cut and resumed; got {streams} after {took:.1f} s")


def test_a_stopped_downlink_ends_the_download_after_rpc_timeout_naming_seconds_and_bytes(
        server: FarmServer, tmp_path: Path) -> None:
    """The link stops 300 kB into a 4 MiB download: the stream ends about
    rpc_timeout_seconds later, saying the link stalled and how far it got,
    instead of after 2 s + 16 s."""
    rpc_timeout = 2.0
    digest, _ = uploaded_blob(server, tmp_path, 4 * MIB)
    out = tmp_path / "out.bin"
    with ThrottledLink(server.address) as link:
        link.stop_after_download_bytes(300_000)
        with impostor.Client(link.address, rpc_timeout_seconds=rpc_timeout, max_attempts=1,
                             max_outage_seconds=0) as client:
            outcome, took = download_timed(client, digest, out)
            assert link.stopped_event.is_set(), "the download never got going"
        assert isinstance(outcome, impostor.ImpostorError), f"{outcome} after {took:.1f} s"
        assert outcome.code == grpc.StatusCode.DEADLINE_EXCEEDED, outcome
        assert outcome.rpc == "ReadBlob", outcome
        assert "the link stalled: no bytes arrived for 2 s (rpc_timeout_seconds), after " in outcome.message, outcome
        assert " bytes of this stream" in outcome.message, outcome
        assert rpc_timeout <= took < rpc_timeout + 3, f"gave up {took:.1f} s after the start; the link stopped at once"
        assert not out.exists()
