"""Client: a connection to one impostor bake server.

    import impostor
    with impostor.Client("bake.example.com:50051", token_file="~/.impostor/token") as farm:
        result = farm.bake("tree/scene.gltf", frames=12, resolution=2048,
                           progress=lambda u: print(u.state, u.stage, f"{u.progress:.0%}"))
        print(result.cache_key, result.quality["silhouette_iou_mean"], result.files)
"""
from __future__ import annotations

import dataclasses
import json
import logging
import os
import secrets
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import grpc
from google.protobuf import json_format

from ._blobs import download_blob_to_bytes, download_blob_to_staged, mesh_input, stage_over_grpc, upload_meshes
from ._farm_http import (
    FARM_HTTP_METADATA_KEY,
    AdvertisedFrontEnd,
    FrontEnd,
    FrontEndFailure,
    farm_http_turned_off,
    resolve_farm_http,
)
from ._mesh_files import MeshFiles, collect_mesh_files
from ._result_install import MANIFEST_FILE_NAME as MANIFEST_FILE_NAME  # this module's name as before
from ._result_install import Staging, install_result, manifest_problem
from ._retry import ConnectionEvent
from ._transport import Transport, TransportOptions, check_options, resolve_token
from .errors import ImpostorError, status_code_from_int
from .results import BakeResult, BatchSubmission, FetchResult, JobUpdate, LookupResult, SubmitResult
from .settings import BakeSettings
from .v1 import asset_service_pb2 as asset_pb
from .v1 import bake_service_pb2 as bake_pb
from .v1 import types_pb2 as pb

PathLike = Union[str, "os.PathLike[str]"]
ProgressCallback = Callable[[JobUpdate], None]
#: A batch item: a model path, or (path, settings as a dict of bake settings).
BatchItem = Union[PathLike, Tuple[PathLike, Mapping[str, Any]]]

_log = logging.getLogger(__name__)

_STATE_NAMES = {
    pb.JOB_STATE_QUEUED: "queued",
    pb.JOB_STATE_RUNNING: "running",
    pb.JOB_STATE_SUCCEEDED: "succeeded",
    pb.JOB_STATE_FAILED: "failed",
    pb.JOB_STATE_CANCELLED: "cancelled",
}


def _job_update(job: "pb.Job") -> JobUpdate:
    return JobUpdate(
        job_id=job.job_id,
        cache_key=job.cache_key,
        state=_STATE_NAMES.get(job.state, "unknown"),
        progress=job.progress,
        stage=job.stage,
        error_code=job.error.code if job.HasField("error") else 0,
        error_message=job.error.message if job.HasField("error") else "",
        cached=job.cached,
    )


# Submits are tried this many times more when the server has lost one of the
# mesh's blobs since it was uploaded (the C++ SDK's kReuploadsPerSubmit).
_REUPLOADS_PER_SUBMIT = 2


def _input_blob_missing(error: ImpostorError) -> bool:
    return error.code == grpc.StatusCode.FAILED_PRECONDITION and error.reason == "INPUT_BLOB_MISSING"


def _submit_result(response: "bake_pb.SubmitBakeResponse", upload: Any) -> SubmitResult:
    failed = response.job.state == pb.JOB_STATE_FAILED
    return SubmitResult(
        job_id=response.job_id,
        cache_key=response.cache_key,
        cached=response.cached,
        upload=upload,
        error_code=response.job.error.code if failed else 0,
        error_message=response.job.error.message if failed else "",
    )


def _check_manifest_files(manifest: "pb.Manifest", server: str, cache_key: str) -> None:
    """A server's manifest names only distinct plain files with valid digests
    (a result must never write outside its folder): manifest_problem."""
    problem = manifest_problem(manifest)
    if problem is not None:
        raise ImpostorError(grpc.StatusCode.INTERNAL, f"server {server} sent a bad result for {cache_key}: {problem}")


class Client:
    """A connection to one bake server: upload, bake, follow, download.

    Thread-safety: every method may be called from any thread, concurrently
    (the Blender add-on bakes on a worker thread). The Client owns its
    channel; close() it, or use it as a context manager.

    Args:
        server: "host:port" (any gRPC target string works), or several
            replicas of one farm, "host1:port,host2:port" (the C++ SDK's
            --server lists): calls stick to one address and move on to the
            next when it answers UNAVAILABLE (or DEADLINE_EXCEEDED: a replica
            that accepts but never answers); idempotent calls retry there,
            SubmitBake resends its request id, watches and downloads resume.
        token: bearer token, sent as "authorization: Bearer <token>" on every
            call. Default: the first line of `token_file`, else
            $IMPOSTOR_TOKEN, else none.
        token_file: file holding the token.
        tls_ca: PEM file of the CA that signed the server's certificate; the
            connection then uses TLS. Default: plaintext.
        tls_cert, tls_key: client certificate and key (PEM) for mutual TLS.
        rpc_timeout_seconds: deadline of every unary RPC. Uploads and
            downloads have no overall deadline, however slow the link, only
            this long at most without progress: no 64 KiB message taken by
            the link (an upload) or none arriving (a download); then
            DEADLINE_EXCEEDED "the link stalled", naming the seconds and the
            bytes. After an upload's last message the server's answer may
            take this long per 64 KiB the link may still hold (up to 4 MiB),
            plus once. A download then resumes at its byte offset, an upload
            after the bytes the server kept (as max_attempts allows).
            WatchJob has no deadline.
            Default 30, > 0.
        max_attempts: tries in all of a call failing with UNAVAILABLE or
            DEADLINE_EXCEEDED, outside an outage, with backoff 100 ms, 200 ms,
            ... capped at 1 s, minus up to 20% jitter. Default 5, >= 1.
        max_outage_seconds: how long a server that answered once may stay
            away (UNAVAILABLE) while calls keep retrying: uploads resume,
            SubmitBake resends its request id, WatchJob resumes via GetJob,
            downloads resume at their byte offset. 0 = max_attempts alone.
            Default 300, range 0..86400.
        connect_timeout_seconds: how long the constructor waits for the
            server (about a second when the connection is refused). Default 10.
        client_id: names this client to the server for per-client limits and
            fairness (the "impostor-client-id" metadata). Default: none.
        on_connection_change: called with a ConnectionEvent when the server
            stops answering and when it answers again; must return quickly.
        keepalive_seconds: while a call is in flight, ping the server after
            this many quiet seconds and give the connection up when no answer
            comes within min(this, 10) s, so a watch over a link that died
            without a reset moves on in seconds. Default 20, whole 1..7200.
        farm_http: the farm's HTTP front end, "http(s)://host[:port][/prefix]"
            (its --http-listen, or an https:// proxy before it; the C++
            SDK's ClientOptions::farm_http): fetch() (and bake()'s download)
            then take the result's listing and every file from it, verified,
            with the token as a bearer header and tls_ca for https://, and
            no gRPC at all; when it cannot give the result (refused, an
            error status, a spoiled listing or file, a stall of
            rpc_timeout_seconds) one warning is logged (logger
            "impostor.client", event=farm_http_fetch_fallback) and the whole
            result comes over gRPC. Default: $IMPOSTOR_FARM_HTTP; "none"
            turns both off. With tls_ca or tls_cert only https:// is
            accepted. With a front end, the gRPC connection is made at the
            first call that needs it (connect_timeout_seconds then), not by
            the constructor: a fetch over the front end needs none.
            Without one (and unless "none" turned it off), a front end the
            farm advertises (impostor-server --http-advertise, named on its
            GetResult answers) is used as the C++ SDK uses it: the listing
            and the small files stay on gRPC (BatchReadBlobs) and each large
            file (over 1 MiB, one ReadBlob stream each otherwise) comes from
            it, verified, with the same token, tls_ca and https:// rule. An
            advertisement that breaks these rules is refused with one
            warning (event=farm_http_advertisement_refused); a file the
            front end cannot give comes over ReadBlob after one warning
            (event=farm_http_fallback), and after 3 such files in a row the
            front end is given up for this Client (event=farm_http_given_up).

    Raises:
        ImpostorError: UNAVAILABLE when no server answers (without a front
            end); INVALID_ARGUMENT for out-of-range options, unreadable
            files or a malformed farm_http (naming it, or
            $IMPOSTOR_FARM_HTTP).
    """

    def __init__(
        self,
        server: str = "localhost:50051",
        *,
        token: Optional[str] = None,
        token_file: Optional[PathLike] = None,
        tls_ca: Optional[PathLike] = None,
        tls_cert: Optional[PathLike] = None,
        tls_key: Optional[PathLike] = None,
        rpc_timeout_seconds: float = 30.0,
        max_attempts: int = 5,
        max_outage_seconds: float = 300.0,
        connect_timeout_seconds: float = 10.0,
        client_id: str = "",
        on_connection_change: Optional[Callable[[ConnectionEvent], None]] = None,
        keepalive_seconds: int = 20,
        farm_http: Optional[str] = None,
    ) -> None:
        resolved_token = resolve_token(token, os.path.expanduser(token_file) if token_file else None)
        options = TransportOptions(
            tls_ca=tls_ca,
            tls_cert=tls_cert,
            tls_key=tls_key,
            rpc_timeout_seconds=rpc_timeout_seconds,
            max_attempts=max_attempts,
            max_outage_seconds=max_outage_seconds,
            connect_timeout_seconds=connect_timeout_seconds,
            keepalive_seconds=keepalive_seconds,
        )
        self._server = server
        self._lock = threading.Lock()
        self._closed = False
        self._transport: Optional[Transport] = None
        tls = tls_ca is not None or tls_cert is not None
        base = resolve_farm_http(farm_http, tls=tls)
        self._front_end: Optional[FrontEnd] = None
        # The front end the farm advertises, when none is given nor turned off.
        self._advertised: Optional[AdvertisedFrontEnd] = None
        if base:
            check_options(server, options)
            self._front_end = FrontEnd(
                base, token=resolved_token, ca_file=tls_ca, timeout_seconds=float(rpc_timeout_seconds)
            )
        elif not farm_http_turned_off(farm_http):
            self._advertised = AdvertisedFrontEnd(
                tls=tls, token=resolved_token, ca_file=tls_ca, timeout_seconds=float(rpc_timeout_seconds)
            )
        self._connect: Callable[[], Transport] = lambda: Transport(
            server, options, token=resolved_token, client_id=client_id, on_connection_change=on_connection_change
        )
        if self._front_end is None:
            self._transport = self._connect()

    @property
    def server(self) -> str:
        return self._server

    @property
    def farm_http(self) -> str:
        """The farm's HTTP front end fetch() reads from, as given (farm_http
        or $IMPOSTOR_FARM_HTTP); "" when none was (one the farm advertises
        is not shown here)."""
        return self._front_end.base if self._front_end is not None else ""

    def _grpc(self) -> Transport:
        """The gRPC transport, connected at the first call that needs it when
        the Client has a front end (a failed connect is tried again by the
        next call). CANCELLED once the Client is closed."""
        transport = self._transport
        if transport is not None:
            return transport
        with self._lock:
            if self._closed:
                raise ImpostorError(grpc.StatusCode.CANCELLED, f"the Client of {self._server} is closed")
            if self._transport is None:
                self._transport = self._connect()
            return self._transport

    def close(self) -> None:
        """Closes the channel; calls in flight fail with CANCELLED."""
        with self._lock:
            self._closed = True
            transport = self._transport
        if transport is not None:
            transport.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- submitting ---------------------------------------------------------

    def _submit_one(self, files: MeshFiles, settings: BakeSettings, upload: Any) -> SubmitResult:
        request = bake_pb.SubmitBakeRequest(mesh=mesh_input(files), parameters=settings.to_parameters())
        settings.apply_scheduling(request)
        # The same id on every retry: a retried submit never makes a second job.
        request.request_id = secrets.token_hex(16)
        t = self._grpc()
        for reuploads in range(_REUPLOADS_PER_SUBMIT + 1):
            try:
                return _submit_result(t.unary("SubmitBake", t.bake.SubmitBake, request), upload)
            except ImpostorError as e:
                # The server lost a blob since the upload (evicted under store
                # pressure while a batch uploaded the rest): upload it again.
                if reuploads == _REUPLOADS_PER_SUBMIT or not _input_blob_missing(e):
                    raise
            (again,) = upload_meshes(t, [files])
            if isinstance(again, ImpostorError):
                raise again
            upload = dataclasses.replace(
                upload,
                uploaded=upload.uploaded + again.uploaded,
                bytes_uploaded=upload.bytes_uploaded + again.bytes_uploaded,
            )
        raise AssertionError("unreachable")

    def submit(self, model: PathLike, **settings: Any) -> SubmitResult:
        """Uploads what the server lacks of `model` (a .gltf or .glb and every
        file its buffers and images refer to by relative URI) and submits a bake.

        `settings` are BakeSettings fields (layout, frames, resolution,
        product, ...); an unknown name is INVALID_ARGUMENT.

        Raises:
            ImpostorError: NOT_FOUND / INVALID_ARGUMENT / PERMISSION_DENIED for
                the model's files (see collect_mesh_files), INVALID_ARGUMENT
                for an unknown layout or product, or an RPC's error (the
                server's INVALID_ARGUMENT naming the field out of range,
                RESOURCE_EXHAUSTED, ...).
        """
        parsed = BakeSettings.from_kwargs(settings)
        parsed.validate()  # settings errors before any upload
        files = collect_mesh_files(model, parsed.follow_symlinks)
        (upload,) = upload_meshes(self._grpc(), [files])
        if isinstance(upload, ImpostorError):
            raise upload
        return self._submit_one(files, parsed, upload)

    def submit_batch(
        self,
        items: Sequence[BatchItem],
        on_submitted: Optional[Callable[[int, BatchSubmission], bool]] = None,
    ) -> List[BatchSubmission]:
        """Submits many bakes: hashes every item's files, uploads each blob the
        server lacks once, then one SubmitBake per item in order. An item whose
        files or settings are bad is not submitted and the others go on.

        Args:
            items: model paths, or (path, {setting: value}) pairs.
            on_submitted: called with each item's index and outcome as soon as
                it is known, in order; returning False stops the batch (the
                rest get CANCELLED "not submitted: the batch stopped").

        Returns:
            One BatchSubmission per item.

        Raises:
            ImpostorError: an RPC's error for the whole batch when
                FindMissingBlobs fails or an upload fails for the caller or
                the connection (an item whose blob the server refused, e.g.
                RESOURCE_EXHAUSTED on a full disk, gets that error alone).
        """
        out: List[BatchSubmission] = [BatchSubmission() for _ in items]
        prepared: List[Optional[Tuple[MeshFiles, BakeSettings]]] = []
        for i, item in enumerate(items):
            path, kwargs = (item[0], dict(item[1])) if isinstance(item, tuple) else (item, {})
            try:
                parsed = BakeSettings.from_kwargs(kwargs)
                parsed.validate()
                prepared.append((collect_mesh_files(path, parsed.follow_symlinks), parsed))
            except ImpostorError as e:
                out[i] = BatchSubmission(error=e)
                prepared.append(None)
        ready = [(i, p) for i, p in enumerate(prepared) if p is not None]
        stats = upload_meshes(self._grpc(), [p[0] for _, p in ready])
        upload_of = {i: s for (i, _), s in zip(ready, stats)}
        stopped = False
        for i, p in enumerate(prepared):
            if stopped:
                out[i] = BatchSubmission(
                    error=ImpostorError(grpc.StatusCode.CANCELLED, "not submitted: the batch stopped")
                )
                continue
            if p is not None:
                upload = upload_of[i]
                if isinstance(upload, ImpostorError):  # the server refused a blob of it
                    out[i] = BatchSubmission(error=upload)
                else:
                    try:
                        out[i] = BatchSubmission(result=self._submit_one(p[0], p[1], upload))
                    except ImpostorError as e:
                        out[i] = BatchSubmission(error=e)
            if on_submitted is not None and not on_submitted(i, out[i]):
                stopped = True
        return out

    # -- following jobs ----------------------------------------------------

    def get_job(self, job_id: str) -> JobUpdate:
        """The job's current state. Raises ImpostorError (NOT_FOUND, ...)."""
        t = self._grpc()
        return _job_update(t.unary("GetJob", t.bake.GetJob, bake_pb.GetJobRequest(job_id=job_id)))

    def cancel(self, job_id: str) -> JobUpdate:
        """Cancels a queued or running job; returns its state afterwards."""
        t = self._grpc()
        return _job_update(t.unary("CancelJob", t.bake.CancelJob, bake_pb.CancelJobRequest(job_id=job_id)))

    def watch(self, job_id: str, progress: Optional[ProgressCallback] = None) -> JobUpdate:
        """Follows a job until it is terminal and returns that state (a failed
        bake is a returned JobUpdate, not an exception). `progress` is called
        on the calling thread for each change, the terminal one included.
        When the stream breaks (a server restart) it resumes with GetJob and a
        new stream for as long as max_outage_seconds allows."""
        last: Optional[JobUpdate] = None

        def emit(update: JobUpdate) -> None:
            nonlocal last
            if last == update:
                return  # a resumed stream repeats the current state
            last = update
            if progress is not None:
                progress(update)

        t = self._grpc()
        retry = t.retry_policy()
        while True:
            got_any = False
            try:
                for job in t.watch_job(bake_pb.WatchJobRequest(job_id=job_id)):
                    got_any = True
                    emit(_job_update(job))
                    if last is not None and last.terminal:
                        return last
                error = ImpostorError(
                    grpc.StatusCode.UNAVAILABLE,
                    f"WatchJob to {t.server}: stream for job {job_id} ended before the job finished",
                    rpc="WatchJob",
                    server=t.server,
                )
            except ImpostorError as e:
                error = e
            if got_any:
                retry.made_progress()
            if not retry.should_retry(error):
                raise error
            # GetJob rides out the rest of an outage itself (the same budget),
            # so its failure is final: the budget is spent or the job is gone.
            emit(self.get_job(job_id))
            if last is not None and last.terminal:
                return last

    # -- results -----------------------------------------------------------

    def _get_result(self, cache_key: str) -> "pb.Manifest":
        """GetResult's answer; the front end it advertises is learned."""
        t = self._grpc()
        manifest: pb.Manifest
        manifest, metadata = t.unary_with_initial_metadata(
            "GetResult", t.assets.GetResult, asset_pb.GetResultRequest(cache_key=cache_key)
        )
        if self._advertised is not None:
            advertised = next((value for key, value in metadata if key == FARM_HTTP_METADATA_KEY), None)
            if advertised is not None:
                self._advertised.learn(advertised)
        return manifest

    def get_manifest(self, cache_key: str) -> Dict[str, Any]:
        """The manifest.json of the result baked under `cache_key`, parsed,
        without downloading its maps. Raises ImpostorError (NOT_FOUND, ...)."""
        manifest = self._get_result(cache_key)
        _check_manifest_files(manifest, self.server, cache_key)
        parsed: Dict[str, Any] = json.loads(download_blob_to_bytes(self._grpc(), manifest.manifest_json))
        return parsed

    def fetch(self, cache_key: str, out_dir: PathLike) -> FetchResult:
        """Downloads the result baked under `cache_key` into `out_dir` (created
        if needed): every file the manifest lists (map images, .glb levels,
        point buffers), then manifest.json last, so a manifest.json on disk
        means its files are complete. Each file is verified against its
        digest into a temporary file beside its name; once all are there
        they are synced and renamed in, and when any fails none is. Files
        already there with the right digest are kept; a manifest.json there
        of another result is removed first.

        With a farm HTTP front end (farm_http) the listing and every file
        come from it and no gRPC connection is made; when it cannot give
        the result, one warning is logged and the whole result comes over
        gRPC (a 404 listing, a farm older than the route: without a
        warning). Without one, the large files come from the front end the
        farm advertises, if any (see Client's farm_http), each over
        ReadBlob when it cannot give it. Local trouble (out_dir, a full
        disk) is raised as it is.

        Raises:
            ImpostorError: NOT_FOUND (nothing baked under the key),
                INVALID_ARGUMENT (malformed key), DATA_LOSS (bytes do not
                match), INTERNAL (a bad manifest or a local disk error).
                When the front end failed too, the message ends with what
                it could not give.
        """
        start = time.monotonic()
        out = Path(out_dir)
        front_end_failure: Optional[FrontEndFailure] = None
        if self._front_end is not None:
            if self._closed:
                raise ImpostorError(grpc.StatusCode.CANCELLED, f"the Client of {self._server} is closed")
            try:
                return self._front_end.fetch(cache_key, out, start)
            except FrontEndFailure as f:
                if f.quiet:
                    # No such result, or a farm older than the listing, or a
                    # key the front end was not asked about: gRPC says.
                    _log.debug('event=farm_http_fetch_not_found key=%s reason="%s"', cache_key[:80], f.message)
                else:
                    _log.warning(
                        'event=farm_http_fetch_fallback key=%s reason="%s" note="fetching the result over gRPC"',
                        cache_key[:80], f.message,
                    )
                    front_end_failure = f
        try:
            return self._fetch_over_grpc(cache_key, out, start)
        except ImpostorError as e:
            if front_end_failure is None:
                raise
            raise ImpostorError(
                e.code,
                f"{e.message} (the farm's HTTP front end could not give the result either: "
                f"{front_end_failure.code.name}: {front_end_failure.message})",
                server_message=e.server_message,
                rpc=e.rpc,
                server=e.server,
                job_id=e.job_id,
                cache_key=e.cache_key,
                reason=e.reason,
            ) from None

    def _fetch_over_grpc(self, cache_key: str, out: Path, start: float) -> FetchResult:
        manifest = self._get_result(cache_key)
        _check_manifest_files(manifest, self.server, cache_key)
        transport = self._grpc()
        advertised = self._advertised

        def from_advertised(name: str, path: Path, digest: "pb.Digest", staging: Staging) -> None:
            # A large file: from the front end the farm advertises while there
            # is one in use (asked per file: one given up half-way leaves the
            # rest to ReadBlob), else, or when it cannot give it, ReadBlob.
            assert advertised is not None
            advertised.stage(cache_key, name, path, digest, staging,
                             lambda staged: download_blob_to_staged(transport, digest, staged))

        stream = from_advertised if advertised is not None else None
        return install_result(
            manifest, out, lambda missing, staging: stage_over_grpc(transport, missing, staging, stream), start
        )

    def lookup(self, model: PathLike, **settings: Any) -> LookupResult:
        """Whether a result for this model at these settings is already baked,
        without uploading or baking (only the files' digests are sent)."""
        parsed = BakeSettings.from_kwargs(settings)
        files = collect_mesh_files(model, parsed.follow_symlinks)
        request = bake_pb.SubmitBakeRequest(mesh=mesh_input(files), parameters=parsed.to_parameters())
        parsed.apply_scheduling(request)
        t = self._grpc()
        response = t.unary("LookupBake", t.bake.LookupBake, request)
        manifest = (
            json_format.MessageToDict(response.result, preserving_proto_field_name=True) if response.found else None
        )
        return LookupResult(cache_key=response.cache_key, found=response.found, manifest=manifest)

    # -- the whole round trip ----------------------------------------------

    def _finish(self, submitted: SubmitResult, out_dir: Optional[PathLike],
                progress: Optional[ProgressCallback]) -> BakeResult:
        job = self.watch(submitted.job_id, progress)
        if job.state != "succeeded":
            raise ImpostorError(
                status_code_from_int(job.error_code) if job.error_code else grpc.StatusCode.UNKNOWN,
                f"bake {job.job_id} {job.state}: {job.error_message}",
                server_message=job.error_message,
                job_id=job.job_id,
                cache_key=job.cache_key,
            )
        target = Path(out_dir) if out_dir is not None else Path(tempfile.mkdtemp(prefix="impostor-"))
        return BakeResult(job.cache_key, job, submitted, self.fetch(job.cache_key, target))

    def bake(
        self,
        model: PathLike,
        out_dir: Optional[PathLike] = None,
        *,
        progress: Optional[ProgressCallback] = None,
        **settings: Any,
    ) -> BakeResult:
        """Submits `model`, follows the job and downloads the result.

        Args:
            model: a .gltf or .glb file.
            out_dir: where the result's files go (created if needed).
                Default: a new temporary folder.
            progress: called with a JobUpdate on each change of the job.
            **settings: BakeSettings fields, e.g. frames=12, resolution=1024.

        Returns:
            BakeResult with cache_key, manifest, quality and the files, each
            verified against the manifest's digests.

        Raises:
            ImpostorError: as submit() and fetch(); and when the bake fails or
                is cancelled, with the job's error code and message (job_id and
                cache_key set; a quality-gate failure is FAILED_PRECONDITION and
                its result can still be fetched).
        """
        return self._finish(self.submit(model, **settings), out_dir, progress)

    def bake_batch(
        self,
        items: Sequence[BatchItem],
        out_dir: PathLike,
        *,
        progress: Optional[Callable[[int, JobUpdate], None]] = None,
    ) -> List[Union[BakeResult, ImpostorError]]:
        """submit_batch(), then follows every job in item order and downloads
        each result into out_dir/<index>_<model stem>. Returns, per item, its
        BakeResult or the ImpostorError that stopped it; `progress` gets the
        item's index and the JobUpdate."""
        submissions = self.submit_batch(items)
        results: List[Union[BakeResult, ImpostorError]] = []
        for i, (item, s) in enumerate(zip(items, submissions)):
            if s.error is not None or s.result is None:
                results.append(s.error or ImpostorError(grpc.StatusCode.UNKNOWN, "not submitted"))
                continue
            path = Path(item[0] if isinstance(item, tuple) else item)
            callback = (lambda u, i=i: progress(i, u)) if progress is not None else None
            try:
                results.append(self._finish(s.result, Path(out_dir) / f"{i}_{path.stem}", callback))
            except ImpostorError as e:
                results.append(e)
        return results
