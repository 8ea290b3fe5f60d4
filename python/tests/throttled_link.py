"""A loopback TCP proxy for tests of slow and stopped links (the Python twin
of tests/client/throttled_link.h): each way carries at most a set number of
bytes per second, and the link can be stopped altogether.

Each way takes what its sender writes at once and queues it, as a deep
router queue does, so a client's kernel hands over a blob's first MiBs
before their first byte reaches the server: the worst case of a real
uplink, where the sender cannot see its bytes cross. (Reading only at the
pace instead closes loopback TCP's window for seconds at a time at such
rates, and a kernel with TCP_USER_TIMEOUT set, as gRPC's keepalive sets it,
then aborts the connection, which no real link does.)

A stopped link (stop(), or stop_after_upload_bytes()) reads and forwards
nothing either way, as a cut cable that sends no reset: the senders' kernels
fill their buffers and take no more.

Both ways are read as HTTP/2 (plaintext gRPC), so a test can count the
streams that carried a blob (upload_streams, download_streams) without a
hook in the client or server.

Thread-safety: every method may be called from any thread. Each connection
has four threads (a receiver and a sender each way); close() ends them.
"""
from __future__ import annotations

import collections
import functools
import socket
import struct
import threading
import time
from typing import Callable, Deque, Dict, List, Optional

_HTTP2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"
_HTTP2_DATA = 0x0
_HTTP2_PADDED = 0x8
_READ_BYTES = 64 * 1024
# The pacing slice: at N bytes/s the link sends at most N/_SLICES_PER_SECOND
# bytes at a time, so the bytes cross evenly, not in bursts.
_SLICES_PER_SECOND = 20


class _Http2Frames:
    """Counts the DATA bytes per stream of one side of an HTTP/2 connection
    (the client's begins with the preface), fed in arbitrary pieces. One
    thread at a time."""

    def __init__(self, on_data: Callable[[int, int], None], *, preface: bool) -> None:
        self._buffer = b""
        self._preface_left = len(_HTTP2_PREFACE) if preface else 0
        self._on_data = on_data

    def feed(self, data: bytes) -> None:
        self._buffer += data
        if self._preface_left:
            skipped = min(self._preface_left, len(self._buffer))
            self._buffer = self._buffer[skipped:]
            self._preface_left -= skipped
        while len(self._buffer) >= 9:
            length = int.from_bytes(self._buffer[0:3], "big")
            if len(self._buffer) < 9 + length:
                return
            kind, flags = self._buffer[3], self._buffer[4]
            stream = struct.unpack(">I", self._buffer[5:9])[0] & 0x7FFFFFFF
            if kind == _HTTP2_DATA:
                padding = self._buffer[9] + 1 if flags & _HTTP2_PADDED and length else 0
                self._on_data(stream, length - padding)
            self._buffer = self._buffer[9 + length:]


class _Way:
    """One direction of one connection: receives into a queue at once,
    sends from it at most `bytes_per_second` (None: as fast as it goes)."""

    def __init__(self, link: "ThrottledLink", source: socket.socket, sink: socket.socket,
                 bytes_per_second: Optional[int], received: _Http2Frames, forwarded: _Http2Frames,
                 to_server: bool) -> None:
        self._link = link
        self.to_server = to_server
        self._source = source
        self._sink = sink
        self._rate = bytes_per_second
        self._received = received  # fed by the receiver, with link._changed held
        self._forwarded = forwarded  # fed by the sender
        self._queue: Deque[bytes] = collections.deque()  # guarded by link._changed
        self._ended = False  # guarded by link._changed: the source closed
        self.threads = [threading.Thread(target=self._receive, daemon=True),
                        threading.Thread(target=self._send, daemon=True)]
        for t in self.threads:
            t.start()

    def _receive(self) -> None:
        changed = self._link._changed
        try:
            while True:
                with changed:
                    changed.wait_for(lambda: not self._link._stopped or self._link._closing)
                    if self._link._closing:
                        return
                data = self._source.recv(_READ_BYTES)
                with changed:
                    if not data:
                        self._ended = True
                        changed.notify_all()
                        return
                    self._queue.append(data)
                    self._received.feed(data)
                    changed.notify_all()
        except OSError:
            with changed:
                self._ended = True
                changed.notify_all()

    def _send(self) -> None:
        changed = self._link._changed
        slice_bytes = max(1, self._rate // _SLICES_PER_SECOND) if self._rate else _READ_BYTES
        next_slice_at = time.monotonic()
        try:
            while True:
                with changed:
                    changed.wait_for(lambda: self._link._closing or (
                        not self._link._stopped and (self._queue or self._ended)))
                    if self._link._closing or (not self._queue and self._ended):
                        break
                    data = self._queue.popleft()
                    if len(data) > slice_bytes:
                        self._queue.appendleft(data[slice_bytes:])
                        data = data[:slice_bytes]
                    if self._rate:
                        # Pacing is what this link is for: the one place a
                        # test's time is the subject, not a wait for an event.
                        while not self._link._closing:
                            left = next_slice_at - time.monotonic()
                            if left <= 0:
                                break
                            changed.wait(left)
                        if self._link._closing:
                            break
                        next_slice_at = max(next_slice_at, time.monotonic() - 1) + len(data) / self._rate
                self._sink.sendall(data)
                self._link._count(self, len(data))
                self._forwarded.feed(data)
        except OSError:
            pass
        try:
            self._sink.shutdown(socket.SHUT_WR)
        except OSError:
            pass


class ThrottledLink:
    """Listens on 127.0.0.1:<kernel's choice> and forwards each connection to
    `upstream` ("127.0.0.1:PORT"): at most `up_bytes_per_second` towards the
    server and `down_bytes_per_second` back (None: unlimited)."""

    def __init__(self, upstream: str, *, up_bytes_per_second: Optional[int] = None,
                 down_bytes_per_second: Optional[int] = None) -> None:
        host, port = upstream.rsplit(":", 1)
        self._upstream = (host, int(port))
        self._up_rate = up_bytes_per_second
        self._down_rate = down_bytes_per_second
        self._changed = threading.Condition()
        self._stopped = False  # guarded by _changed
        self._closing = False  # guarded by _changed
        # Per way (True: towards the server), guarded by _changed: stop() once
        # this much stream data was forwarded; DATA bytes its sender sent per
        # stream, keyed (connection << 32) | stream id; DATA bytes forwarded.
        self._stop_after: Dict[bool, Optional[int]] = {True: None, False: None}
        self._data_by_stream: Dict[bool, Dict[int, int]] = {True: {}, False: {}}
        self._data_forwarded: Dict[bool, int] = {True: 0, False: 0}
        self._connections = 0  # guarded by _changed
        self._bytes_to_server = 0  # guarded by _changed
        self._sockets: List[socket.socket] = []  # guarded by _changed
        self._ways: List[_Way] = []  # guarded by _changed
        self.stopped_event = threading.Event()
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.address = f"127.0.0.1:{self._listener.getsockname()[1]}"
        self._acceptor = threading.Thread(target=self._accept, daemon=True)
        self._acceptor.start()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            try:
                server = socket.create_connection(self._upstream)
            except OSError:
                client.close()
                continue
            for s in (client, server):
                s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._changed:
                if self._closing:
                    client.close()
                    server.close()
                    return
                self._connections += 1
                connection = self._connections
                self._sockets += [client, server]

                def on_received(to_server: bool, stream: int, size: int, connection: int = connection) -> None:
                    # Called by a receiver with _changed held.
                    key = (connection << 32) | stream
                    counts = self._data_by_stream[to_server]
                    counts[key] = counts.get(key, 0) + size

                def on_forwarded(to_server: bool, stream: int, size: int) -> None:
                    with self._changed:  # called by a sender
                        self._data_forwarded[to_server] += size
                        limit = self._stop_after[to_server]
                        if limit is not None and self._data_forwarded[to_server] >= limit:
                            self._stop_locked()

                for to_server, source, sink, rate in ((True, client, server, self._up_rate),
                                                      (False, server, client, self._down_rate)):
                    received = _Http2Frames(functools.partial(on_received, to_server), preface=to_server)
                    forwarded = _Http2Frames(functools.partial(on_forwarded, to_server), preface=to_server)
                    self._ways.append(_Way(self, source, sink, rate, received, forwarded, to_server=to_server))

    def _count(self, way: _Way, size: int) -> None:
        with self._changed:
            if way.to_server:
                self._bytes_to_server += size

    def _stop_locked(self) -> None:
        self._stopped = True
        self.stopped_event.set()
        self._changed.notify_all()

    def stop(self) -> None:
        """From now on nothing is read or forwarded, either way."""
        with self._changed:
            self._stop_locked()

    def stop_after_upload_bytes(self, size: int) -> None:
        """stop() once `size` bytes of the clients' stream data (HTTP/2
        DATA) have crossed towards the server: a link that dies mid-upload."""
        with self._changed:
            self._stop_after[True] = size

    def stop_after_download_bytes(self, size: int) -> None:
        """stop() once `size` bytes of the server's stream data have crossed
        to the clients: a link that dies mid-download."""
        with self._changed:
            self._stop_after[False] = size

    @property
    def connections(self) -> int:
        """Connections accepted so far."""
        with self._changed:
            return self._connections

    @property
    def bytes_to_server(self) -> int:
        """Bytes forwarded towards the server so far, all connections."""
        with self._changed:
            return self._bytes_to_server

    def upload_streams(self, at_least: int) -> List[int]:
        """The DATA bytes the clients sent on each HTTP/2 stream on which
        they sent at least `at_least`, in the order the streams began."""
        with self._changed:
            return [n for _, n in sorted(self._data_by_stream[True].items()) if n >= at_least]

    def download_streams(self, at_least: int) -> List[int]:
        """The same for the DATA bytes the server sent."""
        with self._changed:
            return [n for _, n in sorted(self._data_by_stream[False].items()) if n >= at_least]

    def close(self) -> None:
        """Cuts every connection and ends every thread."""
        with self._changed:
            self._closing = True
            self._changed.notify_all()
            sockets, ways = list(self._sockets), list(self._ways)
        try:
            self._listener.shutdown(socket.SHUT_RDWR)  # wakes accept() (Linux); close() alone does not
        except OSError:
            pass
        self._listener.close()
        for s in sockets:
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            s.close()
        self._acceptor.join()
        for way in ways:
            for t in way.threads:
                t.join()

    def __enter__(self) -> "ThrottledLink":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
