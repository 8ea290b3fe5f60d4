"""A farm result over the farm's HTTP front end (impostor-server
--http-listen, docs/http_api.md), two ways:

- a front end the Client was given (farm_http, $IMPOSTOR_FARM_HTTP): the
  whole result from it, no gRPC: its listing from
  BASE/api/v1/results/KEY/manifest (the impostor.v1.Manifest gRPC's
  GetResult answers, binary, checked against its Repr-Digest header before
  it is read) and every file from BASE/api/v1/results/KEY/files/NAME,
  verified as it streams, installed as the gRPC road installs
  (_result_install). The Python twin of
  client/transfer/farm_http_result_fetch.cc; Client.fetch falls back to
  gRPC when this fails (FrontEndFailure).
- a front end the farm advertises (impostor-server --http-advertise, the
  initial metadata FARM_HTTP_METADATA_KEY of its GetResult answers) to a
  Client given none and not told "none": the gRPC road's large files (those
  no BatchReadBlobs batch carries) from it, each falling back to ReadBlob
  alone (AdvertisedFrontEnd; the twin of client/transport/farm_http_choice.cc
  and client/transfer/farm_http_fetch.cc).

The HTTP reads are _release_http's (the release mirrors' reader): only the
standard library.
"""
from __future__ import annotations

import base64
import hashlib
import logging
import os
import re
import ssl
import threading
import urllib.parse
import urllib.request
from pathlib import Path
from typing import Callable, List, Optional, Sequence, Tuple

import grpc
from google.protobuf.message import DecodeError

from ._release_catalog import _Failure
from ._release_http import _MirrorReader, _Redirects
from ._result_install import StagedFile, Staging, install_result, manifest_problem
from .errors import ImpostorError
from .results import FetchResult
from .v1 import types_pb2 as pb

#: Read when Client's farm_http is not given (the C++ SDK's kFarmHttpEnvVar).
FARM_HTTP_ENV_VAR = "IMPOSTOR_FARM_HTTP"
#: The GetResult answer's initial metadata naming the front end the farm
#: advertises (common/net/farm_http_base.h's kFarmHttpMetadataKey).
FARM_HTTP_METADATA_KEY = "impostor-farm-http"
#: Files in a row an advertised front end could not give after which a
#: Client stops asking it (the C++ SDK's kFarmHttpFailuresToGiveUp): a
#: misconfigured URL or token then costs three warnings, not one per file of
#: a batch of results. A file it gives starts the count over.
FARM_HTTP_FAILURES_TO_GIVE_UP = 3
# The longest base URL accepted (common/net/farm_http_base.h).
MAX_FARM_HTTP_URL_BYTES = 2048
# The listing's media type and the most bytes of it read (a result lists a
# few dozen files: a few KB).
RESULT_MANIFEST_MEDIA_TYPE = "application/x-protobuf"
MAX_RESULT_MANIFEST_BYTES = 4 << 20
REPR_DIGEST_HEADER = "Repr-Digest"

_KEY = re.compile(r"[0-9a-f]{64}\Z")
_USER_AGENT = "impostor-python (farm client)"
# The Client's warnings (Client.fetch logs the others there too).
_log = logging.getLogger("impostor.client")


class FrontEndFailure(Exception):
    """What the front end could not give (the listing or a file: missing,
    refused, spoiled, stalled): the result is then for gRPC. `code`:
    NOT_FOUND (HTTP 404), UNAVAILABLE, DEADLINE_EXCEEDED or DATA_LOSS;
    `message` names the URL. `quiet`: nothing went wrong on the way (the
    listing's 404: no such result, or a farm older than the route; a key
    that is not one), so the fallback is no warning. Never raised for local
    trouble (ImpostorError INTERNAL)."""

    def __init__(self, code: grpc.StatusCode, message: str, *, quiet: bool = False) -> None:
        super().__init__(f"{code.name}: {message}")
        self.code = code
        self.message = message
        self.quiet = quiet


def _check_base(url: str, tls: bool) -> Optional[str]:
    """Why `url` cannot be a front end's base URL, or None
    (ValidateFarmHttpBase in common/net/farm_http_base.cc)."""
    if len(url) > MAX_FARM_HTTP_URL_BYTES:
        return f"the URL is {len(url)} bytes, over the limit of {MAX_FARM_HTTP_URL_BYTES}"
    if any(ord(c) <= 0x20 or ord(c) >= 0x7F for c in url):
        return "the URL holds a space, a control or a non-ASCII character"
    if url.startswith("https://"):
        https, rest = True, url[len("https://"):]
    elif url.startswith("http://"):
        https, rest = False, url[len("http://"):]
    else:
        return f'"{url}" is not an http:// or https:// URL'
    if not rest or rest[0] in "/:":
        return f'"{url}" names no host'
    if "?" in rest or "#" in rest:
        return f'"{url}" has a query or a fragment; give the base URL'
    if "@" in rest:
        return f'"{url}" carries credentials; the token goes in the Authorization header'
    if tls and not https:
        return (
            f'"{url}" is plaintext while the farm\'s gRPC is TLS: the token would cross the network in clear; '
            "give an https:// URL (a TLS proxy in front of --http-listen)"
        )
    return None


def resolve_farm_http(configured: Optional[str], tls: bool) -> str:
    """The front end to use: `configured` (Client's farm_http), else
    $IMPOSTOR_FARM_HTTP (unset or empty: none), without a trailing "/"; ""
    when neither is given or the one given is "none" (ResolveFarmHttp in
    the C++ SDK). INVALID_ARGUMENT naming farm_http (or the variable) and
    what is wrong; with `tls` (the client's gRPC is TLS) only https://."""
    url, named = configured or "", "farm_http"
    if not url:
        url, named = os.environ.get(FARM_HTTP_ENV_VAR, ""), f"${FARM_HTTP_ENV_VAR}"
        if not url:
            return ""
    if not isinstance(url, str):
        raise ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, f"{named}: expected a URL string, not {url!r}")
    if url == "none":
        return ""
    why = _check_base(url, tls)
    if why is not None:
        raise ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, f"{named}: {why}")
    return url.rstrip("/")


def farm_http_turned_off(configured: Optional[str]) -> bool:
    """Whether the front end is turned off: `configured` (Client's
    farm_http), or $IMPOSTOR_FARM_HTTP when it is not given, is "none"
    (FarmHttpTurnedOff in the C++ SDK). Then a front end the farm
    advertises is not used either."""
    value = configured or os.environ.get(FARM_HTTP_ENV_VAR, "")
    return value == "none"


def repr_digest_sha256(body: bytes) -> str:
    """The Repr-Digest value (RFC 9530) of `body`: "sha-256=:BASE64:"."""
    return "sha-256=:" + base64.b64encode(hashlib.sha256(body).digest()).decode("ascii") + ":"


def repr_digest_sha256_member(header: str) -> str:
    """The sha-256 member of a Repr-Digest value, whole ("sha-256=:...:"),
    maybe among other members separated by commas; "" when it has none."""
    for member in header.split(","):
        member = member.strip()
        if member.startswith("sha-256="):
            return member
    return ""


class FrontEnd:
    """A farm's HTTP front end as Client.fetch reads it: its base URL, the
    farm token as a bearer header, the client's CA file for https://, and
    rpc_timeout_seconds as the stall limit (no byte for that long). One try
    per request: gRPC is the next road."""

    def __init__(self, base: str, *, token: Optional[str], ca_file: Optional["str | os.PathLike[str]"],
                 timeout_seconds: float) -> None:
        self.base = base
        handlers: List[urllib.request.BaseHandler] = [_Redirects()]
        if ca_file is not None:
            try:
                context = ssl.create_default_context(cafile=os.fspath(ca_file))
            except (OSError, ssl.SSLError) as e:
                raise ImpostorError(
                    grpc.StatusCode.INVALID_ARGUMENT, f"tls_ca: cannot use {os.fspath(ca_file)} for farm_http: {e}"
                ) from None
            handlers.append(urllib.request.HTTPSHandler(context=context))
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self._reader = _MirrorReader(
            urllib.request.build_opener(*handlers), timeout_seconds, 1, headers=headers, user_agent=_USER_AGENT
        )

    def manifest_url(self, cache_key: str) -> str:
        return f"{self.base}/api/v1/results/{cache_key}/manifest"

    def file_url(self, cache_key: str, file_name: str) -> str:
        # Percent-encoded but for RFC 3986's unreserved characters.
        return f"{self.base}/api/v1/results/{cache_key}/files/{urllib.parse.quote(file_name, safe='')}"

    def get_result(self, cache_key: str) -> "pb.Manifest":
        """The result's listing, checked whole (GetResultOverHttp): its media
        type, its Repr-Digest before it is parsed (a body cut at a field's
        end would parse, as a result with fewer files), the cache key, and
        the files it names (manifest_problem). Raises FrontEndFailure
        (DATA_LOSS for an answer that is not this result's listing)."""
        url = self.manifest_url(cache_key)
        try:
            body, headers = self._reader.get_whole(url, MAX_RESULT_MANIFEST_BYTES, "a result's listing")
        except _Failure as f:
            raise FrontEndFailure(f.code, f.message, quiet=f.code == grpc.StatusCode.NOT_FOUND) from None

        def spoiled(why: str) -> FrontEndFailure:
            return FrontEndFailure(grpc.StatusCode.DATA_LOSS, f"{url}: {why}")

        content_type = str(headers.get("Content-Type") or "")
        if not content_type.lower().startswith(RESULT_MANIFEST_MEDIA_TYPE):
            raise spoiled(
                f"HTTP 200 with {content_type or 'no media type'}, not a result's listing ({RESULT_MANIFEST_MEDIA_TYPE})"
            )
        said = str(headers.get(REPR_DIGEST_HEADER) or "")
        if not said:
            raise spoiled(f"the listing came without its {REPR_DIGEST_HEADER} header (not the farm's answer?)")
        expected = repr_digest_sha256(body)
        if repr_digest_sha256_member(said) != expected:
            raise spoiled(
                f'the listing\'s {len(body)} bytes hash to {expected}, not to its {REPR_DIGEST_HEADER} '
                f'"{said[:200]}": cut or altered on the way'
            )
        try:
            manifest: pb.Manifest = pb.Manifest.FromString(body)
        except DecodeError:
            raise spoiled(f"{len(body)} bytes that are not an impostor.v1.Manifest") from None
        if manifest.cache_key != cache_key:
            raise spoiled(f'the listing is of result "{manifest.cache_key[:80]}", not of the one asked for')
        problem = manifest_problem(manifest)
        if problem is not None:
            raise spoiled(problem)
        return manifest

    def stage_files(self, cache_key: str, missing: Sequence[Tuple[str, Path, "pb.Digest"]], staging: Staging) -> None:
        """install_result's road over the front end: each file streamed into
        its staged file, SHA-256 and size checked as it streams. Raises
        FrontEndFailure naming the URL and the digest; a local write error
        is ImpostorError INTERNAL (StagedFile), raised as it is."""
        # Largest first: each is complete once the next is staged, and its
        # flush to disk then overlaps the rest (_result_install.EarlySync).
        for name, path, digest in sorted(missing, key=lambda f: -f[2].size_bytes):
            self.read_file(cache_key, name, digest, staging.stage(path))

    def read_file(self, cache_key: str, name: str, digest: "pb.Digest", staged: StagedFile) -> None:
        """File `name` of result `cache_key` into `staged` (emptied first),
        SHA-256 and size checked as it streams: one request (a cut after
        some bytes is resumed with a Range request once). Raises
        FrontEndFailure naming the URL and the digest (`staged` then holds
        what came); a local write error is ImpostorError INTERNAL
        (StagedFile), raised as it is."""
        try:
            self._reader.read_verified(
                self.file_url(cache_key, name), digest.hash, digest.size_bytes, staged,
                f"{name} (sha256 {digest.hash}, {digest.size_bytes} bytes)",
            )
        except _Failure as f:
            raise FrontEndFailure(f.code, f.message) from None

    def fetch(self, cache_key: str, out_dir: Path, start: float) -> FetchResult:
        """The whole result over the front end (FetchResultFilesOverHttp).
        A key that is not 64 lowercase hex characters is a quiet
        FrontEndFailure INVALID_ARGUMENT before any request (gRPC then says
        what the farm says of it). Raises FrontEndFailure for what the front end could
        not give; ImpostorError for local trouble. On any error nothing of
        the result was renamed into out_dir."""
        if not _KEY.match(cache_key):
            raise FrontEndFailure(
                grpc.StatusCode.INVALID_ARGUMENT,
                f'cache_key: expected 64 lowercase hex characters, got "{cache_key[:80]}"',
                quiet=True,
            )
        manifest = self.get_result(cache_key)
        return install_result(manifest, out_dir, lambda missing, staging: self.stage_files(cache_key, missing, staging),
                              start)


def _shown(value: str, limit: int = 200) -> str:
    """An untrusted value for a log line: at most `limit` characters, quotes,
    backslashes and anything unprintable escaped (EscapeUntrusted)."""
    return value[:limit].encode("unicode_escape").decode("ascii").replace('"', '\\"')


class AdvertisedFrontEnd:
    """The front end a farm advertises, for a Client given none and not told
    "none" (the C++ SDK's FarmHttpChoice and its transport's record of
    failures): learn() takes the value of each GetResult answer's
    FARM_HTTP_METADATA_KEY, checked as a configured one (_check_base: with
    `tls`, the Client's gRPC is TLS, only https://); stage() reads a large
    file from it, and over gRPC when it cannot give it. After
    FARM_HTTP_FAILURES_TO_GIVE_UP files in a row it could not give, it is
    given up for the Client's life. The token goes as a bearer header and
    `ca_file` is trusted for https://, as for a configured one.

    Thread-safe: a Client's fetches may run side by side."""

    def __init__(self, *, tls: bool, token: Optional[str], ca_file: Optional["str | os.PathLike[str]"],
                 timeout_seconds: float) -> None:
        self._tls = tls
        self._token = token
        self._ca_file = ca_file
        self._timeout_seconds = timeout_seconds
        self._lock = threading.Lock()
        self._front_end: Optional[FrontEnd] = None  # guarded by _lock
        self._refused = ""  # the last value warned about; guarded by _lock
        self._failures_in_a_row = 0  # guarded by _lock
        self._given_up = False  # guarded by _lock

    def learn(self, advertised: str) -> None:
        """The value a GetResult answer advertised: used from now on when it
        checks out (a value already in use changes nothing); else one
        warning (event=farm_http_advertisement_refused) per value refused,
        and the front end in use, if any, stays."""
        why = _check_base(advertised, self._tls)
        base = advertised.rstrip("/")
        front_end: Optional[FrontEnd] = None
        if why is None:
            with self._lock:
                if self._front_end is not None and self._front_end.base == base:
                    return
            try:
                front_end = FrontEnd(base, token=self._token, ca_file=self._ca_file,
                                     timeout_seconds=self._timeout_seconds)
            except ImpostorError as e:
                why = e.message
        with self._lock:
            if front_end is not None:
                _log.debug("event=farm_http_advertised url=%s", base)
                self._front_end = front_end
                return
            # The farm's operator can fix it; the results come over gRPC meanwhile.
            shown = _shown(advertised)
            if shown == self._refused:
                return
            self._refused = shown
        _log.warning('event=farm_http_advertisement_refused url="%s" why="%s" note="results come over gRPC"',
                     shown, _shown(why or "", 500))

    def current(self) -> Optional[FrontEnd]:
        """The front end to read from now: None when none was advertised (or
        none that checked out) or it was given up."""
        with self._lock:
            return None if self._given_up else self._front_end

    def _note(self, front_end: FrontEnd, failure: Optional[FrontEndFailure]) -> None:
        """Counts a file the front end gave (None: the count starts over) or
        could not give; the FARM_HTTP_FAILURES_TO_GIVE_UP-th in a row gives
        it up, with one warning."""
        with self._lock:
            if failure is None:
                self._failures_in_a_row = 0
                return
            self._failures_in_a_row += 1
            if self._failures_in_a_row < FARM_HTTP_FAILURES_TO_GIVE_UP or self._given_up:
                return
            self._given_up = True
        _log.warning('event=farm_http_given_up url=%s failures_in_a_row=%d last="%s" '
                     'note="every further file of this client goes over gRPC"',
                     front_end.base, FARM_HTTP_FAILURES_TO_GIVE_UP, _shown(failure.message, 500))

    def stage(self, cache_key: str, name: str, path: Path, digest: "pb.Digest", staging: Staging,
              over_grpc: Callable[[StagedFile], None]) -> None:
        """_blobs.stage_over_grpc's road for a file no batch carries: into a
        file staged for `path`, from the front end when there is one in use,
        verified; when it cannot give the file (an error status, spoiled
        bytes, a stall), one warning (event=farm_http_fallback) and
        over_grpc(the same staged file, emptied): ReadBlob. A local write
        error (ImpostorError INTERNAL) is raised as it is, never retried."""
        staged = staging.stage(path)
        front_end = self.current()
        if front_end is not None:
            try:
                front_end.read_file(cache_key, name, digest, staged)
                self._note(front_end, None)
                return
            except FrontEndFailure as f:
                self._note(front_end, f)
                _log.warning('event=farm_http_fallback key=%s file=%s reason="%s" note="fetching it over gRPC"',
                             cache_key[:80], name, _shown(f.message, 500))
            staged.seek(0)
            staged.truncate()
        over_grpc(staged)
