"""Blob transfer: uploading what the store lacks of some models, the small
files many to a BatchUpdateBlobs call (as client/transfer/mesh_upload.cc and
blob_batch_upload.cc) and downloading a blob into a staged file
(_result_install), resumed at the byte offset after a break and verified
against its digest (as client/transfer/blob_download.cc): a result's gRPC
road."""
from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Callable, Dict, Iterator, List, Optional, Sequence, Set, Tuple, Union

import grpc

from ._mesh_files import MeshFile, MeshFiles
from ._result_install import StagedFile, Staging
from ._transport import Transport
from .errors import ImpostorError
from .results import UploadStats
from .v1 import asset_service_pb2 as asset_pb
from .v1 import types_pb2 as pb

# Bytes per UploadBlob message (the server takes at most 4 MiB). The stall
# watchdog sees progress only when the link has taken a whole message, so a
# message must cross the slowest link well within rpc_timeout_seconds: a
# 1 MiB one needs 87 s at 12 KB/s, a 64 KiB one 5 s (as the C++ SDK's
# kUploadChunkBytes, client/transfer/blob_upload.h).
UPLOAD_CHUNK_BYTES = 64 << 10
MAX_FIND_MISSING_DIGESTS = 10000  # per FindMissingBlobs, the server's limit
# Blobs up to this size are read many to a BatchReadBlobs call and stored
# many to a BatchUpdateBlobs call, within the server's limits per call (the
# same for both, as in the C++ SDK: common/net/batch_read.h).
BATCH_BLOB_MAX_BYTES = 1 << 20
MAX_BATCH_DIGESTS = 1000
MAX_BATCH_BYTES = 4 << 20
# An upload's BatchUpdateBlobs call carries at most one UploadBlob message's
# bytes, blobs of at most that many each: the uplink may be an artist's slow
# one, and a call must cross it as soon as one message of a stream would. A
# 1 MiB call took 53 s at 20 KB/s, and the connection's keepalive gave up on
# it (its ping waited behind the call's bytes): tests/test_slow_link.py. As
# the C++ SDK's kUploadBatchMaxBytes (client/transfer/blob_batch_upload.h).
UPLOAD_BATCH_MAX_BYTES = UPLOAD_CHUNK_BYTES

_Key = Tuple[str, int]


def _digest(f: MeshFile) -> "pb.Digest":
    return pb.Digest(hash=f.hash, size_bytes=f.size_bytes)


def mesh_input(files: MeshFiles) -> "pb.MeshInput":
    """The MeshInput of a model whose files are (or will be) in the store."""
    mesh = pb.MeshInput()
    mesh.entry.path = files.entry.relative_path
    mesh.entry.digest.CopyFrom(_digest(files.entry))
    for f in files.files:
        mesh.files.add(path=f.relative_path, digest=_digest(f))
    return mesh


def _upload_once(transport: Transport, blob: MeshFile, offset: int = 0) -> None:
    """One UploadBlob stream of `blob` from its byte `offset` (0: the whole
    blob, dropping what the server kept of an earlier try)."""
    def chunks() -> Iterator[asset_pb.UploadBlobRequest]:
        with open(blob.local_path, "rb") as f:
            f.seek(offset)
            first = True
            while True:
                data = f.read(UPLOAD_CHUNK_BYTES)
                if first:
                    yield asset_pb.UploadBlobRequest(digest=_digest(blob), data=data, offset=offset)
                    first = False
                elif data:
                    yield asset_pb.UploadBlobRequest(data=data)
                if not data:
                    return

    transport.upload_blob(chunks(), blob.size_bytes)


def _resume_offset(transport: Transport, blob: MeshFile) -> int:
    """Where the next stream starts: the bytes the server kept of an earlier
    try (QueryUpload), -1 when it has the whole blob, 0 when it kept nothing
    or cannot say (a server older than QueryUpload: UNIMPLEMENTED)."""
    try:
        held = transport.unary("QueryUpload", transport.assets.QueryUpload,
                               asset_pb.QueryUploadRequest(digest=_digest(blob)))
    except ImpostorError:
        return 0
    if held.complete:
        return -1
    kept = int(held.committed_bytes)
    return kept if 0 < kept < blob.size_bytes else 0


def _upload_with_retry(transport: Transport, blob: MeshFile) -> None:
    """Uploads `blob`, resuming after what the server kept of a broken try
    (as the C++ SDK's UploadBlobFile, client/transfer/blob_upload.h): each
    try but a one-message blob's first asks QueryUpload and sends only the
    rest; a try after which the server kept more starts the count of
    failures in a row over."""
    retry = transport.retry_policy()
    ask = blob.size_bytes > UPLOAD_CHUNK_BYTES
    resumed_at = 0
    moved_kept = 0  # FAILED_PRECONDITIONs in a row: the kept partial changed under us
    while True:
        offset = 0
        if ask:
            offset = _resume_offset(transport, blob)
            if offset < 0:
                return  # the store has it
            if offset > resumed_at:
                retry.made_progress()
        resumed_at = offset
        try:
            _upload_once(transport, blob, offset)
            return
        except ImpostorError as e:
            if e.code == grpc.StatusCode.FAILED_PRECONDITION and offset > 0 and moved_kept < 3:
                moved_kept += 1
                ask = True
                continue
            moved_kept = 0
            if not retry.should_retry(e):
                raise
            ask = True


# Upload errors about the blob itself (the server's disk is full, the blob
# is too large): the models needing it fail and the others go on. Anything
# else (the caller refused, the link down) ends the whole upload.
_BLOB_REFUSALS = (
    grpc.StatusCode.RESOURCE_EXHAUSTED,
    grpc.StatusCode.INVALID_ARGUMENT,
    grpc.StatusCode.FAILED_PRECONDITION,
    grpc.StatusCode.DATA_LOSS,
    grpc.StatusCode.NOT_FOUND,
)


def _read_whole(path: Path) -> Optional[bytes]:
    """The file's bytes, or None when it cannot be read (its stream's try
    then says why, naming it)."""
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError:
        return None


def _send_batch(transport: Transport, blobs: Sequence[MeshFile], batch: Sequence[int], stored: List[bool],
                refused: List[str]) -> bool:
    """One BatchUpdateBlobs call of the blobs `batch` (indices into
    `blobs`): marks stored[i] for each the server holds now, refused[i] with
    the code of each it refused in its slot. False from a server older than
    the call (UNIMPLEMENTED); a refusal of the whole request (a quota)
    leaves its blobs to the stream. Raises ImpostorError: the call's error
    that ends the upload (not a refusal of a blob)."""
    sent: List[int] = []
    request = asset_pb.BatchUpdateBlobsRequest()
    for i in batch:
        data = _read_whole(blobs[i].local_path)
        if data is None:
            continue
        request.requests.add(digest=_digest(blobs[i]), data=data)
        sent.append(i)
    if not sent:
        return True
    try:
        response = transport.batch_update_blobs(request)
    except ImpostorError as e:
        if e.code == grpc.StatusCode.UNIMPLEMENTED:
            return False
        if e.code not in _BLOB_REFUSALS:
            raise
        return True  # refused whole: each blob's stream gets its own answer
    if len(response.responses) != len(sent):
        return True  # an answer amiss says nothing of any blob: the streams ask again
    for i, answer in zip(sent, response.responses):
        if answer.digest.hash != blobs[i].hash or answer.digest.size_bytes != blobs[i].size_bytes:
            continue
        if answer.code == 0:
            stored[i] = True
        else:
            refused[i] = _status_code(answer.code).name
    return True


def _upload_blob_files(transport: Transport, blobs: Sequence[MeshFile]) -> "List[Optional[ImpostorError]]":
    """Puts `blobs` (distinct) into the store, as the C++ SDK's
    UploadBlobFiles (client/transfer/blob_batch_upload.h): those of at most
    UPLOAD_BATCH_MAX_BYTES in BatchUpdateBlobs calls of at most that many
    bytes (pack_batches), until a
    server older than the call answers UNIMPLEMENTED; then every blob not
    stored (the large ones, an older server's, a blob a batch refused: its
    one retry) through UploadBlob with its retries. Returns each blob's
    refusal (_BLOB_REFUSALS; its batch's code added when it refused the
    blob too), or None once stored. Raises ImpostorError for any other
    error (the caller refused, the link down), which ends the upload."""
    stored = [False] * len(blobs)
    refused = [""] * len(blobs)
    small = [i for i, b in enumerate(blobs) if b.size_bytes <= UPLOAD_BATCH_MAX_BYTES]
    for packed in pack_batches([blobs[i].size_bytes for i in small], max_bytes=UPLOAD_BATCH_MAX_BYTES):
        if not _send_batch(transport, blobs, [small[k] for k in packed], stored, refused):
            break
    out: List[Optional[ImpostorError]] = [None] * len(blobs)
    for i, blob in enumerate(blobs):
        if stored[i]:
            continue
        try:
            _upload_with_retry(transport, blob)
        except ImpostorError as e:
            if e.code not in _BLOB_REFUSALS:
                raise
            out[i] = e
            if refused[i]:
                out[i] = ImpostorError(e.code, f"{e.message} (refused in its batch first: {refused[i]})",
                                       server_message=e.server_message, rpc=e.rpc, server=e.server, reason=e.reason)
    return out


def upload_meshes(transport: Transport, models: Sequence[MeshFiles]) -> "List[Union[UploadStats, ImpostorError]]":
    """Uploads every distinct blob of `models` the server lacks, once (one
    FindMissingBlobs per 10,000 blobs; the small ones many to a
    BatchUpdateBlobs call: _upload_blob_files). Returns each model's
    UploadStats (an upload counts for the first model that has the blob),
    or the error of a blob of it that the server refused (RESOURCE_EXHAUSTED
    on a full disk, ...; naming the file): the other models go on, as in the
    C++ SDK (client/transfer/mesh_upload.h).
    Raises ImpostorError when FindMissingBlobs fails or an upload fails for
    the caller or the connection."""
    blobs: List[MeshFile] = []
    users: List[List[int]] = []
    index_of: Dict[_Key, int] = {}
    stats: List[Dict[str, int]] = []
    for m, model in enumerate(models):
        s = {"files": 0, "uploaded": 0, "bytes_total": 0, "bytes_uploaded": 0}
        for f in model.all():
            s["files"] += 1
            s["bytes_total"] += f.size_bytes
            key = (f.hash, f.size_bytes)
            if key not in index_of:
                index_of[key] = len(blobs)
                blobs.append(f)
                users.append([])
            if not users[index_of[key]] or users[index_of[key]][-1] != m:
                users[index_of[key]].append(m)
        stats.append(s)
    missing: Set[_Key] = set()
    for begin in range(0, len(blobs), MAX_FIND_MISSING_DIGESTS):
        request = asset_pb.FindMissingBlobsRequest(
            digests=[_digest(b) for b in blobs[begin : begin + MAX_FIND_MISSING_DIGESTS]]
        )
        response = transport.unary("FindMissingBlobs", transport.assets.FindMissingBlobs, request)
        missing.update((d.hash, d.size_bytes) for d in response.missing)
    to_upload = [k for k, b in enumerate(blobs) if (b.hash, b.size_bytes) in missing]
    outcomes = _upload_blob_files(transport, [blobs[k] for k in to_upload])
    errors: Dict[int, ImpostorError] = {}
    for k, e in zip(to_upload, outcomes):
        blob, who = blobs[k], users[k]
        if e is not None:
            for m in who:
                errors.setdefault(m, ImpostorError(e.code, f"uploading {blob.local_path}: {e.message}",
                                                   server_message=e.server_message, rpc=e.rpc, server=e.server,
                                                   reason=e.reason))
            continue
        stats[who[0]]["uploaded"] += 1
        stats[who[0]]["bytes_uploaded"] += blob.size_bytes
    return [errors[m] if m in errors else UploadStats(**s) for m, s in enumerate(stats)]


def pack_batches(sizes: Sequence[int], max_bytes: int = MAX_BATCH_BYTES) -> List[List[int]]:
    """Splits blobs of these sizes (each at most max_bytes) into batch calls
    of at most MAX_BATCH_DIGESTS blobs and max_bytes bytes (by default the
    server's limits), keeping their order: the indices of each call's
    blobs."""
    batches: List[List[int]] = []
    total = 0
    for i, size in enumerate(sizes):
        if not batches or len(batches[-1]) == MAX_BATCH_DIGESTS or total + size > max_bytes:
            batches.append([])
            total = 0
        batches[-1].append(i)
        total += size
    return batches


def read_blob_batch(transport: Transport, digests: Sequence["pb.Digest"], names: Sequence[str]) -> "List[bytes] | None":
    """The blobs' bytes from one BatchReadBlobs call, each checked against
    its digest (size and SHA-256), or None from a server older than the call
    (UNIMPLEMENTED: read them with ReadBlob). `names` (one per digest) go
    into errors. Raises ImpostorError: a blob's own code (NOT_FOUND,
    DATA_LOSS, ...) or DATA_LOSS for an answer that does not match, naming
    the blob; the call's error."""
    request = asset_pb.BatchReadBlobsRequest(digests=list(digests))
    try:
        response = transport.unary("BatchReadBlobs", transport.assets.BatchReadBlobs, request)
    except ImpostorError as e:
        if e.code == grpc.StatusCode.UNIMPLEMENTED:
            return None
        raise
    if len(response.blobs) != len(digests):
        raise ImpostorError(
            grpc.StatusCode.DATA_LOSS, f"BatchReadBlobs: answered {len(response.blobs)} blobs for {len(digests)} asked"
        )
    out: List[bytes] = []
    for blob, want, name in zip(response.blobs, digests, names):
        label = f"{name}: BatchReadBlobs {want.hash}/{want.size_bytes}"
        if blob.digest.hash != want.hash or blob.digest.size_bytes != want.size_bytes:
            raise ImpostorError(grpc.StatusCode.DATA_LOSS, f"{label}: answered with {blob.digest.hash}")
        if blob.code != 0:
            raise ImpostorError(_status_code(blob.code), f"{label}: {blob.message}")
        if len(blob.data) != want.size_bytes or hashlib.sha256(blob.data).hexdigest() != want.hash:
            raise ImpostorError(grpc.StatusCode.DATA_LOSS, f"{label}: received bytes do not match")
        out.append(blob.data)
    return out


def _status_code(number: int) -> grpc.StatusCode:
    """The grpc.StatusCode of a numeric code (UNKNOWN for one outside the
    enum)."""
    for code in grpc.StatusCode:
        if code.value[0] == number:
            return code
    return grpc.StatusCode.UNKNOWN


def download_blob_to_staged(transport: Transport, digest: "pb.Digest", staged: StagedFile) -> None:
    """Streams the blob into `staged` (_result_install.StagedFile), verified
    against its digest; install_result (or download_blob_to_file) renames
    it into place. A broken stream is resumed where it stopped; bytes
    arriving start the failure count over. Raises ImpostorError: DATA_LOSS
    when the bytes do not match the digest, INTERNAL for a local write
    error (never retried), or the RPC's error."""
    name = f"{digest.hash}/{digest.size_bytes}"
    sha = hashlib.sha256()
    received = 0
    retry = transport.retry_policy()
    while True:
        start = received
        try:
            request = asset_pb.ReadBlobRequest(digest=digest, offset=received)
            for chunk in transport.read_blob(request, digest.size_bytes - received):
                if chunk.offset != received:
                    raise ImpostorError(
                        grpc.StatusCode.DATA_LOSS,
                        f"ReadBlob {name}: chunk at offset {chunk.offset}, expected {received}",
                    )
                if len(chunk.data) > digest.size_bytes - received:
                    raise ImpostorError(
                        grpc.StatusCode.DATA_LOSS,
                        f"ReadBlob {name}: server sent more than the blob's {digest.size_bytes} bytes",
                    )
                sha.update(chunk.data)
                staged.write(chunk.data)
                received += len(chunk.data)
            if received == digest.size_bytes:
                break
            # Ended OK but short: treated like a broken stream.
            error = ImpostorError(
                grpc.StatusCode.UNAVAILABLE,
                f"ReadBlob {name}: stream ended after {received} of {digest.size_bytes} bytes",
            )
        except ImpostorError as e:
            if e.rpc is None:
                raise  # ours (bytes that cannot be the blob's, a local write error), not the stream's
            error = e
        if received > start:
            retry.made_progress()
        if not retry.should_retry(error):
            raise error
    if sha.hexdigest() != digest.hash:
        raise ImpostorError(
            grpc.StatusCode.DATA_LOSS, f"{staged.path}: ReadBlob {name}: received bytes hash to {sha.hexdigest()}"
        )


def download_blob_to_file(transport: Transport, digest: "pb.Digest", path: Path) -> None:
    """Writes the blob to `path` atomically (a temporary file beside it,
    synced and renamed into place once every byte arrived and matched the
    digest): download_blob_to_staged for one file."""
    staged = StagedFile(path)
    try:
        download_blob_to_staged(transport, digest, staged)
        staged.commit()
    finally:
        staged.abort()  # a no-op once committed


#: How a file that goes in no BatchReadBlobs batch is staged:
#: stream(name, path, digest, staging). Default: one ReadBlob stream
#: (download_blob_to_staged); the Client's, a front end the farm advertises
#: first (_farm_http.AdvertisedFrontEnd).
Stream = Callable[[str, Path, "pb.Digest", Staging], None]


def stage_over_grpc(transport: Transport, missing: Sequence[Tuple[str, Path, "pb.Digest"]], staging: Staging,
                    stream: Optional[Stream] = None) -> None:
    """install_result's gRPC road: the large files first, one `stream` each
    (by default a ReadBlob stream); then the small ones many to a
    BatchReadBlobs call (one round trip for a result's view images and
    manifest), or one stream each from a server older than the call."""
    def over_read_blob(name: str, path: Path, digest: "pb.Digest", staging: Staging) -> None:
        download_blob_to_staged(transport, digest, staging.stage(path))

    one_each = stream if stream is not None else over_read_blob
    # The large files first, largest first: each is complete once the next
    # is staged, and its flush to disk then overlaps the rest of the fetch
    # (_result_install.EarlySync); the last file staged is a small one.
    for name, path, digest in sorted((f for f in missing if f[2].size_bytes > BATCH_BLOB_MAX_BYTES),
                                     key=lambda f: -f[2].size_bytes):
        one_each(name, path, digest, staging)
    small = [(path, digest) for _, path, digest in missing if digest.size_bytes <= BATCH_BLOB_MAX_BYTES]
    staged: Set[Path] = set()
    for batch in pack_batches([digest.size_bytes for _, digest in small]):
        got = read_blob_batch(transport, [small[i][1] for i in batch], [str(small[i][0]) for i in batch])
        if got is None:
            break
        for i, data in zip(batch, got):
            staging.stage(small[i][0]).write(data)  # verified by read_blob_batch
            staged.add(small[i][0])
    for name, path, digest in missing:
        if path not in staged and digest.size_bytes <= BATCH_BLOB_MAX_BYTES:
            one_each(name, path, digest, staging)  # a server older than BatchReadBlobs


def download_blob_to_bytes(transport: Transport, digest: "pb.Digest") -> bytes:
    """The blob's bytes, verified (small blobs: manifests)."""
    retry = transport.retry_policy()
    while True:
        try:
            data = b"".join(
                c.data for c in transport.read_blob(asset_pb.ReadBlobRequest(digest=digest), digest.size_bytes)
            )
            break
        except ImpostorError as e:
            if not retry.should_retry(e):
                raise
    if len(data) != digest.size_bytes or hashlib.sha256(data).hexdigest() != digest.hash:
        raise ImpostorError(
            grpc.StatusCode.DATA_LOSS, f"ReadBlob {digest.hash}/{digest.size_bytes}: received bytes do not match"
        )
    return data
