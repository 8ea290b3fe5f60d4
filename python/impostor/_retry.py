"""Retries and outage handling, the same policy as the C++ SDK (client/transport/retry.cc,
client/transport/connection_monitor.h).

A call that failed with UNAVAILABLE on one of several addresses is tried at
once on the next one while some address has not failed since the last answer
(_transport.py). Otherwise a call is retried when it fails with UNAVAILABLE or DEADLINE_EXCEEDED after a
capped exponential backoff (100 ms, 200 ms, ... 1 s, minus up to 20% jitter),
up to ``max_attempts`` tries; while the server that answered once stays away
(UNAVAILABLE), calls keep retrying until the outage, counted from the first
failure after the last answer, has lasted ``max_outage_seconds``.

The backoff is waited out with the transport's wait_for_server, which ends
it as soon as the channel connects again (a restarted server), like the C++
SDK's Transport::WaitForServer; a server that answers UNAVAILABLE over a
live connection still gets the whole backoff.
"""
from __future__ import annotations

import dataclasses
import random
import threading
import time
from typing import Callable, Optional

import grpc

from .errors import ImpostorError

_RETRYABLE = (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED)
_INITIAL_BACKOFF_S = 0.1
_MAX_BACKOFF_S = 1.0


def backoff_delay(attempt: int) -> float:
    """Seconds to wait after the `attempt`-th failure in a row (1-based)."""
    delay = min(_INITIAL_BACKOFF_S * 2.0 ** max(0, attempt - 1), _MAX_BACKOFF_S)
    return delay - random.uniform(0, delay / 5)


@dataclasses.dataclass(frozen=True)
class ConnectionEvent:
    """A change in whether the server answers (Client's on_connection_change).

    kind: "lost" (a call failed with UNAVAILABLE after the server had
        answered; calls retry for up to max_outage_seconds from now) or
        "regained" (the server answered again).
    error: for "lost", the error that showed the outage.
    outage_seconds: for "regained", how long the server was gone.
    """

    kind: str
    server: str
    error: Optional[ImpostorError] = None
    outage_seconds: float = 0.0
    max_outage_seconds: float = 0.0


class ConnectionMonitor:
    """When the current outage began, and the lost/regained events.

    Thread-safe; the callback runs on the noting thread, serialised with
    itself, once per transition however many calls notice.
    """

    def __init__(
        self,
        server: str,
        max_outage_seconds: float,
        on_change: Optional[Callable[[ConnectionEvent], None]],
    ) -> None:
        self._server = server
        self._max_outage_seconds = max_outage_seconds
        self._on_change = on_change
        self._report_lock = threading.Lock()  # taken before _lock
        self._lock = threading.Lock()
        self._outage_start: Optional[float] = None  # guarded by _lock

    def note_answer(self) -> None:
        """The server answered (any code but UNAVAILABLE, or a stream message)."""
        with self._report_lock:
            with self._lock:
                start, self._outage_start = self._outage_start, None
            if start is not None and self._on_change is not None:
                self._on_change(
                    ConnectionEvent(
                        "regained",
                        self._server,
                        outage_seconds=time.monotonic() - start,
                        max_outage_seconds=self._max_outage_seconds,
                    )
                )

    def note_failure(self, error: ImpostorError) -> None:
        """A call failed; UNAVAILABLE begins an outage unless one is under way."""
        if error.code != grpc.StatusCode.UNAVAILABLE:
            return
        with self._report_lock:
            with self._lock:
                began = self._outage_start is None
                if began:
                    self._outage_start = time.monotonic()
            if began and self._on_change is not None:
                self._on_change(
                    ConnectionEvent(
                        "lost", self._server, error=error, max_outage_seconds=self._max_outage_seconds
                    )
                )

    def outage_seconds(self) -> Optional[float]:
        """Seconds since the current outage began; None while the server answers."""
        with self._lock:
            return None if self._outage_start is None else time.monotonic() - self._outage_start


class RetryPolicy:
    """Decides, for one logical call, whether a failed attempt is tried again.

    `wait(seconds)` waits out a backoff: it returns after at most `seconds`,
    and may return sooner when the server is back (Transport.wait_for_server).
    Default: time.sleep.

    Not thread-safe: one per call.
    """

    def __init__(
        self,
        max_attempts: int,
        max_outage_seconds: float,
        monitor: ConnectionMonitor,
        wait: Optional[Callable[[float], None]] = None,
    ) -> None:
        self._max_attempts = max_attempts
        self._max_outage_seconds = max_outage_seconds
        self._monitor = monitor
        self._wait: Callable[[float], None] = wait if wait is not None else time.sleep
        self.failures = 0

    def made_progress(self) -> None:
        """Bytes or news arrived: the count of failures in a row starts over."""
        self.failures = 0

    def should_retry(self, error: ImpostorError) -> bool:
        """True (after waiting the backoff out, or until the server is back if
        that is sooner) when the call should be tried again."""
        if error.code not in _RETRYABLE:
            return False
        if error.failover_now:
            return True  # another address, untried since the last answer: no backoff
        self.failures += 1
        delay = backoff_delay(self.failures)
        retry = self.failures < self._max_attempts
        if error.code == grpc.StatusCode.UNAVAILABLE and self._max_outage_seconds > 0:
            outage = self._monitor.outage_seconds()
            if outage is not None and outage < self._max_outage_seconds:
                retry = True
                # The last try comes when the budget ends, not up to a second later.
                delay = min(delay, self._max_outage_seconds - outage)
        if retry:
            self._wait(delay)
        return retry
