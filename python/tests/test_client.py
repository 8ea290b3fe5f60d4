"""The Python client against a real impostor-server and worker: bake, cache
hit, fetch, lookup, batch, and bad input (local and the server's status)."""
from __future__ import annotations

import json
import os
import re
import sys
import threading
import time
from pathlib import Path
from typing import List, Set

import grpc
import pytest

import impostor
from conftest import sha256_file
from farm_process import FarmServer

TREE = "vegetation/TreeLowPoly_RicardoSanchez/scene.gltf"  # .gltf + .bin + 2 textures
BOX = "props_pbr/Box/glTF-Binary/Box.glb"
DUCK = "props_pbr/Duck/glTF-Binary/Duck.glb"
# Quick on the software renderer, with a small quality pass.
SMALL = dict(frames=4, resolution=128, quality_views=4)


def assert_files_match_manifest(result_dir: Path, manifest: dict) -> None:
    """Every file the manifest lists is on disk with its digest's hash and size."""
    assert manifest["maps"], "manifest lists no files"
    for m in manifest["maps"]:
        path = result_dir / m["file"]
        assert path.stat().st_size == m["digest"]["size_bytes"], m["file"]
        assert sha256_file(path) == m["digest"]["hash"], m["file"]


@pytest.fixture(scope="module")
def client(farm: FarmServer) -> impostor.Client:
    with impostor.Client(farm.address) as c:
        yield c


@pytest.fixture(scope="module")
def tree_bake(client: impostor.Client, assets: Path, tmp_path_factory: pytest.TempPathFactory):
    updates: List[impostor.JobUpdate] = []
    result = client.bake(assets / TREE, tmp_path_factory.mktemp("tree"), progress=updates.append, **SMALL)
    return result, updates


def test_bake_uploads_every_file_and_downloads_a_verified_result(tree_bake) -> None:
    result, updates = tree_bake
    assert re.fullmatch(r"[0-9a-f]{64}", result.cache_key)
    assert not result.cached
    assert result.submit.upload == impostor.UploadStats(
        files=4, uploaded=4, bytes_total=result.submit.upload.bytes_total,
        bytes_uploaded=result.submit.upload.bytes_total)
    assert result.manifest["cache_key"] == result.cache_key
    assert result.manifest["frames"] == 4 and result.manifest["resolution"] == 128
    assert {m["semantic"] for m in result.manifest["maps"]} >= {"albedo_alpha", "normal_depth", "orm"}
    assert_files_match_manifest(result.dir, result.manifest)
    assert [p.name for p in result.files][-1] == "manifest.json"
    assert json.loads(result.files[-1].read_text()) == result.manifest
    assert result.quality is not None and result.quality["views"] == 4
    assert 0 < result.quality["silhouette_iou_mean"] <= 1
    # Progress: every update is a change, the last the terminal one.
    assert updates[-1].state == "succeeded" and updates[-1].progress == 1
    assert all(a != b for a, b in zip(updates, updates[1:]))
    assert any(u.state == "running" for u in updates)


def test_same_bake_again_is_a_cache_hit_without_uploads(client, assets, tree_bake, tmp_path) -> None:
    first, _ = tree_bake
    updates: List[impostor.JobUpdate] = []
    again = client.bake(assets / TREE, tmp_path, progress=updates.append, **SMALL)
    assert again.cached
    assert again.cache_key == first.cache_key
    assert again.submit.upload.uploaded == 0 and again.submit.upload.files == 4
    assert [u.state for u in updates] == ["succeeded"] and updates[0].cached
    assert again.manifest["maps"] == first.manifest["maps"]
    assert_files_match_manifest(tmp_path, again.manifest)


def test_fetched_files_are_plain_files_others_can_read(client, tree_bake, tmp_path) -> None:
    old = os.umask(0o022)
    try:
        fetched = client.fetch(tree_bake[0].cache_key, tmp_path / "shared")
    finally:
        os.umask(old)
    for path in fetched.files:
        assert path.stat().st_mode & 0o777 == 0o644, path


def test_fetch_downloads_then_reuses_files_already_there(client, tree_bake, tmp_path) -> None:
    first, _ = tree_bake
    fetched = client.fetch(first.cache_key, tmp_path / "a")
    total = sum(m["digest"]["size_bytes"] for m in fetched.manifest["maps"])
    assert fetched.bytes_reused == 0 and fetched.bytes_downloaded > total
    assert_files_match_manifest(tmp_path / "a", fetched.manifest)
    assert [p.name for p in fetched.files] == [p.name for p in first.files]
    # A damaged file is downloaded again, the intact ones are kept.
    damaged = tmp_path / "a" / "albedo_alpha.png"
    damaged.write_bytes(b"not a png")
    again = client.fetch(first.cache_key, tmp_path / "a")
    size = next(m["digest"]["size_bytes"] for m in fetched.manifest["maps"] if m["file"] == "albedo_alpha.png")
    assert again.bytes_downloaded == size
    assert again.bytes_reused == fetched.bytes_downloaded - size
    assert_files_match_manifest(tmp_path / "a", again.manifest)


class _CountingTransport:
    """The client's transport, counting BatchReadBlobs calls and ReadBlob
    streams; `batch` may replace the BatchReadBlobs answer."""

    def __init__(self, inner, batch=None) -> None:
        self._inner = inner
        self._batch = batch
        self.batch_calls = 0
        self.streams = 0

    def __getattr__(self, name):
        return getattr(self._inner, name)

    def unary(self, rpc, method, request):
        if rpc == "BatchReadBlobs":
            self.batch_calls += 1
            if self._batch is not None:
                return self._batch(self._inner, method, request)
        return self._inner.unary(rpc, method, request)

    def read_blob(self, request, remaining_bytes):
        self.streams += 1
        return self._inner.read_blob(request, remaining_bytes)


def test_fetch_reads_the_small_files_in_one_batch(client, tree_bake, tmp_path, monkeypatch) -> None:
    first, _ = tree_bake
    counting = _CountingTransport(client._transport)
    monkeypatch.setattr(client, "_transport", counting)
    fetched = client.fetch(first.cache_key, tmp_path / "batched")
    assert_files_match_manifest(tmp_path / "batched", fetched.manifest)
    from impostor._blobs import BATCH_BLOB_MAX_BYTES

    small = [m for m in fetched.manifest["maps"] if m["digest"]["size_bytes"] <= BATCH_BLOB_MAX_BYTES]
    large = len(fetched.manifest["maps"]) - len(small)
    assert len(small) > 5, "the quality pass's view images are small"
    assert counting.batch_calls == 1
    assert counting.streams == large, "only files over 1 MiB stream"


def test_fetch_from_a_server_without_batch_reads_streams_every_file(client, tree_bake, tmp_path, monkeypatch) -> None:
    first, _ = tree_bake

    def unimplemented(inner, method, request):
        raise impostor.ImpostorError(grpc.StatusCode.UNIMPLEMENTED, "BatchReadBlobs: unknown method (test)")

    counting = _CountingTransport(client._transport, batch=unimplemented)
    monkeypatch.setattr(client, "_transport", counting)
    fetched = client.fetch(first.cache_key, tmp_path / "old_server")
    assert_files_match_manifest(tmp_path / "old_server", fetched.manifest)
    assert counting.streams == len(fetched.manifest["maps"]) + 1, "every map and manifest.json"


def test_a_forged_blob_in_a_batch_fails_naming_its_file(client, tree_bake, tmp_path, monkeypatch) -> None:
    first, _ = tree_bake
    forged_file = []

    def forge(inner, method, request):
        response = inner.unary("BatchReadBlobs", method, request)
        blob = response.blobs[len(response.blobs) // 2]
        blob.data = bytes([blob.data[0] ^ 1]) + blob.data[1:]
        forged_file.append(blob.digest.hash)
        return response

    monkeypatch.setattr(client, "_transport", _CountingTransport(client._transport, batch=forge))
    with pytest.raises(impostor.ImpostorError) as e:
        client.fetch(first.cache_key, tmp_path / "forged")
    assert e.value.code == grpc.StatusCode.DATA_LOSS
    assert forged_file[0] in e.value.message and str(tmp_path / "forged") in e.value.message
    assert not (tmp_path / "forged" / "manifest.json").exists()


def test_pack_batches_keeps_order_and_both_limits() -> None:
    from impostor._blobs import MAX_BATCH_DIGESTS, pack_batches

    assert pack_batches([3 << 20, 1 << 20, 1, 0]) == [[0, 1], [2, 3]]
    batches = pack_batches([10] * (MAX_BATCH_DIGESTS * 2 + 1))
    assert [len(b) for b in batches] == [MAX_BATCH_DIGESTS, MAX_BATCH_DIGESTS, 1]
    assert batches[2] == [MAX_BATCH_DIGESTS * 2]
    assert pack_batches([]) == []


def test_get_manifest_matches_the_fetched_one(client, tree_bake) -> None:
    first, _ = tree_bake
    assert client.get_manifest(first.cache_key) == first.manifest


def test_lookup_finds_a_result_only_once_baked(client, assets, tmp_path) -> None:
    settings = dict(frames=6, resolution=96, quality_views=0)
    before = client.lookup(assets / BOX, **settings)
    assert not before.found and before.manifest is None
    assert re.fullmatch(r"[0-9a-f]{64}", before.cache_key)
    baked = client.bake(assets / BOX, tmp_path, **settings)
    assert baked.cache_key == before.cache_key
    after = client.lookup(assets / BOX, **settings)
    assert after.found and after.cache_key == before.cache_key
    assert after.manifest is not None and after.manifest["cache_key"] == before.cache_key
    # Other settings are another key.
    assert client.lookup(assets / BOX, frames=8, resolution=96, quality_views=0).cache_key != before.cache_key


def test_batch_bakes_good_items_and_reports_bad_ones(client, assets, tmp_path) -> None:
    settings = dict(frames=3, resolution=64, quality_views=0)
    items = [
        (assets / BOX, settings),
        (assets / "no/such/model.glb", settings),
        (assets / DUCK, settings),
        (assets / BOX, dict(settings, layout="cubic")),
        (assets / BOX, settings),  # the same bake as item 0
        (assets / BOX, dict(settings, priority="50")),  # a wrong type: refused alone
    ]
    results = client.bake_batch(items, tmp_path, progress=lambda i, u: None)
    assert isinstance(results[0], impostor.BakeResult)
    assert isinstance(results[2], impostor.BakeResult)
    assert isinstance(results[4], impostor.BakeResult)
    assert results[4].cache_key == results[0].cache_key != results[2].cache_key
    assert isinstance(results[1], impostor.ImpostorError) and results[1].code == grpc.StatusCode.NOT_FOUND
    assert "no/such/model.glb" in results[1].message
    assert isinstance(results[3], impostor.ImpostorError) and results[3].code == grpc.StatusCode.INVALID_ARGUMENT
    assert "layout" in results[3].message
    assert isinstance(results[5], impostor.ImpostorError) and results[5].code == grpc.StatusCode.INVALID_ARGUMENT
    assert "priority" in results[5].message
    for r in (results[0], results[2]):
        assert_files_match_manifest(r.dir, r.manifest)
    assert results[0].dir == tmp_path / "0_Box" and results[2].dir == tmp_path / "2_Duck"


def test_batch_goes_on_past_a_blob_the_server_refuses(assets, tmp_path) -> None:
    """A blob over the server's size limit (as a full disk would) fails the
    models that need it; the others are submitted."""
    small = FarmServer(tmp_path / "data", local_workers=0, extra_args=["--max-blob-bytes=100000"])
    try:
        with impostor.Client(small.address) as c:
            helmet = assets / "props_pbr/DamagedHelmet/glTF-Binary/DamagedHelmet.glb"
            out = c.submit_batch([helmet, assets / BOX, helmet])
    finally:
        small.stop()
    for refused in (out[0], out[2]):
        assert refused.error is not None and "DamagedHelmet.glb" in refused.error.message, refused
    assert out[1].error is None and out[1].result is not None, out[1]


def test_batch_stops_when_the_callback_says_so(client, assets) -> None:
    settings = dict(frames=3, resolution=64, quality_views=0)
    seen: List[int] = []

    def on_submitted(index: int, submission: impostor.BatchSubmission) -> bool:
        seen.append(index)
        return index < 1

    out = client.submit_batch([(assets / BOX, settings)] * 4, on_submitted)
    assert seen == [0, 1]
    assert out[0].result is not None and out[1].result is not None
    assert [o.error.code for o in out[2:]] == [grpc.StatusCode.CANCELLED] * 2
    for o in out[:2]:
        assert client.watch(o.result.job_id).state == "succeeded"


@pytest.mark.parametrize(
    "settings, field",
    [
        (dict(frames=1), "frames"),
        (dict(frames=65), "frames"),
        (dict(resolution=32), "resolution"),
        (dict(frames=4, resolution=128, supersampling=9), "supersampling"),
        (dict(product="cards", frames=4), "frames"),
        (dict(priority=101), "priority"),
        (dict(required_tags=["gpu", "GPU"]), "required_tags[1]"),
    ],
    ids=["frames-too-few", "frames-too-many", "resolution-too-small", "supersampling", "cards-with-frames",
         "priority", "required-tag"],
)
def test_bad_settings_carry_the_servers_status(client, assets, settings, field) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        client.submit(assets / BOX, **settings)
    e = caught.value
    assert e.code == grpc.StatusCode.INVALID_ARGUMENT, e
    assert e.rpc == "SubmitBake" and e.server == client.server and e.is_rpc_error
    assert field in e.server_message, e.server_message
    assert e.server_message in e.message


@pytest.mark.parametrize(
    "model, settings, code, words",
    [
        ("no/such.glb", {}, grpc.StatusCode.NOT_FOUND, "not found"),
        ("LICENSES", {}, grpc.StatusCode.INVALID_ARGUMENT, "not a regular file"),
        ("MANIFEST.md", {}, grpc.StatusCode.INVALID_ARGUMENT, "expected a .gltf or .glb"),
        ("edge_cases/gltf-validator-tests/base/data/glb/invalid_magic.glb", {}, grpc.StatusCode.INVALID_ARGUMENT, "magic"),
        ("edge_cases/gltf-validator-tests/base/data/json/invalid_syntax.gltf", {}, grpc.StatusCode.INVALID_ARGUMENT,
         "invalid JSON"),
        ("edge_cases/gltf-validator-tests/base/data/buffer/not_found.gltf", {}, grpc.StatusCode.NOT_FOUND, "buffers[0].uri"),
        ("edge_cases/missing_textures/BoxTextured_png_removed/BoxTextured.gltf", {}, grpc.StatusCode.NOT_FOUND,
         "CesiumLogoFlat.png"),
        (BOX, {"layout": "cubic"}, grpc.StatusCode.INVALID_ARGUMENT, "layout"),
        (BOX, {"product": "voxels"}, grpc.StatusCode.INVALID_ARGUMENT, "product"),
        (BOX, {"framez": 4}, grpc.StatusCode.INVALID_ARGUMENT, "framez"),
        (BOX, {"frames": -1}, grpc.StatusCode.INVALID_ARGUMENT, "frames"),
        (BOX, {"priority": "high"}, grpc.StatusCode.INVALID_ARGUMENT, "priority: 'high'"),
        (BOX, {"min_iou": "0.9"}, grpc.StatusCode.INVALID_ARGUMENT, "min_iou: '0.9'"),
        (BOX, {"lod_ratios": 0.5}, grpc.StatusCode.INVALID_ARGUMENT, "lod_ratios: 0.5 is not valid here (expected a list)"),
        (BOX, {"frames": True}, grpc.StatusCode.INVALID_ARGUMENT, "frames: True"),
        (BOX, {"required_tags": "gpu"}, grpc.StatusCode.INVALID_ARGUMENT,
         "required_tags: 'gpu' is not valid here (expected a list)"),
    ],
    ids=["missing", "directory", "not-gltf", "bad-glb-magic", "bad-json", "missing-buffer", "missing-texture",
         "layout", "product", "unknown-setting", "negative-frames", "priority-text", "gate-text", "ratios-scalar",
         "frames-bool", "tags-scalar"],
)
def test_bad_local_input_is_refused_before_any_rpc(client, assets, model, settings, code, words) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        client.submit(assets / model, **settings)
    assert caught.value.code == code, caught.value
    assert words in caught.value.message
    assert not caught.value.is_rpc_error


def test_a_uri_leaving_the_model_folder_is_refused(client, tmp_path) -> None:
    (tmp_path / "m.gltf").write_text(json.dumps({"asset": {"version": "2.0"}, "buffers": [{"uri": "../x.bin"}]}))
    with pytest.raises(impostor.ImpostorError) as caught:
        client.submit(tmp_path / "m.gltf")
    assert caught.value.code == grpc.StatusCode.INVALID_ARGUMENT and '".."' in caught.value.message


def test_a_symlink_out_of_the_folder_is_refused(client, assets, tmp_path) -> None:
    (tmp_path / "m.gltf").write_text(json.dumps({"asset": {"version": "2.0"}, "buffers": [{"uri": "x.bin"}]}))
    (tmp_path / "x.bin").symlink_to(assets / "MANIFEST.md")
    with pytest.raises(impostor.ImpostorError) as caught:
        client.submit(tmp_path / "m.gltf")
    assert caught.value.code == grpc.StatusCode.PERMISSION_DENIED and "symbolic link" in caught.value.message


def test_quality_gate_failure_raises_with_the_jobs_code(client, assets, tree_bake, tmp_path) -> None:
    first, _ = tree_bake
    with pytest.raises(impostor.ImpostorError) as caught:
        client.bake(assets / TREE, tmp_path, min_psnr_db=100, **SMALL)
    e = caught.value
    assert e.code == grpc.StatusCode.FAILED_PRECONDITION, e
    assert e.cache_key == first.cache_key and e.job_id  # the gate is not part of the key
    assert "psnr" in e.message.lower()
    # The result is still there for inspection.
    assert_files_match_manifest(tmp_path / "gated", client.fetch(e.cache_key, tmp_path / "gated").manifest)


@pytest.mark.parametrize(
    "call, code",
    [
        (lambda c: c.fetch("0" * 64, "/nonexistent/never"), grpc.StatusCode.NOT_FOUND),
        (lambda c: c.fetch("not-a-key", "/nonexistent/never"), grpc.StatusCode.INVALID_ARGUMENT),
        (lambda c: c.get_job("no-such-job"), grpc.StatusCode.NOT_FOUND),
        (lambda c: c.watch(""), grpc.StatusCode.INVALID_ARGUMENT),
        (lambda c: c.get_manifest("0" * 64), grpc.StatusCode.NOT_FOUND),
    ],
    ids=["fetch-unknown-key", "fetch-malformed-key", "get-unknown-job", "watch-empty-id", "manifest-unknown-key"],
)
def test_rpc_errors_carry_the_servers_code(client, call, code) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        call(client)
    assert caught.value.code == code, caught.value
    assert caught.value.is_rpc_error and caught.value.server == client.server


def test_connecting_to_nothing_is_unavailable(tmp_path) -> None:
    import socket

    with socket.socket() as s:  # a port nobody listens on: bound, never listening
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        with pytest.raises(impostor.ImpostorError) as caught:
            impostor.Client(f"127.0.0.1:{port}", connect_timeout_seconds=30)
    assert caught.value.code == grpc.StatusCode.UNAVAILABLE
    assert "refused" in caught.value.message and caught.value.rpc == "Connect"


def test_each_kind_of_unreachable_server_is_named() -> None:
    import http.server
    import socket

    web = http.server.HTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
    threading.Thread(target=web.serve_forever, daemon=True).start()
    try:
        with pytest.raises(impostor.ImpostorError) as not_grpc:
            impostor.Client(f"127.0.0.1:{web.server_address[1]}", connect_timeout_seconds=30)
    finally:
        web.shutdown()
        web.server_close()
    assert "not a gRPC server" in not_grpc.value.message, not_grpc.value
    with pytest.raises(impostor.ImpostorError) as no_name:
        impostor.Client("nohost.invalid:50051", connect_timeout_seconds=30)
    assert "does not resolve" in no_name.value.message, no_name.value
    # A listener that never accepts: the connection is made (the kernel's
    # backlog) but no gRPC server ever speaks.
    with socket.socket() as silent:
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        with pytest.raises(impostor.ImpostorError) as stopped:
            impostor.Client(f"127.0.0.1:{silent.getsockname()[1]}", connect_timeout_seconds=2)
    assert stopped.value.code == grpc.StatusCode.UNAVAILABLE
    assert "refused" not in stopped.value.message, stopped.value


def test_a_script_that_never_closes_its_client_still_exits(farm) -> None:
    """A subscribed gRPC channel left open hung the interpreter at exit."""
    import subprocess

    script = (
        "import impostor\n"
        f"farm = impostor.Client({farm.address!r})\n"
        "try:\n"
        "    farm.get_job('job-that-does-not-exist')\n"
        "except impostor.ImpostorError:\n"
        "    pass\n"
        "print('done')\n"
    )
    package_dir = str(Path(impostor.__file__).resolve().parent.parent)
    run = subprocess.run(
        [sys.executable, "-c", script],
        env={**os.environ, "PYTHONPATH": package_dir},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "done"


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(max_attempts=0), "max_attempts"),
        (dict(max_outage_seconds=-1), "max_outage_seconds"),
        (dict(max_outage_seconds=86401), "max_outage_seconds"),
        (dict(rpc_timeout_seconds=0), "rpc_timeout_seconds"),
        (dict(tls_cert="c.pem"), "tls_key"),
        (dict(token_file="/nonexistent/token"), "token_file"),
        (dict(tls_ca="/nonexistent/ca.pem"), "tls_ca"),
    ],
    ids=["attempts", "outage-negative", "outage-too-long", "timeout", "cert-without-key", "token-file",
         "tls-ca"],
)
def test_bad_client_options_are_invalid_argument(farm, kwargs, words) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        impostor.Client(farm.address, **kwargs)
    assert caught.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert words in caught.value.message


def test_token_and_client_id_reach_the_wire_as_metadata(tmp_path) -> None:
    """The token travels as "authorization: Bearer <token>" on every call, as
    the server's auth layer reads it: seen here by a stand-in BakeService."""
    from concurrent import futures

    from impostor.v1 import bake_service_pb2_grpc, types_pb2

    seen: List[dict] = []

    class Recorder(bake_service_pb2_grpc.BakeServiceServicer):
        def GetJob(self, request, context):  # noqa: N802 (gRPC's name)
            seen.append(dict(context.invocation_metadata()))
            return types_pb2.Job(job_id=request.job_id, state=types_pb2.JOB_STATE_QUEUED)

    server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
    bake_service_pb2_grpc.add_BakeServiceServicer_to_server(Recorder(), server)
    port = server.add_insecure_port("127.0.0.1:0")
    server.start()
    try:
        token_file = tmp_path / "token"
        token_file.write_text("s3cret-token\nignored second line\n")
        with impostor.Client(f"127.0.0.1:{port}", token_file=token_file, client_id="ci-nightly") as c:
            assert c.get_job("j1").state == "queued"
        with impostor.Client(f"127.0.0.1:{port}", token="explicit", token_file=token_file) as c:
            c.get_job("j2")
    finally:
        server.stop(None)
    assert seen[0]["authorization"] == "Bearer s3cret-token"
    assert seen[0]["impostor-client-id"] == "ci-nightly"
    assert seen[1]["authorization"] == "Bearer explicit"


def test_a_blob_lost_between_upload_and_submit_is_uploaded_again(assets: Path) -> None:
    """A server that evicted the model's blob after its upload refuses the
    submit with the reason INPUT_BLOB_MISSING: the client uploads it again and
    submits once more, with the same request id, twice at most (a stand-in
    server that loses the blob at the first two, then at every submit)."""
    from concurrent import futures

    from impostor.v1 import asset_service_pb2, asset_service_pb2_grpc, bake_service_pb2, bake_service_pb2_grpc

    store: Set[str] = set()
    submits: List[str] = []
    evictions = {"left": 1}

    class Assets(asset_service_pb2_grpc.AssetServiceServicer):
        def FindMissingBlobs(self, request, context):  # noqa: N802 (gRPC's name)
            return asset_service_pb2.FindMissingBlobsResponse(
                missing=[d for d in request.digests if d.hash not in store])

        def UploadBlob(self, request_iterator, context):  # noqa: N802
            digest = None
            for chunk in request_iterator:
                if chunk.HasField("digest"):
                    digest = chunk.digest
            store.add(digest.hash)
            return asset_service_pb2.UploadBlobResponse(digest=digest)

    class Bake(bake_service_pb2_grpc.BakeServiceServicer):
        def SubmitBake(self, request, context):  # noqa: N802
            submits.append(request.request_id)
            if evictions["left"] != 0:
                evictions["left"] -= 1
                store.clear()
            if request.mesh.entry.digest.hash not in store:
                context.set_trailing_metadata((("impostor-error-reason", "INPUT_BLOB_MISSING"),))
                context.set_code(grpc.StatusCode.FAILED_PRECONDITION)
                context.set_details("mesh.entry: blob is not in the store; upload it first")
                return bake_service_pb2.SubmitBakeResponse()
            return bake_service_pb2.SubmitBakeResponse(job_id="job-1", cache_key="a" * 64)

    server = grpc.server(futures.ThreadPoolExecutor(max_workers=2))
    asset_service_pb2_grpc.add_AssetServiceServicer_to_server(Assets(), server)
    bake_service_pb2_grpc.add_BakeServiceServicer_to_server(Bake(), server)
    port = server.add_insecure_port("127.0.0.1:0")
    server.start()
    try:
        with impostor.Client(f"127.0.0.1:{port}", max_attempts=1) as c:
            result = c.submit(assets / BOX, **SMALL)
            assert result.job_id == "job-1"
            assert result.upload.uploaded == 2, "uploaded, lost, uploaded again"
            assert len(submits) == 2 and submits[0] == submits[1], "one logical submit"
            evictions["left"] = -1  # every submit from now on
            submits.clear()
            with pytest.raises(impostor.ImpostorError) as caught:
                c.submit(assets / BOX, **SMALL)
    finally:
        server.stop(None)
    assert caught.value.code == grpc.StatusCode.FAILED_PRECONDITION
    assert caught.value.reason == "INPUT_BLOB_MISSING"
    assert len(submits) == 3, "the first try and two uploads again, then the answer"
