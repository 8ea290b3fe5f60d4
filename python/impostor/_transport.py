"""The gRPC side of the Client: the channels, their credentials and metadata,
and every RPC with the retry policy applied (the Python twin of
client/transport/transport.cc). The rest of the package never sees a grpc.RpcError.

Several addresses ("host1:port,host2:port", the C++ SDK's --server lists,
common/net/server_list.h) give one channel each, as common/net/failover_channel.h
does: calls stick to the current address while it answers; a call that
fails with UNAVAILABLE (or, with several addresses, DEADLINE_EXCEEDED) moves
every later call on to the next address, and is tried there at once (without backoff) while some address has not failed
since the last answer. Retries, resumed watches and resumed downloads thus
land on a live replica."""
from __future__ import annotations

import dataclasses
import os
import threading
import time
from typing import Any, Callable, Iterator, List, Optional, Sequence, Set, Tuple

import grpc

from ._connect_error import explain_connect_error
from ._retry import ConnectionEvent, ConnectionMonitor, RetryPolicy
from ._tls_peer_check import diagnose_server_certificate
from .errors import ImpostorError, rpc_error
from .v1 import asset_service_pb2_grpc, bake_service_pb2_grpc

# ReadBlob sends at most 1 MiB per message; the margin is for manifests.
_MAX_RECEIVE_BYTES = 64 << 20
# Linux's largest TCP send buffer by default (net.ipv4.tcp_wmem), which a
# loopback connection reaches at once and a real uplink on a deep queue
# approaches: an upload's last bytes may sit there, unseen, until they cross
# (client/transport/transport.cc's kMaxBytesTheLinkHolds).
_MAX_BYTES_THE_LINK_HOLDS = 4 << 20
_MAX_OUTAGE_SECONDS = 86400.0
# The bytes of a BatchUpdateBlobs request that earn its deadline another
# rpc_timeout_seconds: UploadBlob's message size (_blobs.UPLOAD_CHUNK_BYTES,
# as the C++ SDK's Transport::kBatchUpdateMessageBytes).
_BATCH_UPDATE_MESSAGE_BYTES = 64 << 10
# gRPC's default reconnect backoff grows to 120 s, so a server back after a
# restart would go unnoticed for minutes; try every second at most. A private
# subchannel pool: a fresh channel never inherits a dead server's connection.
_CHANNEL_OPTIONS: List[Tuple[str, Any]] = [
    ("grpc.max_receive_message_length", _MAX_RECEIVE_BYTES),
    ("grpc.initial_reconnect_backoff_ms", 200),
    ("grpc.max_reconnect_backoff_ms", 1000),
    ("grpc.min_reconnect_backoff_ms", 1000),
    ("grpc.use_local_subchannel_pool", 1),
]
_MAX_KEEPALIVE_SECONDS = 7200
# How long a refused certificate's diagnosis may take (its own handshakes);
# the C++ SDK allows the same.
_DIAGNOSIS_SECONDS = 2.0


def _reached_server(error: grpc.RpcError) -> bool:
    """Whether a failed call's code can only have come from a server that
    answered (not UNAVAILABLE, DEADLINE_EXCEEDED or CANCELLED, which our own
    side also says)."""
    code = error.code() if isinstance(error, grpc.Call) else None
    return code not in (
        None,
        grpc.StatusCode.UNAVAILABLE,
        grpc.StatusCode.DEADLINE_EXCEEDED,
        grpc.StatusCode.CANCELLED,
    )


def keepalive_options(keepalive_seconds: int) -> List[Tuple[str, Any]]:
    """The C++ SDK's keepalive policy (common/net/keepalive.h): while a call is in
    flight, ping after `keepalive_seconds` of quiet and give the connection up
    when no answer comes within min(keepalive_seconds, 10) s, so a watch over
    a link that died without a reset fails over in seconds. No pings on an
    idle channel; no cap on pings without data (gRPC's default of 2 would stop
    them during a quiet watch)."""
    return [
        ("grpc.keepalive_time_ms", keepalive_seconds * 1000),
        ("grpc.keepalive_timeout_ms", min(keepalive_seconds, 10) * 1000),
        ("grpc.keepalive_permit_without_calls", 0),
        ("grpc.http2.max_pings_without_data", 0),
    ]


def _read_bytes(path: "str | os.PathLike[str]", what: str) -> bytes:
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as e:
        raise ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, f"{what}: cannot read {path}: {e.strerror}") from None


def resolve_token(token: Optional[str], token_file: Optional["str | os.PathLike[str]"]) -> Optional[str]:
    """The bearer token: `token`, else the first line of `token_file`, else
    $IMPOSTOR_TOKEN, else None. INVALID_ARGUMENT for an unreadable or empty file."""
    if token:
        return token.strip()
    if token_file:
        text = _read_bytes(token_file, "token_file").decode("utf-8", "replace").strip()
        if not text:
            raise ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, f"token_file: {token_file} is empty")
        return text.splitlines()[0].strip()
    return os.environ.get("IMPOSTOR_TOKEN") or None


def parse_server_list(server: str) -> List[str]:
    """The addresses of "a:1,b:2" (spaces around entries ignored).
    INVALID_ARGUMENT naming `server` for an empty list or entry."""
    entries = [e.strip() for e in server.split(",")]
    if not server.strip():
        raise ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, "server: required")
    for i, entry in enumerate(entries):
        if not entry:
            raise ImpostorError(
                grpc.StatusCode.INVALID_ARGUMENT,
                f"server: entry {i + 1} of {server!r} is empty; expected host:port[,host:port...]",
            )
    return entries


@dataclasses.dataclass(frozen=True)
class TransportOptions:
    """A Transport's options, as the Client takes them (client.py says what
    each means): checked by check_options."""

    tls_ca: Optional["str | os.PathLike[str]"] = None
    tls_cert: Optional["str | os.PathLike[str]"] = None
    tls_key: Optional["str | os.PathLike[str]"] = None
    rpc_timeout_seconds: float = 30.0
    max_attempts: int = 5
    max_outage_seconds: float = 300.0
    connect_timeout_seconds: float = 10.0
    keepalive_seconds: int = 20


def check_options(server: str, options: TransportOptions, *, read_files: bool = True) -> List[str]:
    """The checks of Transport's options, without connecting: the addresses
    of `server` (parse_server_list), or INVALID_ARGUMENT naming the option
    out of range. `read_files`: also read the TLS files (Transport reads
    them itself), INVALID_ARGUMENT naming the unreadable one. A Client
    with a farm HTTP front end checks its options so before it connects at
    its first gRPC call."""

    def invalid(message: str) -> ImpostorError:
        return ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, message)

    targets = parse_server_list(server or "")
    if not options.rpc_timeout_seconds > 0:
        raise invalid(f"rpc_timeout_seconds: must be > 0, got {options.rpc_timeout_seconds}")
    if not options.connect_timeout_seconds > 0:
        raise invalid(f"connect_timeout_seconds: must be > 0, got {options.connect_timeout_seconds}")
    if options.max_attempts < 1:
        raise invalid(f"max_attempts: must be >= 1, got {options.max_attempts}")
    if isinstance(options.keepalive_seconds, bool) or not isinstance(options.keepalive_seconds, int) or not (
        1 <= options.keepalive_seconds <= _MAX_KEEPALIVE_SECONDS
    ):
        raise invalid(
            f"keepalive_seconds: {options.keepalive_seconds!r} is not a whole number of seconds in 1..{_MAX_KEEPALIVE_SECONDS}"
        )
    if not 0 <= options.max_outage_seconds <= _MAX_OUTAGE_SECONDS:
        raise invalid(f"max_outage_seconds: must be in 0..{_MAX_OUTAGE_SECONDS:g}, got {options.max_outage_seconds}")
    if (options.tls_cert is None) != (options.tls_key is None):
        raise invalid("tls_cert and tls_key: give both (client certificate for mTLS) or neither")
    if read_files:
        for path, what in ((options.tls_ca, "tls_ca"), (options.tls_key, "tls_key"), (options.tls_cert, "tls_cert")):
            if path is not None:
                _read_bytes(path, what)
    return targets


def _health_check(channel: grpc.Channel) -> Any:
    """`channel`'s gRPC health check of the whole server (impostor-server
    serves grpc.health.v1 without a token), raw bytes in and out."""
    return channel.unary_unary(
        "/grpc.health.v1.Health/Check",
        request_serializer=lambda _: b"",  # an empty HealthCheckRequest: the whole server
        response_deserializer=lambda raw: raw,
    )


class _StallWatch:
    """The watchdog of one blob stream (the Python twin of client/transport/transport.cc's
    StallWatch): says when a stream has made no progress for a step's time
    limit, rpc_timeout_seconds unless the step says otherwise. gRPC has no
    deadline per message, and a deadline on the whole call would cut a slow
    link that keeps moving.

    Progress is the stream's to report (progress()); time the caller spends
    on a message it holds is not the link's (pause()). done() ends the watch.
    Thread-safe: the stream's thread reports, another waits (wait()).
    """

    def __init__(self, limit_seconds: float) -> None:
        self._changed = threading.Condition()
        self._limit = limit_seconds
        # When the current step stalls; None while paused. Guarded by _changed.
        self._deadline: Optional[float] = time.monotonic() + limit_seconds
        self._done = False  # guarded by _changed
        self._stalled = False  # guarded by _changed

    @property
    def stalled(self) -> bool:
        """Whether wait() gave up on the stream."""
        with self._changed:
            return self._stalled

    def progress(self, limit_seconds: Optional[float] = None) -> None:
        """The stream moved: the next step may take `limit_seconds` (default:
        the watch's limit)."""
        with self._changed:
            self._deadline = time.monotonic() + (self._limit if limit_seconds is None else limit_seconds)
            self._changed.notify_all()

    def pause(self) -> None:
        """The caller holds the stream (reads a file, writes a message out):
        no limit until the next progress()."""
        with self._changed:
            self._deadline = None

    def done(self) -> None:
        """The call ended (any way): wait() returns False."""
        with self._changed:
            self._done = True
            self._changed.notify_all()

    def wait(self) -> bool:
        """Blocks until done() (False) or until a step outlasts its limit
        (True: the stream stalled)."""
        with self._changed:
            while not self._done:
                if self._deadline is None:
                    self._changed.wait()
                    continue
                left = self._deadline - time.monotonic()
                if left <= 0:
                    self._stalled = True
                    return True
                self._changed.wait(left)
            return False


class _UploadMessages:
    """The request iterator of one UploadBlob stream, which tells its
    _StallWatch of each message the link took. gRPC's sending thread asks
    for a message only once the transport has taken the one before (it is
    in gRPC's outgoing buffer or the kernel's; gRPC's Python API has no
    per-byte progress), and for the one after the last when that was taken.
    Called by that thread; the stream's thread reads the counts once the
    watch gave up or the call ended (their writes happen before)."""

    def __init__(self, messages: Iterator[Any], watch: _StallWatch, rpc_timeout_seconds: float) -> None:
        self._messages = messages
        self._watch = watch
        self._rpc_timeout_seconds = rpc_timeout_seconds
        self._handed_over: Optional[int] = None  # blob bytes of the message gRPC holds, not yet taken
        self.sent = 0  # blob bytes the link has taken
        self.largest_message = 1  # bytes
        self.all_sent = False  # every message was taken; the answer is awaited
        self.messages_held = 0  # when all_sent: the messages the link may still hold
        self.answer_limit = 0.0  # when all_sent: seconds the answer may take

    def __iter__(self) -> "_UploadMessages":
        return self

    def __next__(self) -> Any:
        if self._handed_over is not None:
            self.sent += self._handed_over
            self.largest_message = max(self.largest_message, self._handed_over)
            self._handed_over = None
        self._watch.pause()  # reading the file is not the link's time
        try:
            message = next(self._messages)
        except StopIteration:
            # What the link still holds crosses unseen (the server answers
            # once it has every byte): each message it may hold gets the
            # time any message gets, and the answer once more.
            held = (min(self.sent, _MAX_BYTES_THE_LINK_HOLDS) + self.largest_message - 1) // self.largest_message
            self.messages_held = held
            self.answer_limit = self._rpc_timeout_seconds * (1 + held)
            self.all_sent = True
            self._watch.progress(self.answer_limit)
            raise
        except BaseException:
            self._watch.progress()
            raise
        self._handed_over = len(message.data)
        self._watch.progress()
        return message


class _Route:
    """One address: its channel, stubs and health check."""

    def __init__(self, target: str, channel: grpc.Channel) -> None:
        self.target = target
        self.channel = channel
        self.health = _health_check(channel)
        # The generated stubs are untyped (grpc_python_plugin writes no .pyi).
        self.bake = bake_service_pb2_grpc.BakeServiceStub(channel)  # type: ignore[no-untyped-call]
        self.assets = asset_service_pb2_grpc.AssetServiceStub(channel)  # type: ignore[no-untyped-call]


class _CurrentMethod:
    """One RPC of the current address's stub, looked up when it is called
    (a retry after a failover goes to the new address): called as gRPC's
    multi-callable is, or through its with_call (the answer and its call,
    whose initial_metadata() the server sent)."""

    def __init__(self, transport: "Transport", service: str, method: str) -> None:
        self._transport = transport
        self._service = service
        self._method = method

    def _current(self) -> Any:
        route = self._transport._route_for_call()
        return getattr(getattr(route, self._service), self._method)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self._current()(*args, **kwargs)

    def with_call(self, *args: Any, **kwargs: Any) -> Any:
        return self._current().with_call(*args, **kwargs)


class _CurrentStub:
    """Looks the method up on the current address's stub when it is called,
    so a retry after a failover goes to the new address."""

    def __init__(self, transport: "Transport", service: str) -> None:
        self._transport = transport
        self._service = service

    def __getattr__(self, method: str) -> _CurrentMethod:
        return _CurrentMethod(self._transport, self._service, method)


class Transport:
    """Channels to the server's addresses and its RPCs. Thread-safe (grpc
    stubs are; the current address is guarded by a lock)."""

    def __init__(
        self,
        server: str,
        options: TransportOptions,
        *,
        token: Optional[str],
        client_id: str,
        on_connection_change: Optional[Callable[[ConnectionEvent], None]],
    ) -> None:
        targets = check_options(server, options, read_files=False)
        tls_ca, tls_cert, tls_key = options.tls_ca, options.tls_cert, options.tls_key
        rpc_timeout_seconds, max_attempts = options.rpc_timeout_seconds, options.max_attempts
        max_outage_seconds, keepalive_seconds = options.max_outage_seconds, options.keepalive_seconds
        connect_timeout_seconds = options.connect_timeout_seconds
        self.server = server
        self.rpc_timeout_seconds = rpc_timeout_seconds
        self.max_attempts = max_attempts
        self.max_outage_seconds = max_outage_seconds
        self.monitor = ConnectionMonitor(server, max_outage_seconds, on_connection_change)
        metadata: List[Tuple[str, str]] = []
        if token:
            metadata.append(("authorization", f"Bearer {token}"))
        if client_id:
            metadata.append(("impostor-client-id", client_id[:128]))
        self._metadata: Sequence[Tuple[str, str]] = tuple(metadata)
        credentials: Optional[grpc.ChannelCredentials] = None
        self._uses_tls = tls_ca is not None or tls_cert is not None
        # Kept to explain a refused server certificate (_tls_peer_check).
        self._tls_ca_pem = _read_bytes(tls_ca, "tls_ca") if tls_ca is not None else None
        self._tls_cert = tls_cert
        self._tls_key = tls_key
        if tls_ca is not None or tls_cert is not None:
            credentials = grpc.ssl_channel_credentials(
                root_certificates=self._tls_ca_pem,
                private_key=_read_bytes(tls_key, "tls_key") if tls_key is not None else None,
                certificate_chain=_read_bytes(tls_cert, "tls_cert") if tls_cert is not None else None,
            )
        channel_options = _CHANNEL_OPTIONS + keepalive_options(keepalive_seconds)
        self._routes: List[_Route] = []
        for target in targets:
            channel = (
                grpc.secure_channel(target, credentials, options=channel_options)
                if credentials is not None
                else grpc.insecure_channel(target, options=channel_options)
            )
            self._routes.append(_Route(target, channel))
        self._lock = threading.Lock()
        self._current = 0  # guarded by _lock
        self._failed: Set[int] = set()  # indexes failed since the last answer; guarded by _lock
        self._call_route = threading.local()  # the route this thread's last call went to
        # The first address that answers becomes the current one.
        errors: List[ImpostorError] = []
        for index, route in enumerate(self._routes):
            try:
                self._wait_ready(route.channel, route.target, connect_timeout_seconds)
                self._current = index
                break
            except ImpostorError as e:
                errors.append(e)
            except BaseException:
                self.close()
                raise
        else:
            self.close()
            if len(errors) == 1:
                raise errors[0]
            raise ImpostorError(
                grpc.StatusCode.UNAVAILABLE,
                f"Connect to {server}: no address answered: " + "; ".join(e.server_message for e in errors),
                server_message="no address answered",
                rpc="Connect",
                server=server,
            )
        self.bake: Any = _CurrentStub(self, "bake")
        self.assets: Any = _CurrentStub(self, "assets")

    @property
    def current_target(self) -> str:
        """The address calls go to now."""
        with self._lock:
            return self._routes[self._current].target

    def _route_for_call(self) -> _Route:
        with self._lock:
            index = self._current
        self._call_route.index = index
        return self._routes[index]

    def _fail_over(self) -> bool:
        """The calling thread's last call failed with UNAVAILABLE: moves calls
        on to the next address (unless another call already has). True when
        the address calls go to now has not failed since the last answer, so
        the caller may try again at once."""
        index = getattr(self._call_route, "index", None)
        with self._lock:
            if len(self._routes) == 1:
                return False
            if index is not None:
                self._failed.add(index)
                if index == self._current:
                    self._current = (self._current + 1) % len(self._routes)
            return self._current not in self._failed

    def close(self) -> None:
        for route in self._routes:
            route.channel.close()

    def _wait_ready(self, channel: grpc.Channel, target: str, timeout: float) -> None:
        """Returns once the server at `target` answers. Gives up a second after
        the first failed connection attempt (a script should hear "nobody
        there" at once, not after the whole timeout); a server that accepts
        but does not answer gets the whole timeout.

        Asks with gRPC health checks rather than channel.subscribe: a
        subscribed channel that is never closed hangs the interpreter at exit
        (grpc's connectivity thread), and a failed call carries gRPC's reason,
        which says which failure it is."""
        check = _health_check(channel)
        deadline = time.monotonic() + timeout
        failed_at: Optional[float] = None
        last = ""
        while True:
            limit = deadline if failed_at is None else min(deadline, failed_at + 1.0)
            remaining = limit - time.monotonic()
            if remaining <= 0:
                break
            try:
                # After a failure, wait for the channel's next attempt (a
                # server that is just starting); before it, fail fast.
                check(b"", timeout=remaining, wait_for_ready=failed_at is not None)
                self.monitor.note_answer()
                return
            except grpc.RpcError as e:
                code = e.code() if hasattr(e, "code") else None
                if code not in (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED):
                    # The server answered (UNIMPLEMENTED, UNAUTHENTICATED, ...).
                    self.monitor.note_answer()
                    return
                if code == grpc.StatusCode.UNAVAILABLE:
                    last = e.details() or ""
                    if failed_at is None:
                        failed_at = time.monotonic()
        if last:
            why, _ = explain_connect_error(last, self._uses_tls, lambda: self._diagnose_certificate(target))
        else:
            why = f"no impostor server answered within {timeout:g} s"
        raise ImpostorError(
            grpc.StatusCode.UNAVAILABLE,
            f"Connect to {target}: {why}",
            server_message=why,
            rpc="Connect",
            server=target,
        )

    def _diagnose_certificate(self, target: str) -> str:
        """Why `target`'s certificate was refused, or "" (no tls_ca: gRPC's
        default roots are not ones this check can trust the same way)."""
        if self._tls_ca_pem is None:
            return ""
        return diagnose_server_certificate(
            target, self._tls_ca_pem, self._tls_cert, self._tls_key, _DIAGNOSIS_SECONDS
        )

    def note(self, error: grpc.RpcError, rpc: str) -> ImpostorError:
        """The ImpostorError of a failed call, noted by the connection monitor."""
        index = getattr(self._call_route, "index", self._current)
        converted = rpc_error(error, rpc, self._routes[index].target)
        if converted.code == grpc.StatusCode.UNAVAILABLE:
            self.monitor.note_failure(converted)
            converted.failover_now = self._fail_over()
        elif converted.code == grpc.StatusCode.DEADLINE_EXCEEDED and len(self._routes) > 1:
            # A replica that accepts connections but never answers (hung,
            # stopped, its host overloaded) says nothing else; with several
            # addresses the next one gets the retry (the C++ SDK does the
            # same, common/net/failover_channel.h). Not an outage: the server
            # may be fine and the call merely slow.
            converted.failover_now = self._fail_over()
        elif converted.code not in (grpc.StatusCode.DEADLINE_EXCEEDED, grpc.StatusCode.CANCELLED):
            # Said by the server (our own side says deadlines and cancels).
            self.note_answer()
        return converted

    def note_answer(self) -> None:
        """A server answered: every address counts as untried again."""
        with self._lock:
            self._failed.clear()
        self.monitor.note_answer()

    def wait_for_server(self, at_most: float) -> None:
        """A RetryPolicy's backoff: waits at most `at_most` seconds for the
        channel of the address calls go to now, returning as soon as it
        connects and the server answers (the C++ SDK's
        Transport::WaitForServer). Nothing else makes a channel in
        TRANSIENT_FAILURE try again while every call sleeps in its backoff
        (gRPC's backup poller runs every 5 s), so a server restarted after a
        SIGKILL went unnoticed for about 4 s after it listened.

        First a health check that fails fast: answered, the channel is
        connected (a live server answered UNAVAILABLE, or a call ran past its
        deadline), and the whole backoff is waited. Refused without an
        answer, the channel is not connected: a health check with
        wait_for_ready then drives its reconnection and returns once the
        server answers. (A channel left idle by a dropped connection is
        connected by the first check; a server back by then is taken for a
        live one: one whole backoff, at most a second.) Health checks rather
        than channel.subscribe (see _wait_ready). The checks are not noted as
        answers: the retried call's own outcome says whether the outage is
        over (a healthy server may still answer it UNAVAILABLE)."""
        deadline = time.monotonic() + at_most
        with self._lock:
            health = self._routes[self._current].health
        try:
            try:
                health(b"", timeout=at_most, wait_for_ready=False)
                connected = True
            except grpc.RpcError as e:
                # UNAVAILABLE: not connected (or a live server said so: it
                # says so again below); DEADLINE_EXCEEDED: the backoff is over.
                connected = _reached_server(e)
            left = deadline - time.monotonic()
            if not connected and left > 0:
                try:
                    health(b"", timeout=left, wait_for_ready=True)
                    return  # connected again, and the server answers: retry now
                except grpc.RpcError as e:
                    if _reached_server(e):
                        return  # it answers (UNAUTHENTICATED, ...): retry now
                    # DEADLINE_EXCEEDED: not back within the backoff.
                    # UNAVAILABLE: a live server said so, or the new
                    # connection broke at once: the rest of the backoff.
        except ValueError:
            return  # the Client was closed ("Cannot invoke RPC on closed channel!"): the retry says so
        remaining = deadline - time.monotonic()
        if remaining > 0:
            time.sleep(remaining)

    def retry_policy(self) -> RetryPolicy:
        """One call's RetryPolicy, waiting its backoffs with wait_for_server."""
        return RetryPolicy(self.max_attempts, self.max_outage_seconds, self.monitor, self.wait_for_server)

    def unary(self, rpc: str, method: Callable[..., Any], request: Any, timeout: Optional[float] = None) -> Any:
        """Calls a unary RPC, retried as RetryPolicy decides; each attempt's
        deadline is `timeout` seconds (None: rpc_timeout_seconds)."""
        return self._retried(rpc, lambda seconds: method(request, timeout=seconds, metadata=self._metadata), timeout)

    def unary_with_initial_metadata(
        self, rpc: str, method: Any, request: Any, timeout: Optional[float] = None
    ) -> Tuple[Any, List[Tuple[str, str]]]:
        """unary(), and the initial metadata the server sent with the answer
        of the attempt that succeeded: (key, value) pairs in order, the
        text ones only (a "-bin" key's bytes are left out). `method` is a
        stub's method (self.assets.GetResult): its with_call is used."""
        response, call = self._retried(
            rpc, lambda seconds: method.with_call(request, timeout=seconds, metadata=self._metadata), timeout
        )
        metadata = [(str(key), value) for key, value in (call.initial_metadata() or ()) if isinstance(value, str)]
        return response, metadata

    def _retried(self, rpc: str, attempt: Callable[[float], Any], timeout: Optional[float]) -> Any:
        """attempt(deadline seconds) until it answers, retried as RetryPolicy
        decides: unary()'s loop."""
        retry = self.retry_policy()
        while True:
            try:
                response = attempt(timeout or self.rpc_timeout_seconds)
            except grpc.RpcError as e:
                error = self.note(e, rpc)
                if not retry.should_retry(error):
                    raise error from None
                continue
            self.note_answer()
            return response

    def batch_update_blobs(self, request: Any) -> Any:
        """One AssetService.BatchUpdateBlobs call of `request`, retried as
        the other unary calls; its deadline is rpc_timeout_seconds for each
        64 KiB of its data and once more (the time UploadBlob's stall
        watchdog gives those bytes), so a slow uplink is not cut for being
        slow. Raises ImpostorError: UNIMPLEMENTED from a server older than
        the call; the call's error."""
        data = sum(len(r.data) for r in request.requests)
        messages = (data + _BATCH_UPDATE_MESSAGE_BYTES - 1) // _BATCH_UPDATE_MESSAGE_BYTES
        return self.unary("BatchUpdateBlobs", self.assets.BatchUpdateBlobs, request,
                          timeout=self.rpc_timeout_seconds * (1 + messages))

    def watch_job(self, request: Any) -> Iterator[Any]:
        """One WatchJob stream (no deadline: a bake may take long). Raises
        ImpostorError when it breaks; the caller resumes."""
        try:
            for job in self.bake.WatchJob(request, metadata=self._metadata):
                self.note_answer()
                yield job
        except grpc.RpcError as e:
            raise self.note(e, "WatchJob") from None

    def _note_stall(self, rpc: str, why: str) -> ImpostorError:
        """DEADLINE_EXCEEDED "the link stalled: <why>" for the calling
        thread's last call, which the stall watchdog cancelled; told to the
        failover as note() tells a DEADLINE_EXCEEDED (nothing for the
        connection monitor: no answer came)."""
        index = getattr(self._call_route, "index", self._current)
        target = self._routes[index].target
        details = f"the link stalled: {why}"
        error = ImpostorError(
            grpc.StatusCode.DEADLINE_EXCEEDED, f"{rpc} to {target}: {details}",
            server_message=details, rpc=rpc, server=target,
        )
        if len(self._routes) > 1:
            error.failover_now = self._fail_over()
        return error

    def read_blob(self, request: Any, remaining_bytes: int) -> Iterator[Any]:
        """One ReadBlob stream, not retried (the caller resumes at its offset).

        No deadline on the whole stream: it goes on however slow the link,
        and is cancelled only when no message arrives for
        rpc_timeout_seconds (DEADLINE_EXCEEDED "the link stalled", naming
        the seconds and the bytes this stream brought). The time the caller
        holds a message is not counted. Another thread (one per stream)
        watches; closing the generator or the Client ends the call."""
        route = self._route_for_call()
        watch = _StallWatch(self.rpc_timeout_seconds)
        call = route.assets.ReadBlob(request, metadata=self._metadata)
        call.add_done_callback(lambda _: watch.done())

        def watchdog() -> None:
            if watch.wait():
                call.cancel()

        watcher = threading.Thread(target=watchdog, name="impostor-readblob-watch", daemon=True)
        watcher.start()
        received = 0
        try:
            for chunk in call:
                watch.pause()
                received += len(chunk.data)
                self.note_answer()
                yield chunk
                watch.progress()
        except grpc.RpcError as e:
            code = e.code() if isinstance(e, grpc.Call) else None
            if watch.stalled and code in (grpc.StatusCode.CANCELLED, grpc.StatusCode.DEADLINE_EXCEEDED):
                after = f", after {received} bytes of this stream" if received else ""
                raise self._note_stall(
                    "ReadBlob",
                    f"no bytes arrived for {self.rpc_timeout_seconds:g} s (rpc_timeout_seconds){after}",
                ) from None
            raise self.note(e, "ReadBlob") from None
        finally:
            call.cancel()  # a no-op once the call ended; else the caller stopped early
            watch.done()
            watcher.join()

    def upload_blob(self, requests: Iterator[Any], size_bytes: int) -> Any:
        """One UploadBlob stream of `requests` (the blob's messages, the
        first with its digest and offset), not retried (the caller resumes
        it: QueryUpload says from where).

        No deadline on the whole stream: it goes on however slow the link.
        It is cancelled when the link takes no message for
        rpc_timeout_seconds, or when, after the last message, the server's
        answer does not come within rpc_timeout_seconds per message the link
        may still hold (up to 4 MiB of them), plus once: DEADLINE_EXCEEDED
        "the link stalled", naming the seconds and the bytes sent, as the
        C++ SDK's Transport::UploadBlob. Closing the Client (or an exception
        such as KeyboardInterrupt in the waiting thread) ends the call at
        once: CANCELLED."""
        route = self._route_for_call()
        watch = _StallWatch(self.rpc_timeout_seconds)
        messages = _UploadMessages(requests, watch, self.rpc_timeout_seconds)
        call = route.assets.UploadBlob.future(messages, metadata=self._metadata)
        call.add_done_callback(lambda _: watch.done())
        try:
            stalled = watch.wait()
        except BaseException:
            call.cancel()
            raise
        if stalled and call.cancel():
            if messages.all_sent:
                why = (
                    f"no answer for {messages.answer_limit:g} s (rpc_timeout_seconds, "
                    f"{self.rpc_timeout_seconds:g} s, times the {messages.messages_held} message(s) the link "
                    f"may have held, plus one) after all {messages.sent} bytes of the blob were sent"
                )
            else:
                why = (
                    f"it took nothing for {self.rpc_timeout_seconds:g} s (rpc_timeout_seconds), with "
                    f"{messages.sent} of the blob's {size_bytes} bytes sent"
                )
            raise self._note_stall("UploadBlob", why)
        try:
            response = call.result()
        except grpc.RpcError as e:
            raise self.note(e, "UploadBlob") from None
        self.note_answer()
        return response
