"""Uploads of a model's small files many to a BatchUpdateBlobs call (issue
45), the twin of tests/client/fake_server_batch_upload_test.cc: against a
real impostor-server one call carries a model's small files while the large
one streams; against stand-in servers, an older server (UNIMPLEMENTED) gets
every file streamed, a blob refused in its batch is streamed once more, a
blob refused twice fails only the models that use it, and a refusal of the
caller ends the upload."""
from __future__ import annotations

import hashlib
from concurrent import futures
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Sequence, Set

import grpc
import pytest

import impostor
from conftest import write_triangle_gltf
from farm_process import FarmServer
from impostor.v1 import asset_service_pb2 as asset_pb
from impostor.v1 import asset_service_pb2_grpc as asset_grpc
from impostor.v1 import bake_service_pb2 as bake_pb
from impostor.v1 import bake_service_pb2_grpc as bake_grpc

KIB = 1 << 10
MIB = 1 << 20


def write_model(folder: Path, image_sizes: Sequence[int]) -> Path:
    """A glTF (one triangle in a 4 KiB .bin) with an image of each size,
    random bytes, so that no server has them yet."""
    return write_triangle_gltf(folder, 4 * KIB, image_sizes)


def model_bytes(entry: Path) -> int:
    return sum(p.stat().st_size for p in entry.parent.iterdir())


class _CountingTransport:
    """The client's transport, counting BatchUpdateBlobs calls (and their
    blobs) and UploadBlob streams."""

    def __init__(self, inner: Any) -> None:
        self._inner = inner
        self.batches: List[int] = []
        self.streams = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)

    def batch_update_blobs(self, request: Any) -> Any:
        self.batches.append(len(request.requests))
        return self._inner.batch_update_blobs(request)

    def upload_blob(self, requests: Iterator[Any], size_bytes: int) -> Any:
        self.streams += 1
        return self._inner.upload_blob(requests, size_bytes)


@pytest.fixture
def server(tmp_path: Path) -> Iterator[FarmServer]:
    """A farm of its own with no worker: jobs stay queued."""
    farm = FarmServer(tmp_path / "data", local_workers=0)
    yield farm
    farm.stop()


def test_a_models_small_files_go_in_one_call_and_the_large_one_streams(server: FarmServer, tmp_path: Path,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    entry = write_model(tmp_path / "model", [8 * KIB] * 6 + [2 * MIB])
    with impostor.Client(server.address) as c:
        counting = _CountingTransport(c._transport)
        monkeypatch.setattr(c, "_transport", counting)
        submitted = c.submit(entry, frames=4, resolution=64, quality_views=0)
        assert counting.batches == [8], "the .gltf, the .bin and six images in one call"
        assert counting.streams == 1, "only the 2 MiB image streams"
        assert submitted.upload.files == 9
        assert submitted.upload.uploaded == 9
        assert submitted.upload.bytes_uploaded == submitted.upload.bytes_total == model_bytes(entry)
        again = c.submit(entry, frames=4, resolution=64, quality_views=0)
        assert again.upload.uploaded == 0 and again.upload.bytes_uploaded == 0, "the server holds every blob"
        assert counting.batches == [8] and counting.streams == 1


class _StandIn:
    """A stand-in AssetService and BakeService on a loopback port: a store
    in memory; BatchUpdateBlobs UNIMPLEMENTED unless `batches` (a server
    from before the call); hashes in `refuse_in_batch` refused in their slot,
    those in `refuse_always` on the stream too (a full store);
    `batch_code` refuses whole calls."""

    def __init__(self, batches: bool = True) -> None:
        self.store: Dict[str, bytes] = {}
        self.batches = batches
        self.batch_code: Optional[grpc.StatusCode] = None
        self.refuse_in_batch: Set[str] = set()
        self.refuse_always: Set[str] = set()
        self.batch_calls: List[List[str]] = []
        self.streamed: List[str] = []
        self.submits = 0
        stand_in = self

        class Assets(asset_grpc.AssetServiceServicer):
            def FindMissingBlobs(self, request, context):  # noqa: N802 (gRPC's name)
                return asset_pb.FindMissingBlobsResponse(
                    missing=[d for d in request.digests if d.hash not in stand_in.store])

            def UploadBlob(self, request_iterator, context):  # noqa: N802
                digest, data = None, b""
                for chunk in request_iterator:
                    if chunk.HasField("digest"):
                        digest = chunk.digest
                    data += chunk.data
                stand_in.streamed.append(digest.hash)
                if digest.hash in stand_in.refuse_always:
                    context.abort(grpc.StatusCode.RESOURCE_EXHAUSTED, "No space left on device (test)")
                stand_in.store[digest.hash] = data
                return asset_pb.UploadBlobResponse(digest=digest)

            def BatchUpdateBlobs(self, request, context):  # noqa: N802
                if not stand_in.batches:
                    context.abort(grpc.StatusCode.UNIMPLEMENTED, "unknown method (test)")
                if stand_in.batch_code is not None:
                    context.abort(stand_in.batch_code, "the whole batch refused (test)")
                stand_in.batch_calls.append([r.digest.hash for r in request.requests])
                response = asset_pb.BatchUpdateBlobsResponse()
                for r in request.requests:
                    answer = response.responses.add(digest=r.digest)
                    if hashlib.sha256(r.data).hexdigest() != r.digest.hash:
                        answer.code, answer.message = grpc.StatusCode.INVALID_ARGUMENT.value[0], "mismatch (test)"
                    elif r.digest.hash in stand_in.refuse_in_batch | stand_in.refuse_always:
                        answer.code = grpc.StatusCode.RESOURCE_EXHAUSTED.value[0]
                        answer.message, answer.reason = "No space left on device (test)", "STORE_FULL"
                    else:
                        stand_in.store[r.digest.hash] = r.data
                return response

        class Bake(bake_grpc.BakeServiceServicer):
            def SubmitBake(self, request, context):  # noqa: N802
                stand_in.submits += 1
                return bake_pb.SubmitBakeResponse(job_id=f"job-{stand_in.submits}", cache_key="a" * 64)

        self._server = grpc.server(futures.ThreadPoolExecutor(max_workers=4))
        asset_grpc.add_AssetServiceServicer_to_server(Assets(), self._server)
        bake_grpc.add_BakeServiceServicer_to_server(Bake(), self._server)
        self.address = f"127.0.0.1:{self._server.add_insecure_port('127.0.0.1:0')}"
        self._server.start()

    def stop(self) -> None:
        self._server.stop(None)


def sha256_of(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def submit_through(stand_in: _StandIn, entry: Path) -> impostor.SubmitResult:
    """Submits `entry` to the stand-in, which is stopped after, whatever happens."""
    try:
        with impostor.Client(stand_in.address) as c:
            return c.submit(entry)
    finally:
        stand_in.stop()


def test_an_older_server_gets_every_file_through_upload_blob(tmp_path: Path) -> None:
    stand_in = _StandIn(batches=False)
    entry = write_model(tmp_path / "model", [10 * KIB] * 4)
    submitted = submit_through(stand_in, entry)
    assert submitted.upload.uploaded == 6 and submitted.upload.bytes_uploaded == model_bytes(entry)
    assert len(stand_in.streamed) == 6, "every file streamed"
    assert stand_in.submits == 1


def test_a_call_carries_at_most_one_upload_messages_bytes(tmp_path: Path) -> None:
    """Calls of at most UPLOAD_BATCH_MAX_BYTES (64 KiB: a slow uplink must
    carry one as soon as a stream's message); a file larger than that
    streams, even one a server would take in a batch."""
    from impostor import _blobs
    stand_in = _StandIn()
    entry = write_model(tmp_path / "model", [20 * KIB] * 9 + [_blobs.UPLOAD_BATCH_MAX_BYTES + 1])
    sizes = {sha256_of(p): p.stat().st_size for p in entry.parent.iterdir()}
    submitted = submit_through(stand_in, entry)
    assert submitted.upload.uploaded == 12 and submitted.upload.bytes_uploaded == model_bytes(entry)
    assert len(stand_in.batch_calls) == 4, stand_in.batch_calls
    for call in stand_in.batch_calls:
        assert sum(sizes[h] for h in call) <= _blobs.UPLOAD_BATCH_MAX_BYTES
    assert stand_in.streamed == [sha256_of(entry.parent / "tex_9.png")], "the one over the limit streams"


def test_a_blob_refused_in_its_batch_is_streamed_once_more(tmp_path: Path) -> None:
    stand_in = _StandIn()
    entry = write_model(tmp_path / "model", [10 * KIB] * 4)
    refused = sha256_of(entry.parent / "tex_2.png")
    stand_in.refuse_in_batch.add(refused)
    submitted = submit_through(stand_in, entry)
    assert len(stand_in.batch_calls) == 1 and len(stand_in.batch_calls[0]) == 6
    assert stand_in.streamed == [refused], "the refused blob alone, once"
    assert submitted.upload.uploaded == 6 and submitted.upload.bytes_uploaded == model_bytes(entry)
    assert stand_in.submits == 1


def test_a_blob_refused_twice_fails_only_the_models_that_use_it(tmp_path: Path) -> None:
    stand_in = _StandIn()
    full = write_model(tmp_path / "full", [10 * KIB] * 2)
    fine = write_model(tmp_path / "fine", [10 * KIB] * 2)
    stand_in.refuse_always.add(sha256_of(full.parent / "tex_1.png"))
    try:
        with impostor.Client(stand_in.address) as c:
            out = c.submit_batch([full, fine, full])
    finally:
        stand_in.stop()
    for refused in (out[0], out[2]):
        assert refused.error is not None and refused.error.code == grpc.StatusCode.RESOURCE_EXHAUSTED, refused
        assert str(full.parent / "tex_1.png") in refused.error.message, refused.error
        assert "refused in its batch first: RESOURCE_EXHAUSTED" in refused.error.message, refused.error
    assert out[1].error is None and out[1].result is not None, out[1]
    # The two .gltf files are the same bytes, one blob, counted for the
    # first model that has it.
    assert out[1].result.upload.files == 4 and out[1].result.upload.uploaded == 3
    assert out[1].result.upload.bytes_uploaded == model_bytes(fine) - fine.stat().st_size
    assert len(stand_in.batch_calls) == 1, "both models' small files in one call"
    assert stand_in.submits == 1


@pytest.mark.parametrize("code", [grpc.StatusCode.UNAUTHENTICATED, grpc.StatusCode.PERMISSION_DENIED])
def test_a_refusal_of_the_caller_ends_the_upload(tmp_path: Path, code: grpc.StatusCode) -> None:
    stand_in = _StandIn()
    stand_in.batch_code = code
    entry = write_model(tmp_path / "model", [10 * KIB])
    try:
        with impostor.Client(stand_in.address) as c:
            with pytest.raises(impostor.ImpostorError) as caught:
                c.submit(entry)
    finally:
        stand_in.stop()
    assert caught.value.code == code and caught.value.rpc == "BatchUpdateBlobs"
    assert stand_in.streamed == [] and stand_in.submits == 0


def test_a_quota_refusal_of_the_whole_call_leaves_each_blob_to_its_stream(tmp_path: Path) -> None:
    stand_in = _StandIn()
    stand_in.batch_code = grpc.StatusCode.RESOURCE_EXHAUSTED
    entry = write_model(tmp_path / "model", [10 * KIB])
    submitted = submit_through(stand_in, entry)
    assert len(stand_in.streamed) == 3 and submitted.upload.uploaded == 3
