"""Resumable uploads (issue 44) against a real impostor-server: a stream
that breaks leaves the server a partial upload, QueryUpload reports its
length, and the Python client's next try sends only the rest; a resume whose
bytes are not the blob's is refused and leaves nothing behind. The twin of
tests/client/upload_resume_test.cc.

Every wait for an event is an Event, a join or a call's answer; time enters
only as the stall watchdog's rpc_timeout_seconds, which ends the cut try.
"""
from __future__ import annotations

import hashlib
import os
import time
from pathlib import Path
from typing import Any, Iterator, List

import grpc
import pytest

import impostor
from impostor.v1 import asset_service_pb2 as asset_pb
from impostor.v1 import asset_service_pb2_grpc as asset_grpc
from impostor.v1 import types_pb2 as pb
from farm_process import FarmServer
from conftest import write_triangle_gltf
from test_slow_link import KIB, MIB
from throttled_link import ThrottledLink

CHUNK = 64 * KIB  # impostor._blobs.UPLOAD_CHUNK_BYTES


@pytest.fixture
def server(tmp_path: Path) -> Iterator[FarmServer]:
    """A farm of its own with no worker: jobs stay queued."""
    farm = FarmServer(tmp_path / "data", local_workers=0)
    yield farm
    farm.stop()


def framing_allowance(blob_bytes: int) -> int:
    """gRPC message framing within HTTP/2 DATA (about 10 bytes a 64 KiB
    message), other calls' DATA and the first message's digest."""
    return blob_bytes // 1000 + 2048


def wait_until_server_holds(address: str, digest: "pb.Digest", size: int, timeout_s: float = 60) -> bool:
    """Polls QueryUpload (straight to the server, not through a link) until
    the server holds `size` bytes of the upload: what crossed a link
    reaches the server's handler only as fast as it reads it, so a cut "at
    50 %" is made once the server has read 50 %. False after `timeout_s`."""
    end = time.monotonic() + timeout_s
    with grpc.insecure_channel(address) as channel:
        stub = asset_grpc.AssetServiceStub(channel)
        while time.monotonic() < end:
            held = stub.QueryUpload(asset_pb.QueryUploadRequest(digest=digest), timeout=60)
            if held.committed_bytes >= size:
                return True
            time.sleep(0.005)
    return False


def test_an_upload_cut_at_half_resumes_sending_at_most_the_rest_plus_one_message(
        server: FarmServer, tmp_path: Path) -> None:
    """The link lets a little more than half of mesh.bin through and stops;
    once the server has read half, the link is closed (the server sees the
    connection go). The next submit sends only the rest."""
    size = 4 * MIB
    model = write_triangle_gltf(tmp_path / "mesh", size)
    bin_digest = _digest((model.parent / "mesh.bin").read_bytes())
    half = size // 2
    with ThrottledLink(server.address) as link:
        link.stop_after_upload_bytes(half + CHUNK + framing_allowance(half))
        with impostor.Client(link.address, rpc_timeout_seconds=2.0, max_attempts=1,
                             max_outage_seconds=0) as client:
            with pytest.raises(impostor.ImpostorError) as cut:
                client.submit(model)
        assert link.stopped_event.is_set(), "the upload never reached half way"
        assert wait_until_server_holds(server.address, bin_digest, half), "the server never read half the blob"
        first = link.upload_streams(at_least=CHUNK)  # what the client sent, crossed or not
    # The stall watchdog's DEADLINE_EXCEEDED, or the connection's keepalive
    # giving up first (UNAVAILABLE): a broken link either way.
    assert cut.value.code in (grpc.StatusCode.DEADLINE_EXCEEDED, grpc.StatusCode.UNAVAILABLE), cut.value

    with ThrottledLink(server.address) as link:
        with impostor.Client(link.address, rpc_timeout_seconds=30) as client:
            result = client.submit(model)
        streams: List[int] = link.upload_streams(at_least=CHUNK)
    assert result.upload.uploaded == 1, "mesh.gltf went through the first time; mesh.bin now"
    assert len(streams) == 1, f"one resumed stream of mesh.bin; DATA bytes per stream: {streams}"
    bound = size - half + CHUNK
    assert streams[0] <= bound, (
        f"the resumed stream sent {streams[0]} bytes after a cut at {half} of {size}: "
        f"more than the rest plus one message ({bound})")
    assert len(first) == 1 and streams[0] + first[0] >= size, (
        f"the two streams sent {first} and {streams}: less than the blob?")


def _digest(data: bytes) -> "pb.Digest":
    return pb.Digest(hash=hashlib.sha256(data).hexdigest(), size_bytes=len(data))


def _stream(stub: Any, digest: "pb.Digest", offset: int, data: bytes) -> Any:
    """One raw UploadBlob from the blob's byte `offset`; the error it ends
    with (every stream here is meant to fail)."""
    def messages() -> Iterator[asset_pb.UploadBlobRequest]:
        yield asset_pb.UploadBlobRequest(digest=digest, offset=offset, data=data[:CHUNK])
        for begin in range(CHUNK, len(data), CHUNK):
            yield asset_pb.UploadBlobRequest(data=data[begin:begin + CHUNK])

    with pytest.raises(grpc.RpcError) as caught:
        stub.UploadBlob(messages(), timeout=60)
    return caught.value


def _kept(stub: Any, digest: "pb.Digest") -> int:
    response = stub.QueryUpload(asset_pb.QueryUploadRequest(digest=digest), timeout=60)
    assert not response.complete
    return int(response.committed_bytes)


def test_a_corrupt_resume_or_a_wrong_offset_is_refused(server: FarmServer) -> None:
    blob = os.urandom(MIB)
    digest = _digest(blob)
    half = len(blob) // 2
    with grpc.insecure_channel(server.address) as channel:
        stub = asset_grpc.AssetServiceStub(channel)
        ended = _stream(stub, digest, 0, blob[:half])  # ends early: kept
        assert ended.code() == grpc.StatusCode.INVALID_ARGUMENT, ended
        assert _kept(stub, digest) == half

        wrong = _stream(stub, digest, half + 1, blob[half + 1:])
        assert wrong.code() == grpc.StatusCode.FAILED_PRECONDITION, wrong
        assert str(half + 1) in wrong.details() and f"({half} bytes)" in wrong.details(), wrong.details()
        assert _kept(stub, digest) == half, "a refused offset leaves the partial as it was"

        corrupt = bytearray(blob[half:])
        corrupt[1000] ^= 0xFF
        refused = _stream(stub, digest, half, bytes(corrupt))
        assert refused.code() == grpc.StatusCode.INVALID_ARGUMENT, refused
        assert "hash mismatch" in refused.details(), refused.details()
        assert _kept(stub, digest) == 0, "a corrupt resume leaves no partial behind"

        with pytest.raises(grpc.RpcError) as bad:
            stub.QueryUpload(asset_pb.QueryUploadRequest(digest=pb.Digest(hash="xyz", size_bytes=1)), timeout=60)
        assert bad.value.code() == grpc.StatusCode.INVALID_ARGUMENT, bad.value
