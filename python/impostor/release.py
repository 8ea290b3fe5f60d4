"""Impostors by asset name from published releases, over HTTP(S): no farm.

A release tree (client/delivery/release_format.md, written by `impostor
publish`) is plain files that any static web server, CDN or bucket serves:

    v1/channels/<channel>.json       mutable: the channel's catalog digest
    v1/catalogs/sha256/<hh>/<hex>    the catalog: asset name -> files
    v1/blobs/sha256/<hh>/<hex>       one file's bytes

ReleaseClient reads them from a list of mirror base URLs (the URL of the
folder holding `v1/`), in order, the way the C++ SDK's CacheOptions::mirrors
and ::channel do (client/delivery/): every byte is verified against its
SHA-256 and size while it streams (and the catalog against its Ed25519
signature when a public key is given), a cut transfer is resumed with a
Range request, and a mirror that serves a wrong byte, an HTML page, a short
body, an error status or nothing at all is left for the next one. The last
good catalog and every fetched file are kept under `cache_dir`:

    cache_dir/releases/channels/<channel>.json   the channel file, as served
    cache_dir/releases/catalogs/<hex>            the catalog it names
    cache_dir/blobs/<hex>                        each file, by its SHA-256

so a client that fetched once keeps resolving names and serving files with
every mirror gone. Only the standard library is used (urllib.request), plus
the cryptography package (Debian: python3-cryptography) when
`public_key_pem` is given.
"""
from __future__ import annotations

import base64
import binascii
import copy
import dataclasses
import hashlib
import http.client
import io
import json
import logging
import os
import re
import socket
import ssl
import tempfile
import threading
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path
from typing import IO, Any, BinaryIO, Callable, Dict, List, Optional, Sequence, Tuple, Type, Union

import grpc

from .errors import ImpostorError

__all__ = [
    "CATALOG_SCHEMA_VERSION",
    "CHANNEL_SCHEMA_VERSION",
    "FetchedAsset",
    "ReleaseClient",
    "ReleaseError",
    "blob_path",
    "catalog_path",
    "channel_path",
    "validate_asset_name",
    "validate_channel_name",
]

_log = logging.getLogger(__name__)

#: The newest schema_version of a catalog / channel file this reader knows.
CATALOG_SCHEMA_VERSION = 1
CHANNEL_SCHEMA_VERSION = 1
MAX_ASSET_NAME_LENGTH = 200
MAX_CHANNEL_NAME_LENGTH = 64

_MAX_FILE_NAME_LENGTH = 255
_MAX_FILES_PER_ASSET = 4096
# A channel file is a few hundred bytes; anything far larger is not one.
_MAX_CHANNEL_FILE_BYTES = 64 << 10
_MAX_CATALOG_BYTES = 512 << 20
_CHUNK_BYTES = 64 << 10
_USER_AGENT = "impostor-python (release client)"

_HEX = re.compile(r"[0-9a-f]{64}\Z")
_ASSET_NAME_CHARS = re.compile(r"[A-Za-z0-9._/-]+\Z")
_CHANNEL_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*\Z")
_CONTENT_RANGE = re.compile(r"\s*bytes\s+(\d+)-(\d+)/(\d+|\*)\s*\Z")

_Code = grpc.StatusCode
PathLike = Union[str, "os.PathLike[str]"]


# ---------------------------------------------------------------------------
# Names and paths (release_format.md; client/delivery/release_paths.cc)


def _shown(text: str) -> str:
    # Names come from users and from untrusted catalogs: shown clipped.
    return text if len(text) <= 80 else text[:80] + "..."


def validate_asset_name(name: str, field: str = "asset name") -> None:
    """Raises ValueError naming `field` unless `name` is a valid asset name:
    1..200 characters of [A-Za-z0-9._/-], "/"-separated segments, none
    empty, "." or "..", no leading or trailing "/"."""
    if not isinstance(name, str):
        raise TypeError(f"{field}: expected a string, not {type(name).__name__}")

    def bad(why: str) -> ValueError:
        return ValueError(f'{field} "{_shown(name)}": {why}')

    if not name:
        raise bad("must not be empty")
    if len(name) > MAX_ASSET_NAME_LENGTH:
        raise bad(f"is {len(name)} characters; the limit is {MAX_ASSET_NAME_LENGTH}")
    if not _ASSET_NAME_CHARS.match(name):
        raise bad("may hold only letters, digits and . _ - / (one character is outside that set)")
    if name.startswith("/"):
        raise bad("must not start with / (names are relative)")
    if name.endswith("/"):
        raise bad("must not end with /")
    for segment in name.split("/"):
        if not segment:
            raise bad("has an empty segment (//)")
        if segment in (".", ".."):
            raise bad("has a . or .. segment")


def validate_channel_name(name: str, field: str = "channel") -> None:
    """Raises ValueError naming `field` unless `name` matches
    [A-Za-z0-9][A-Za-z0-9._-]{0,63}."""
    if not isinstance(name, str):
        raise TypeError(f"{field}: expected a string, not {type(name).__name__}")

    def bad(why: str) -> ValueError:
        return ValueError(f'{field} "{_shown(name)}": {why}')

    if not name:
        raise bad("must not be empty")
    if len(name) > MAX_CHANNEL_NAME_LENGTH:
        raise bad(f"is {len(name)} characters; the limit is {MAX_CHANNEL_NAME_LENGTH}")
    if not name[0].isascii() or not name[0].isalnum():
        raise bad("must start with a letter or digit")
    if not _CHANNEL_NAME.match(name):
        raise bad("may hold only letters, digits and . _ -")


def blob_path(sha256: str) -> str:
    """"v1/blobs/sha256/<hh>/<hex>", relative to a release root."""
    return f"v1/blobs/sha256/{sha256[:2]}/{sha256}"


def catalog_path(sha256: str) -> str:
    """"v1/catalogs/sha256/<hh>/<hex>", relative to a release root."""
    return f"v1/catalogs/sha256/{sha256[:2]}/{sha256}"


def channel_path(channel: str) -> str:
    """"v1/channels/<channel>.json", relative to a release root."""
    return f"v1/channels/{channel}.json"


def _join_url(base: str, path: str) -> str:
    return base.rstrip("/") + "/" + path.lstrip("/")


def _check_mirror(url: Any, index: int) -> str:
    field = f"mirrors[{index}]"
    if not isinstance(url, str):
        raise TypeError(f"{field}: expected a base URL string, not {type(url).__name__}")
    parts = urllib.parse.urlsplit(url)
    if parts.scheme not in ("http", "https") or not parts.hostname:
        raise ValueError(f'{field} "{_shown(url)}": expected an http:// or https:// base URL')
    if parts.query or parts.fragment:
        raise ValueError(f'{field} "{_shown(url)}": a base URL has no query or fragment')
    return url.rstrip("/")


def _check_file_name(name: str) -> Optional[str]:
    """Why `name` is not a plain file name a catalog may list, or None."""
    if not name or len(name) > _MAX_FILE_NAME_LENGTH:
        return "must be 1..255 characters"
    if any(c in name for c in "/\\\0"):
        return "must be a plain file name (no path)"
    if name.startswith("."):
        return "must not be hidden or . or .. (start with .)"
    return None


# ---------------------------------------------------------------------------
# Errors


class ReleaseError(ImpostorError):
    """A release could not be read: raised by ReleaseClient.

    code (a grpc.StatusCode, as for every ImpostorError):
        DATA_LOSS: a mirror served bytes that do not match the digest (a
            wrong byte, an HTML page, a truncated file); with several
            mirrors, the code when at least one of them did.
        NOT_FOUND: every mirror answered 404 (no such channel or file), or
            the catalog has no asset of that name or cache key.
        UNAVAILABLE: no mirror answered (and nothing usable is cached).
        DEADLINE_EXCEEDED: every mirror stalled (no byte for timeout_seconds).
        PERMISSION_DENIED: public_key_pem is set and the catalog is not
            signed, signed by another key, or its signature does not verify.
        FAILED_PRECONDITION: the channel file or catalog has a schema_version
            newer than this reader's (the message names both).
        INVALID_ARGUMENT: the channel file or catalog is malformed (the
            message names the field), e.g. a file name with a path.
    message: one line naming the file, its digest and every mirror's failure.
    file, digest: the file that failed ("" for channel and catalog problems).
    asset: the asset name, when fetching one.
    failures: each mirror's failure, "URL: why", in the order tried.
    """

    def __init__(
        self,
        code: grpc.StatusCode,
        message: str,
        *,
        file: str = "",
        digest: str = "",
        asset: str = "",
        cache_key: Optional[str] = None,
        failures: Sequence[str] = (),
    ) -> None:
        super().__init__(code, message, cache_key=cache_key)
        self.file = file
        self.digest = digest
        self.asset = asset
        self.failures = list(failures)


class _Failure(Exception):
    """One source's failure; `message` names its URL."""

    def __init__(self, code: grpc.StatusCode, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


def _combined_code(failures: Sequence[_Failure]) -> grpc.StatusCode:
    codes = {f.code for f in failures}
    if len(codes) == 1:
        return next(iter(codes))
    for code in (_Code.PERMISSION_DENIED, _Code.FAILED_PRECONDITION, _Code.DATA_LOSS):
        if code in codes:
            return code
    return _Code.UNAVAILABLE


# ---------------------------------------------------------------------------
# The channel file and the catalog (untrusted documents: every field checked;
# client/delivery/catalog.cc)


@dataclasses.dataclass(frozen=True)
class _Pointer:
    channel: str
    catalog_sha256: str
    catalog_size_bytes: int
    signature: Optional[Dict[str, str]]


_KINDS: Dict[str, Tuple[str, Callable[[Any], bool]]] = {
    "string": ("a string", lambda v: isinstance(v, str)),
    "object": ("an object", lambda v: isinstance(v, dict)),
    "array": ("an array", lambda v: isinstance(v, list)),
    "count": ("a whole number >= 0", lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 0),
}


def _invalid(source: str, message: str) -> _Failure:
    return _Failure(_Code.INVALID_ARGUMENT, f"{source}: {message}")


def _field(obj: Any, key: str, path: str, kind: str, source: str) -> Any:
    if not isinstance(obj, dict):
        raise _invalid(source, f"{path.rstrip('.') or 'the document'} must be an object")
    if key not in obj:
        raise _invalid(source, f"{path}{key} is missing")
    description, ok = _KINDS[kind]
    if not ok(obj[key]):
        raise _invalid(source, f"{path}{key} must be {description}")
    return obj[key]


def _hex_field(obj: Any, key: str, path: str, source: str) -> str:
    value: str = _field(obj, key, path, "string", source)
    if not _HEX.match(value):
        raise _invalid(source, f"{path}{key} must be 64 lowercase hex characters")
    return value


def _parse_json(data: bytes, source: str, what: str) -> Dict[str, Any]:
    try:
        doc = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        doc = None
    if not isinstance(doc, dict):
        raise _invalid(source, f"not a JSON object (a {what} was expected; an HTML error page?)")
    return doc


def _check_schema(doc: Dict[str, Any], schema: str, known: int, source: str) -> int:
    name: str = _field(doc, "schema", "", "string", source)
    if name != schema:
        raise _invalid(source, f'schema is "{_shown(name)}", expected "{schema}"')
    version: int = _field(doc, "schema_version", "", "count", source)
    if version > known:
        raise _Failure(
            _Code.FAILED_PRECONDITION,
            f"{source}: schema_version {version} is newer than this reader's ({known}); "
            "update the impostor package",
        )
    if version < 1:
        raise _invalid(source, "schema_version must be >= 1")
    return version


def _parse_channel(data: bytes, source: str) -> _Pointer:
    doc = _parse_json(data, source, "channel file")
    _check_schema(doc, "impostor-channel", CHANNEL_SCHEMA_VERSION, source)
    channel: str = _field(doc, "channel", "", "string", source)
    catalog = _field(doc, "catalog", "", "object", source)
    sha = _hex_field(catalog, "sha256", "catalog.", source)
    size: int = _field(catalog, "size_bytes", "catalog.", "count", source)
    if "published_at" in doc:
        _field(doc, "published_at", "", "string", source)
    signature: Optional[Dict[str, str]] = None
    if "signature" in doc:
        sig = _field(doc, "signature", "", "object", source)
        signature = {k: _field(sig, k, "signature.", "string", source) for k in ("algorithm", "key_id", "value")}
    try:
        validate_channel_name(channel, f"{source}: channel")
    except ValueError as e:
        raise _Failure(_Code.INVALID_ARGUMENT, str(e)) from None
    return _Pointer(channel, sha, size, signature)


def _parse_catalog(data: bytes, source: str) -> Dict[str, Any]:
    """The catalog document, every field a client relies on checked."""
    doc = _parse_json(data, source, "catalog")
    _check_schema(doc, "impostor-catalog", CATALOG_SCHEMA_VERSION, source)
    assets = _field(doc, "assets", "", "object", source)
    for name, asset in assets.items():
        try:
            validate_asset_name(name, f"{source}: asset name")
        except ValueError as e:
            raise _Failure(_Code.INVALID_ARGUMENT, str(e)) from None
        path = f'assets["{_shown(name)}"].'
        _hex_field(asset, "cache_key", path, source)
        for key in ("product", "layout"):
            _field(asset, key, path, "string", source)
        for key in ("frames", "resolution"):
            _field(asset, key, path, "count", source)
        manifest = _field(asset, "manifest", path, "object", source)
        manifest_sha = _hex_field(manifest, "sha256", path + "manifest.", source)
        manifest_size = _field(manifest, "size_bytes", path + "manifest.", "count", source)
        files = _field(asset, "files", path, "array", source)
        if len(files) > _MAX_FILES_PER_ASSET:
            raise _invalid(source, f"{path}files lists {len(files)} files; the limit is {_MAX_FILES_PER_ASSET}")
        names = set()
        for i, f in enumerate(files):
            fpath = f"{path}files[{i}]."
            file_name: str = _field(f, "name", fpath, "string", source)
            _hex_field(f, "sha256", fpath, source)
            _field(f, "size_bytes", fpath, "count", source)
            why = _check_file_name(file_name)
            if why is not None:
                raise _invalid(source, f'{fpath}name "{_shown(file_name)}" {why}')
            if file_name in names:
                raise _invalid(source, f'{fpath}name "{_shown(file_name)}" is listed twice')
            names.add(file_name)
            if file_name == "manifest.json" and (f["sha256"] != manifest_sha or f["size_bytes"] != manifest_size):
                raise _invalid(source, f"{fpath}sha256 differs from the asset's manifest digest")
        if "manifest.json" not in names:
            raise _invalid(source, f"{path}files must list manifest.json")
    return doc


class _Ed25519Verifier:
    """The catalog signature check (client/delivery/catalog_signature.cc)."""

    def __init__(self, pem: Union[bytes, str]) -> None:
        try:
            from cryptography.exceptions import InvalidSignature, UnsupportedAlgorithm
            from cryptography.hazmat.primitives import serialization
            from cryptography.hazmat.primitives.asymmetric import ed25519
        except ImportError as e:  # pragma: no cover - Debian ships it
            raise ImportError(
                "public_key_pem: checking catalog signatures needs the cryptography package "
                "(Debian: python3-cryptography)"
            ) from e
        if isinstance(pem, str):
            pem = pem.encode("ascii", "replace")
        if not isinstance(pem, bytes):
            raise TypeError(f"public_key_pem: expected PEM bytes, not {type(pem).__name__}")
        try:
            key = serialization.load_pem_public_key(pem)
        except (ValueError, TypeError, UnsupportedAlgorithm) as e:
            raise ValueError(f"public_key_pem: not a public key in PEM ({e})") from None
        if not isinstance(key, ed25519.Ed25519PublicKey):
            raise ValueError(
                "public_key_pem: not an Ed25519 public key "
                "(openssl genpkey -algorithm ed25519; openssl pkey -pubout)"
            )
        self._key = key
        raw = key.public_bytes(serialization.Encoding.Raw, serialization.PublicFormat.Raw)
        self.key_id = hashlib.sha256(raw).hexdigest()[:16]
        self._invalid: Type[Exception] = InvalidSignature

    def check(self, signature: Optional[Dict[str, str]], message: bytes, source: str) -> None:
        def denied(why: str) -> _Failure:
            return _Failure(_Code.PERMISSION_DENIED, f"{source}: {why}")

        if signature is None:
            raise denied("the catalog is not signed, and this client accepts only signed catalogs")
        if signature["algorithm"] != "ed25519":
            raise denied(f'signature algorithm "{_shown(signature["algorithm"])}" (expected ed25519)')
        if signature["key_id"] != self.key_id:
            raise denied(f"signed by key {signature['key_id'][:16]}, but this client trusts key {self.key_id}")
        try:
            raw = base64.b64decode(signature["value"], validate=True)
        except (binascii.Error, ValueError):
            raw = b""
        if len(raw) != 64:
            raise denied("the signature is not 64 bytes of base64")
        try:
            self._key.verify(raw, message)
        except self._invalid:
            raise denied(
                "the catalog's signature does not verify (tampered with, or signed by another key)"
            ) from None


# ---------------------------------------------------------------------------
# Files on disk


def _umask() -> int:
    """The process's umask, read from /proc without changing it (Linux);
    elsewhere set and restored."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _unlink_quietly(path: Union[str, Path]) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def _file_matches(path: Path, sha256: str, size: int) -> bool:
    """True when `path` is a plain file holding exactly these bytes."""
    try:
        if not path.is_file() or path.stat().st_size != size:
            return False
        digest = hashlib.sha256()
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                digest.update(chunk)
        return digest.hexdigest() == sha256
    except OSError:
        return False


def _write_atomically(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        _unlink_quietly(tmp)
        raise


def _install_copy(source: Path, target: Path, sha256: str, size: int) -> bool:
    """Copies `source` to `target` by a temporary file in target's folder,
    fsynced and renamed, hashing as it copies: False (target untouched) when
    the bytes are not the digest's."""
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent)
    try:
        digest = hashlib.sha256()
        copied = 0
        with os.fdopen(fd, "wb") as out, open(source, "rb") as src:
            for chunk in iter(lambda: src.read(1 << 20), b""):
                digest.update(chunk)
                copied += len(chunk)
                out.write(chunk)
            out.flush()
            os.fsync(out.fileno())
        if copied != size or digest.hexdigest() != sha256:
            _unlink_quietly(tmp)
            return False
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, target)
        return True
    except BaseException:
        _unlink_quietly(tmp)
        raise


# ---------------------------------------------------------------------------
# HTTP


class _Redirects(urllib.request.HTTPRedirectHandler):
    """Follows redirects to http(s) only (urllib would also follow ftp)."""

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
        return super().redirect_request(req, fp, code, msg, headers, newurl)


def _range_start(value: Optional[str]) -> Optional[int]:
    m = _CONTENT_RANGE.match(value or "")
    return int(m.group(1)) if m else None


def _read_some(response: Any) -> bytes:
    read1 = getattr(response, "read1", None)
    data = read1(_CHUNK_BYTES) if read1 is not None else response.read(_CHUNK_BYTES)
    return bytes(data)


def _is_cut(error: BaseException) -> bool:
    """A connection that broke after it was made (worth resuming on the
    same mirror), as opposed to one refused or never made."""
    return isinstance(
        error, (ConnectionResetError, ConnectionAbortedError, BrokenPipeError, http.client.HTTPException)
    )


# ---------------------------------------------------------------------------
# The client


@dataclasses.dataclass(frozen=True)
class FetchedAsset:
    """What ReleaseClient.fetch() left on disk.

    name: the asset name (also when fetched by cache key).
    cache_key: the farm's cache key of the baked result.
    dir: the folder holding the files (out_dir).
    files: every file of the asset, in the catalog's order (manifest.json
        last), by file name, each verified against its SHA-256.
    manifest: the path of manifest.json.
    downloaded_bytes, downloaded_files: what came from mirrors in this call
        (0 when every file was already in out_dir or in the cache).
    sources: for each file, where it came from: "out_dir" (already there),
        "cache" (cache_dir/blobs), or the mirror base URL that served it.
    catalog_sha256: the catalog the asset was resolved in.
    offline: no mirror answered for the channel; the catalog kept under
        cache_dir was used.
    """

    name: str
    cache_key: str
    dir: Path
    files: Dict[str, Path]
    manifest: Path
    downloaded_bytes: int
    downloaded_files: int = 0
    sources: Dict[str, str] = dataclasses.field(default_factory=dict)
    catalog_sha256: str = ""
    offline: bool = False


class ReleaseClient:
    """Fetches impostors by asset name (or cache key) from a published
    release channel on one or more mirrors.

        client = ReleaseClient(["https://cdn.example.com/impostors"], "nightly", "~/.cache/game")
        oak = client.fetch("trees/oak", "assets/trees/oak")
        oak.files["albedo_alpha.png"], oak.manifest

    mirrors: base URLs (http:// or https://) of the folder that holds v1/,
        tried in order for every file.
    channel: the channel to follow ("nightly", "release-1.4").
    cache_dir: where the last good catalog (releases/) and every fetched
        file (blobs/) are kept; created as needed; may be shared by clients.
    timeout_seconds: a mirror that sends no byte for this long (connecting
        included) has stalled and the next one is asked.
    public_key_pem: an Ed25519 public key in PEM; when set, only catalogs
        signed by it are accepted (`impostor publish --sign-key`).
    max_attempts: transfers in a row that bring no new byte from one mirror
        (a cut connection) before it is left for the next one.
    ca_file: PEM CA certificates to trust for https:// mirrors instead of
        the system's.

    Raises ValueError (naming the argument) for bad arguments. Methods are
    safe to call from several threads; refreshes of the catalog are
    serialised, downloads are not.
    """

    def __init__(
        self,
        mirrors: Sequence[str],
        channel: str,
        cache_dir: PathLike,
        *,
        timeout_seconds: float = 30,
        public_key_pem: Optional[Union[bytes, str]] = None,
        max_attempts: int = 3,
        ca_file: Optional[PathLike] = None,
    ) -> None:
        if isinstance(mirrors, (str, bytes)):
            raise TypeError("mirrors: expected a list of base URLs, not one string")
        self._mirrors: List[str] = [_check_mirror(m, i) for i, m in enumerate(mirrors)]
        validate_channel_name(channel, "channel")
        self._channel = channel
        if isinstance(timeout_seconds, bool) or not isinstance(timeout_seconds, (int, float)) or not (
            0 < timeout_seconds < 1e6
        ):
            raise ValueError(f"timeout_seconds: expected seconds > 0, not {timeout_seconds!r}")
        self._timeout = float(timeout_seconds)
        if isinstance(max_attempts, bool) or not isinstance(max_attempts, int) or max_attempts < 1:
            raise ValueError(f"max_attempts: expected a whole number >= 1, not {max_attempts!r}")
        self._max_attempts = max_attempts
        if cache_dir is None or str(cache_dir) == "":
            raise ValueError("cache_dir: expected a folder path")
        self._cache_dir = Path(os.path.expanduser(os.fspath(cache_dir)))
        self._releases = self._cache_dir / "releases"
        self._blobs = self._cache_dir / "blobs"
        self._verifier = _Ed25519Verifier(public_key_pem) if public_key_pem is not None else None

        handlers: List[urllib.request.BaseHandler] = [_Redirects()]
        if ca_file is not None:
            try:
                context = ssl.create_default_context(cafile=os.fspath(ca_file))
            except (OSError, ssl.SSLError) as e:
                raise ValueError(f"ca_file {os.fspath(ca_file)!r}: {e}") from None
            handlers.append(urllib.request.HTTPSHandler(context=context))
        self._opener = urllib.request.build_opener(*handlers)

        self._lock = threading.Lock()
        self._catalog: Optional[Dict[str, Any]] = None
        self._catalog_bytes: Optional[bytes] = None
        self._catalog_sha256 = ""
        self._channel_text: Optional[bytes] = None
        self._checked = False  # the mirrors were asked (or found gone) since this client started
        self._offline = False
        self._loaded_from_disk = False
        self._etags: Dict[str, str] = {}  # by mirror

    # -- public ------------------------------------------------------------

    @property
    def mirrors(self) -> List[str]:
        return list(self._mirrors)

    @property
    def channel(self) -> str:
        return self._channel

    @property
    def cache_dir(self) -> Path:
        return self._cache_dir

    @property
    def catalog_sha256(self) -> str:
        """The digest of the catalog in use ("" before the first catalog())."""
        return self._catalog_sha256

    @property
    def offline(self) -> bool:
        """True when the last look at the mirrors found none answering and
        the catalog kept under cache_dir is in use."""
        return self._offline

    def catalog(self, refresh: bool = False) -> Dict[str, Any]:
        """The channel's catalog (a copy of the JSON document: "assets" maps
        each asset name to its cache_key, product, layout, frames,
        resolution, manifest and files).

        The first call asks the mirrors in order for the channel file (with
        If-None-Match once an ETag is known) and fetches the catalog it
        names by its digest, verified (SHA-256, size, and signature when
        public_key_pem is set), keeping both under cache_dir/releases. Later
        calls answer from memory unless `refresh`. When no mirror answers,
        the catalog kept under cache_dir is used (`offline` is then True).

        Raises ReleaseError: UNAVAILABLE (no mirror answered and nothing is
        kept), NOT_FOUND (every mirror has no such channel),
        PERMISSION_DENIED, FAILED_PRECONDITION, INVALID_ARGUMENT or
        DATA_LOSS, naming every mirror's failure.
        """
        with self._lock:
            self._ensure_catalog(refresh)
            return copy.deepcopy(self._catalog) if self._catalog is not None else {}

    def fetch(self, name_or_key: str, out_dir: PathLike) -> FetchedAsset:
        """Puts every file of an asset into `out_dir` (created if needed),
        each under its file name, and returns where.

        name_or_key: an asset name of the catalog ("trees/oak"), or the 64
        hex characters of a cache key one of its assets has. A name the
        catalog in memory lacks makes one refresh of the catalog.

        Each file is taken from out_dir when it already holds the file's
        bytes, else from cache_dir/blobs, else from the first mirror that
        serves it intact: verified while it streams, resumed with a Range
        request after a cut, and stored under cache_dir/blobs; it reaches
        out_dir through a temporary file there, fsynced and renamed, so
        out_dir never holds a byte that was not verified.

        Raises ValueError for a bad name; ReleaseError as catalog() does,
        NOT_FOUND for a name the catalog lacks, and, for a file no mirror
        gave intact, DATA_LOSS / NOT_FOUND / UNAVAILABLE /
        DEADLINE_EXCEEDED with a message naming the asset, the file, its
        digest and every mirror's failure. Files fetched before the failure
        stay (verified) in out_dir.
        """
        if not isinstance(name_or_key, str):
            raise TypeError(f"name_or_key: expected a string, not {type(name_or_key).__name__}")
        if not _HEX.match(name_or_key):
            validate_asset_name(name_or_key, "name_or_key")
        if out_dir is None or str(out_dir) == "":
            raise ValueError("out_dir: expected a folder path")
        out = Path(os.path.expanduser(os.fspath(out_dir)))

        with self._lock:
            asked = self._ensure_catalog(False)
            found = self._find(name_or_key)
            if found is None and not asked:
                self._ensure_catalog(True)
                found = self._find(name_or_key)
            catalog_sha256 = self._catalog_sha256
            offline = self._offline
        if found is None:
            what = "cache key" if _HEX.match(name_or_key) else "asset named"
            raise ReleaseError(
                _Code.NOT_FOUND,
                f'channel {self._channel} (catalog {catalog_sha256}{", offline" if offline else ""}) '
                f'has no {what} "{_shown(name_or_key)}"',
                asset=name_or_key,
            )
        name, asset = found

        out.mkdir(parents=True, exist_ok=True)
        files: Dict[str, Path] = {}
        sources: Dict[str, str] = {}
        downloaded_bytes = 0
        downloaded_files = 0
        for entry in asset["files"]:
            file_name: str = entry["name"]
            sha256: str = entry["sha256"]
            size: int = entry["size_bytes"]
            target = out / file_name
            if _file_matches(target, sha256, size):
                sources[file_name] = "out_dir"
            else:
                blob = self._blobs / sha256
                try:
                    cached = blob.is_file() and _install_copy(blob, target, sha256, size)
                except FileNotFoundError:  # removed meanwhile (another client's cleanup)
                    cached = False
                if cached:
                    sources[file_name] = "cache"
                else:
                    _unlink_quietly(blob)  # absent, or not the digest's bytes
                    mirror = self._download_blob(name, asset, file_name, sha256, size)
                    downloaded_bytes += size
                    downloaded_files += 1
                    if not _install_copy(blob, target, sha256, size):
                        raise ReleaseError(
                            _Code.DATA_LOSS,
                            f"{blob}: changed on disk right after it was verified (sha256 {sha256})",
                            file=file_name, digest=sha256, asset=name, cache_key=asset["cache_key"],
                        )
                    sources[file_name] = mirror
            files[file_name] = target
        return FetchedAsset(
            name=name,
            cache_key=asset["cache_key"],
            dir=out,
            files=files,
            manifest=files["manifest.json"],
            downloaded_bytes=downloaded_bytes,
            downloaded_files=downloaded_files,
            sources=sources,
            catalog_sha256=catalog_sha256,
            offline=offline,
        )

    # -- the catalog ---------------------------------------------------------

    def _find(self, name_or_key: str) -> Optional[Tuple[str, Dict[str, Any]]]:
        if self._catalog is None:
            return None
        assets: Dict[str, Any] = self._catalog["assets"]
        if name_or_key in assets:
            return name_or_key, assets[name_or_key]
        if _HEX.match(name_or_key):
            for name in sorted(assets):
                if assets[name]["cache_key"] == name_or_key:
                    return name, assets[name]
        return None

    def _ensure_catalog(self, refresh: bool) -> bool:
        """Makes self._catalog current; True when the mirrors were asked."""
        if self._catalog is not None and self._checked and not refresh:
            return False
        if self._catalog is None and not self._loaded_from_disk:
            self._loaded_from_disk = True
            self._load_from_disk()
        failures: List[_Failure] = []
        for mirror in self._mirrors:
            try:
                self._refresh_from(mirror)
            except _Failure as f:
                failures.append(f)
                continue
            self._checked = True
            self._offline = False
            return True
        why = "; ".join(f.message for f in failures) if failures else "no mirror is configured"
        if self._catalog is not None:
            if not self._offline:
                _log.warning(
                    "release: channel %s: no mirror answered, using the catalog %s kept in %s: %s",
                    self._channel, self._catalog_sha256, self._releases, why,
                )
            self._checked = True
            self._offline = True
            return True
        if not failures:
            raise ReleaseError(
                _Code.UNAVAILABLE,
                f"channel {self._channel}: no mirror is configured and no catalog is kept in {self._releases}",
            )
        code = _combined_code(failures)
        if code in (_Code.UNAVAILABLE, _Code.DEADLINE_EXCEEDED):
            why = f"no mirror answered and no catalog is kept in {self._releases}: {why}"
        raise ReleaseError(code, f"channel {self._channel}: {why}", failures=[f.message for f in failures])

    def _refresh_from(self, mirror: str) -> None:
        url = _join_url(mirror, channel_path(self._channel))
        etag = self._etags.get(mirror) if self._catalog is not None else None
        got = self._get_small(url, _MAX_CHANNEL_FILE_BYTES, etag)
        if got is None:
            return  # 304: the catalog in memory is current
        text, new_etag = got
        pointer = _parse_channel(text, url)
        if pointer.channel != self._channel:
            raise _Failure(_Code.DATA_LOSS, f'{url}: names channel "{_shown(pointer.channel)}"')
        if pointer.catalog_size_bytes > _MAX_CATALOG_BYTES:
            raise _invalid(url, f"catalog.size_bytes {pointer.catalog_size_bytes} is over {_MAX_CATALOG_BYTES}")
        if pointer.catalog_sha256 == self._catalog_sha256 and self._catalog_bytes is not None:
            catalog_bytes = self._catalog_bytes
            if self._verifier is not None:
                self._verifier.check(pointer.signature, catalog_bytes, url)
            catalog = self._catalog
        else:
            catalog_bytes, catalog = self._fetch_catalog(pointer, mirror)
        if new_etag:
            self._etags[mirror] = new_etag
        if pointer.catalog_sha256 != self._catalog_sha256 or text != self._channel_text:
            self._save(text, pointer.catalog_sha256, catalog_bytes)
            if pointer.catalog_sha256 != self._catalog_sha256:
                _log.info(
                    "release: channel %s: catalog %s (%d assets) from %s",
                    self._channel, pointer.catalog_sha256, len(catalog["assets"]) if catalog else 0, mirror,
                )
        self._catalog, self._catalog_bytes = catalog, catalog_bytes
        self._catalog_sha256, self._channel_text = pointer.catalog_sha256, text

    def _fetch_catalog(self, pointer: _Pointer, first: str) -> Tuple[bytes, Dict[str, Any]]:
        # The catalog's name is its digest: any mirror's copy will do, the
        # one that gave the channel file first.
        sha = pointer.catalog_sha256
        failures: List[_Failure] = []
        for mirror in [first] + [m for m in self._mirrors if m != first]:
            url = _join_url(mirror, catalog_path(sha))
            sink = io.BytesIO()
            try:
                self._read_verified(url, sha, pointer.catalog_size_bytes, sink, f"catalog {sha}")
            except _Failure as f:
                failures.append(f)
                continue
            data = sink.getvalue()
            # Verified bytes: every mirror has the same, so a refusal is final.
            if self._verifier is not None:
                self._verifier.check(pointer.signature, data, url)
            return data, _parse_catalog(data, url)
        raise _Failure(
            _combined_code(failures),
            f"catalog {sha} ({pointer.catalog_size_bytes} bytes): " + "; ".join(f.message for f in failures),
        )

    def _load_from_disk(self) -> None:
        channel_file = self._releases / "channels" / f"{self._channel}.json"
        try:
            text = channel_file.read_bytes()
        except OSError:
            return
        try:
            pointer = _parse_channel(text, str(channel_file))
            catalog_file = self._releases / "catalogs" / pointer.catalog_sha256
            data = catalog_file.read_bytes()
            if len(data) != pointer.catalog_size_bytes or hashlib.sha256(data).hexdigest() != pointer.catalog_sha256:
                raise _Failure(_Code.DATA_LOSS, f"{catalog_file}: does not match catalog {pointer.catalog_sha256}")
            if self._verifier is not None:
                self._verifier.check(pointer.signature, data, str(catalog_file))
            catalog = _parse_catalog(data, str(catalog_file))
        except (OSError, _Failure) as e:
            _log.warning("release: ignoring the channel %s kept on disk: %s", self._channel, e)
            return
        self._catalog, self._catalog_bytes = catalog, data
        self._catalog_sha256, self._channel_text = pointer.catalog_sha256, text

    def _save(self, channel_text: bytes, sha: str, catalog_bytes: bytes) -> None:
        # The catalog first: the channel file on disk always names a
        # catalog that is there.
        try:
            catalog_file = self._releases / "catalogs" / sha
            if not _file_matches(catalog_file, sha, len(catalog_bytes)):
                _write_atomically(catalog_file, catalog_bytes)
            _write_atomically(self._releases / "channels" / f"{self._channel}.json", channel_text)
        except OSError as e:
            # Not fatal: the catalog in memory serves; only offline starts lose it.
            _log.warning("release: cannot keep channel %s in %s: %s", self._channel, self._releases, e)

    # -- blobs ---------------------------------------------------------------

    def _download_blob(self, name: str, asset: Dict[str, Any], file_name: str, sha256: str, size: int) -> str:
        """cache_dir/blobs/<sha256> from the first mirror that gives it
        intact; the mirror's base URL."""
        self._blobs.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{sha256[:16]}.", suffix=".part", dir=self._blobs)
        try:
            failures: List[_Failure] = []
            served_by = ""
            with os.fdopen(fd, "w+b") as sink:
                for mirror in self._mirrors:
                    try:
                        self._read_verified(
                            _join_url(mirror, blob_path(sha256)), sha256, size, sink, f"blob {sha256}"
                        )
                    except _Failure as f:
                        failures.append(f)
                        continue
                    sink.flush()
                    os.fsync(sink.fileno())
                    served_by = mirror
                    break
            if not served_by:
                why = "; ".join(f.message for f in failures) if failures else "no mirror is configured"
                raise ReleaseError(
                    _combined_code(failures) if failures else _Code.UNAVAILABLE,
                    f'asset "{name}": file "{file_name}" (sha256 {sha256}, {size} bytes): '
                    f"no mirror gave it intact: {why}",
                    file=file_name,
                    digest=sha256,
                    asset=name,
                    cache_key=asset["cache_key"],
                    failures=[f.message for f in failures],
                )
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, self._blobs / sha256)
            return served_by
        except BaseException:
            _unlink_quietly(tmp)
            raise

    # -- HTTP ----------------------------------------------------------------

    def _open(self, url: str, headers: Dict[str, str]) -> Any:
        request = urllib.request.Request(
            url, headers={"User-Agent": _USER_AGENT, "Accept-Encoding": "identity", **headers}
        )
        return self._opener.open(request, timeout=self._timeout)

    def _connect_failure(self, url: str, error: urllib.error.URLError) -> _Failure:
        reason = error.reason
        if isinstance(reason, socket.timeout):
            return _Failure(_Code.DEADLINE_EXCEEDED, f"{url}: no answer for {self._timeout:g} s (stalled)")
        return _Failure(_Code.UNAVAILABLE, f"{url}: {reason}")

    def _get_small(self, url: str, limit: int, etag: Optional[str]) -> Optional[Tuple[bytes, Optional[str]]]:
        """The body of a small mutable file and its ETag; None for a 304."""
        headers = {"If-None-Match": etag} if etag else {}
        last = ""
        for _ in range(self._max_attempts):
            try:
                with self._open(url, headers) as response:
                    if response.status != 200:
                        raise _Failure(_Code.UNAVAILABLE, f"{url}: HTTP {response.status}")
                    data = bytearray()
                    while True:
                        chunk = _read_some(response)
                        if not chunk:
                            break
                        data += chunk
                        if len(data) > limit:
                            raise _invalid(url, f"more than {limit} bytes: not a channel file")
                    announced = response.headers.get("Content-Length")
                    if announced is not None and announced.strip().isdigit() and int(announced) != len(data):
                        last = f"{url}: the body ended after {len(data)} of {int(announced)} bytes"
                        continue
                    tag = response.headers.get("ETag")
                    return bytes(data), (tag if isinstance(tag, str) else None)
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

    def _read_verified(self, url: str, sha256: str, size: int, sink: BinaryIO, what: str) -> None:
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
