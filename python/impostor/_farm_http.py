"""A farm result over the farm's HTTP front end alone (impostor-server
--http-listen, docs/http_api.md), no gRPC: its listing from
BASE/api/v1/results/KEY/manifest (the impostor.v1.Manifest gRPC's GetResult
answers, binary, checked against its Repr-Digest header before it is read)
and every file from BASE/api/v1/results/KEY/files/NAME, verified as it
streams, installed as the gRPC road installs (_result_install). The Python
twin of client/transfer/farm_http_result_fetch.cc; Client.fetch falls back
to gRPC when this fails (FrontEndFailure).

The HTTP reads are _release_http's (the release mirrors' reader): only the
standard library.
"""
from __future__ import annotations

import base64
import hashlib
import os
import re
import ssl
import urllib.parse
import urllib.request
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

import grpc
from google.protobuf.message import DecodeError

from ._release_catalog import _Failure
from ._release_http import _MirrorReader, _Redirects
from ._result_install import Staging, install_result, manifest_problem
from .errors import ImpostorError
from .results import FetchResult
from .v1 import types_pb2 as pb

#: Read when Client's farm_http is not given (the C++ SDK's kFarmHttpEnvVar).
FARM_HTTP_ENV_VAR = "IMPOSTOR_FARM_HTTP"
# The longest base URL accepted (common/net/farm_http_base.h).
MAX_FARM_HTTP_URL_BYTES = 2048
# The listing's media type and the most bytes of it read (a result lists a
# few dozen files: a few KB).
RESULT_MANIFEST_MEDIA_TYPE = "application/x-protobuf"
MAX_RESULT_MANIFEST_BYTES = 4 << 20
REPR_DIGEST_HEADER = "Repr-Digest"

_KEY = re.compile(r"[0-9a-f]{64}\Z")
_USER_AGENT = "impostor-python (farm client)"


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
        for name, path, digest in missing:
            url = self.file_url(cache_key, name)
            try:
                self._reader.read_verified(
                    url, digest.hash, digest.size_bytes, staging.stage(path),
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
