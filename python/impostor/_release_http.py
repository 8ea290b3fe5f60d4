"""HTTP(S) reads from one mirror, for impostor.release: a small mutable file
(the channel file, revalidated with If-None-Match) and a file by digest,
verified while it streams and resumed with a Range request after a cut.
The farm's HTTP front end is read with the same reader (_farm_http: a
result's listing with get_whole, its files with read_verified).
"""
from __future__ import annotations

import hashlib
import http.client
import json
import re
import socket
import urllib.error
import urllib.parse
import urllib.request
from typing import IO, Any, Dict, Optional, Protocol, Tuple

import grpc

from ._release_catalog import _Failure, _invalid

_CHUNK_BYTES = 64 << 10
_USER_AGENT = "impostor-python (release client)"

# The most bytes of an error answer's body read for the server's message.
_MAX_ERROR_BODY_BYTES = 64 << 10

_CONTENT_RANGE = re.compile(r"\s*bytes\s+(\d+)-(\d+)/(\d+|\*)\s*\Z")

_Code = grpc.StatusCode


# ---------------------------------------------------------------------------
# Redirects and responses


def _origin(url: str) -> Tuple[str, str, Optional[int]]:
    parts = urllib.parse.urlsplit(url)
    try:
        port = parts.port
    except ValueError:
        port = None
    return parts.scheme.lower(), (parts.hostname or "").lower(), port


class _Redirects(urllib.request.HTTPRedirectHandler):
    """Follows redirects to http(s) only (urllib would also follow ftp), and
    sends no Authorization header to another origin than the one it was
    meant for (urllib would: a farm token must not reach a host a redirect
    names, as curl does not send it either)."""

    def redirect_request(
        self,
        req: urllib.request.Request,
        fp: IO[bytes],
        code: int,
        msg: str,
        headers: http.client.HTTPMessage,
        newurl: str,
    ) -> Optional[urllib.request.Request]:
        if urllib.parse.urlsplit(newurl).scheme not in ("http", "https"):
            raise urllib.error.HTTPError(newurl, code, f"{msg}: redirect to a non-HTTP URL", headers, fp)
        new = super().redirect_request(req, fp, code, msg, headers, newurl)
        if new is not None and _origin(newurl) != _origin(req.full_url):
            for name in list(new.headers):
                if name.lower() == "authorization":
                    del new.headers[name]
        return new


class _Sink(Protocol):
    """Where read_verified puts the bytes: a file opened for writing, or
    _result_install.StagedFile."""

    def seek(self, offset: int, whence: int = 0) -> int: ...

    def truncate(self, size: Optional[int] = None) -> int: ...

    def write(self, data: bytes) -> int: ...


def _server_message(error: urllib.error.HTTPError) -> str:
    """The farm's own words in an error answer ({"error": {"message": ...}},
    docs/http_api.md), or "" for a body that is not its JSON (a proxy's
    page)."""
    try:
        body = error.read(_MAX_ERROR_BODY_BYTES)
        parsed = json.loads(body)
    except Exception:  # any body at all: a page, bytes, a cut answer
        return ""
    inner = parsed.get("error") if isinstance(parsed, dict) else None
    message = inner.get("message") if isinstance(inner, dict) else None
    return message[:500] if isinstance(message, str) else ""


def _range_start(value: Optional[str]) -> Optional[int]:
    m = _CONTENT_RANGE.match(value or "")
    return int(m.group(1)) if m else None


def _read_some(response: Any) -> bytes:
    read1 = getattr(response, "read1", None)
    data = read1(_CHUNK_BYTES) if read1 is not None else response.read(_CHUNK_BYTES)
    return bytes(data)


def _read_body(response: Any, limit: int, too_long: _Failure) -> Tuple[bytes, Optional[int]]:
    """A small answer's whole body, raising `too_long` past `limit` bytes,
    and the Content-Length it announced when the body ended short of it
    (else None)."""
    data = bytearray()
    while True:
        chunk = _read_some(response)
        if not chunk:
            break
        data += chunk
        if len(data) > limit:
            raise too_long
    announced = response.headers.get("Content-Length")
    if announced is not None and announced.strip().isdigit() and int(announced) != len(data):
        return bytes(data), int(announced)
    return bytes(data), None


def _is_cut(error: BaseException) -> bool:
    """A connection that broke after it was made (worth resuming on the
    same mirror), as opposed to one refused or never made."""
    return isinstance(
        error, (ConnectionResetError, ConnectionAbortedError, BrokenPipeError, http.client.HTTPException)
    )


class _MirrorReader:
    """Reads release files over HTTP(S) with one urllib opener: a mirror that
    sends no byte for `timeout` seconds has stalled, and `max_attempts`
    transfers in a row that bring nothing give up on it. `headers` go with
    every request (the farm's "Authorization: Bearer TOKEN"). Keeps nothing
    between calls: several threads may read through one at once.
    """

    def __init__(
        self,
        opener: urllib.request.OpenerDirector,
        timeout: float,
        max_attempts: int,
        *,
        headers: Optional[Dict[str, str]] = None,
        user_agent: str = _USER_AGENT,
    ) -> None:
        self._opener = opener
        self._timeout = timeout
        self._max_attempts = max_attempts
        self._headers = {"User-Agent": user_agent, "Accept-Encoding": "identity", **(headers or {})}

    def _open(self, url: str, headers: Dict[str, str]) -> Any:
        request = urllib.request.Request(url, headers={**self._headers, **headers})
        return self._opener.open(request, timeout=self._timeout)

    def _connect_failure(self, url: str, error: urllib.error.URLError) -> _Failure:
        reason = error.reason
        if isinstance(reason, socket.timeout):
            return _Failure(_Code.DEADLINE_EXCEEDED, f"{url}: no answer for {self._timeout:g} s (stalled)")
        return _Failure(_Code.UNAVAILABLE, f"{url}: {reason}")

    def get_small(self, url: str, limit: int, etag: Optional[str]) -> Optional[Tuple[bytes, Optional[str]]]:
        """The body of a small mutable file and its ETag; None for a 304."""
        headers = {"If-None-Match": etag} if etag else {}
        last = ""
        for _ in range(self._max_attempts):
            try:
                with self._open(url, headers) as response:
                    if response.status != 200:
                        raise _Failure(_Code.UNAVAILABLE, f"{url}: HTTP {response.status}")
                    data, announced = _read_body(
                        response, limit, _invalid(url, f"more than {limit} bytes: not a channel file")
                    )
                    if announced is not None:
                        last = f"{url}: the body ended after {len(data)} of {announced} bytes"
                        continue
                    tag = response.headers.get("ETag")
                    return data, (tag if isinstance(tag, str) else None)
            except _Failure:
                raise
            except urllib.error.HTTPError as e:
                e.close()
                if e.code == 304:
                    return None
                if e.code in (404, 410):
                    raise _Failure(_Code.NOT_FOUND, f"{url}: HTTP {e.code} (no such channel)") from None
                raise _Failure(_Code.UNAVAILABLE, f"{url}: HTTP {e.code} {e.reason}") from None
            except urllib.error.URLError as e:
                if not (isinstance(e.reason, BaseException) and _is_cut(e.reason)):
                    raise self._connect_failure(url, e) from None
                last = f"{url}: {e.reason}"
            except socket.timeout:
                raise _Failure(_Code.DEADLINE_EXCEEDED, f"{url}: no byte for {self._timeout:g} s (stalled)") from None
            except (http.client.HTTPException, OSError) as e:
                last = f"{url}: the connection broke: {e!r}"
        raise _Failure(_Code.UNAVAILABLE, last)

    def get_whole(self, url: str, limit: int, what: str) -> Tuple[bytes, Any]:
        """The body of a 200 answer to one GET (no retry: the caller has
        another road), read whole, and the answer's headers (an
        email.message.Message: .get(name) ignores case). Raises _Failure:
        NOT_FOUND (404, 410), UNAVAILABLE (refused, another status, a body
        cut short of its Content-Length, a broken connection),
        DEADLINE_EXCEEDED (no byte for timeout seconds), DATA_LOSS (more
        than `limit` bytes). Messages name the URL and, for an error
        status, the server's own message when it sent one."""
        try:
            with self._open(url, {}) as response:
                if response.status != 200:
                    raise _Failure(_Code.UNAVAILABLE, f"{url}: HTTP {response.status} for {what}")
                data, announced = _read_body(
                    response, limit, _Failure(_Code.DATA_LOSS, f"{url}: more than {limit} bytes: not {what}")
                )
                if announced is not None:
                    raise _Failure(
                        _Code.UNAVAILABLE, f"{url}: the body of {what} ended after {len(data)} of {announced} bytes"
                    )
                return data, response.headers
        except _Failure:
            raise
        except urllib.error.HTTPError as e:
            said = _server_message(e)
            e.close()
            why = f"{url}: HTTP {e.code}{': ' + said if said else ''}"
            raise _Failure(_Code.NOT_FOUND if e.code in (404, 410) else _Code.UNAVAILABLE, why) from None
        except urllib.error.URLError as e:
            raise self._connect_failure(url, e) from None
        except socket.timeout:
            raise _Failure(_Code.DEADLINE_EXCEEDED, f"{url}: no byte for {self._timeout:g} s (stalled)") from None
        except (http.client.HTTPException, OSError) as e:
            raise _Failure(_Code.UNAVAILABLE, f"{url}: the connection broke: {e!r}") from None

    def read_verified(self, url: str, sha256: str, size: int, sink: _Sink, what: str) -> None:
        """Bytes [0, size) of `url` into `sink` (emptied first), checked
        against `sha256` as they stream. A transfer cut after some bytes is
        resumed with a Range request; `max_attempts` transfers in a row that
        bring nothing give up. Raises _Failure: DATA_LOSS (bytes that cannot
        be the digest's: too many, a Content-Length or Content-Range that
        does not fit, a 416, a wrong hash; the sink then holds them),
        NOT_FOUND (404/410), UNAVAILABLE (refused, an error status, cuts),
        DEADLINE_EXCEEDED (no byte for timeout_seconds)."""
        sink.seek(0)
        sink.truncate()
        digest = hashlib.sha256()
        have = 0
        fruitless = 0  # transfers in a row that brought nothing
        stalls = 0
        short_body = False
        last = ""
        while True:
            start = have
            headers = {"Range": f"bytes={have}-"} if have > 0 else {}
            try:
                with self._open(url, headers) as response:
                    status = response.status
                    if status == 206:
                        first = _range_start(response.headers.get("Content-Range"))
                        if first != have:
                            raise _Failure(
                                _Code.DATA_LOSS,
                                f"{url}: asked for bytes from {have} of {what}, the mirror sent them from {first}",
                            )
                    elif status == 200:
                        if have > 0:
                            # The mirror ignored the Range request and sends the
                            # whole file: take it from the start.
                            sink.seek(0)
                            sink.truncate()
                            digest = hashlib.sha256()
                            have = start = 0
                    else:
                        raise _Failure(_Code.UNAVAILABLE, f"{url}: HTTP {status} for {what}")
                    content_type = str(response.headers.get("Content-Type", "")).lower()
                    hint = " (an HTML page)" if "html" in content_type else " (an error page or another file?)"
                    encoding = str(response.headers.get("Content-Encoding", "")).strip().lower()
                    if encoding not in ("", "identity"):
                        raise _Failure(
                            _Code.DATA_LOSS,
                            f"{url}: Content-Encoding {encoding} for {what}: release files are served as they are",
                        )
                    announced = response.headers.get("Content-Length")
                    if announced is not None and announced.strip().isdigit() and int(announced) != size - have:
                        raise _Failure(
                            _Code.DATA_LOSS,
                            f"{url}: {int(announced)} bytes announced from byte {have} of {what}, "
                            f"which has {size}{hint}",
                        )
                    while True:
                        chunk = _read_some(response)
                        if not chunk:
                            break
                        if have + len(chunk) > size:
                            raise _Failure(_Code.DATA_LOSS, f"{url}: more than the {size} bytes of {what}{hint}")
                        digest.update(chunk)
                        sink.write(chunk)
                        have += len(chunk)
                    if have == size:
                        break
                    short_body = True
                    last = f"{url}: the body ended after {have} of {size} bytes of {what}"
            except _Failure:
                raise
            except urllib.error.HTTPError as e:
                e.close()
                if e.code in (404, 410):
                    raise _Failure(_Code.NOT_FOUND, f"{url}: HTTP {e.code} (the mirror has no {what})") from None
                if e.code == 416:
                    raise _Failure(
                        _Code.DATA_LOSS,
                        f"{url}: HTTP 416 for bytes {have}- of {what}: the mirror's file is shorter than "
                        f"its {size} bytes (truncated)",
                    ) from None
                raise _Failure(_Code.UNAVAILABLE, f"{url}: HTTP {e.code} {e.reason} for {what}") from None
            except urllib.error.URLError as e:
                if not (isinstance(e.reason, BaseException) and _is_cut(e.reason)):
                    raise self._connect_failure(url, e) from None
                short_body = False
                last = f"{url}: the connection broke after {have} of {size} bytes of {what}: {e.reason}"
            except socket.timeout:
                stalls += 1
                if have == start or stalls >= self._max_attempts:
                    raise _Failure(
                        _Code.DEADLINE_EXCEEDED,
                        f"{url}: no byte for {self._timeout:g} s after {have} of {size} bytes of {what} (stalled)",
                    ) from None
                short_body = False
                last = f"{url}: stalled after {have} of {size} bytes of {what}"
            except (http.client.HTTPException, OSError) as e:
                short_body = False
                last = f"{url}: the connection broke after {have} of {size} bytes of {what}: {e!r}"
            fruitless = 0 if have > start else fruitless + 1
            if fruitless >= self._max_attempts:
                if short_body:
                    raise _Failure(_Code.DATA_LOSS, f"{last} (truncated on the mirror)")
                raise _Failure(_Code.UNAVAILABLE, last)
        actual = digest.hexdigest()
        if actual != sha256:
            raise _Failure(
                _Code.DATA_LOSS,
                f"{url}: the bytes hash to {actual}, not to {what} (a wrong byte, or an error page served as 200)",
            )
