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

The format's names, parsers and signature check are in _release_catalog,
the HTTP reads in _release_http, the files on disk in _release_files.
"""
from __future__ import annotations

import copy
import dataclasses
import hashlib
import io
import logging
import os
import ssl
import tempfile
import threading
import urllib.request
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import grpc

# The format's public names, defined in _release_catalog, are this module's
# as before (`from impostor.release import validate_asset_name`).
from ._release_catalog import (
    CATALOG_SCHEMA_VERSION,
    CHANNEL_SCHEMA_VERSION,
    MAX_ASSET_NAME_LENGTH as MAX_ASSET_NAME_LENGTH,
    MAX_CHANNEL_NAME_LENGTH as MAX_CHANNEL_NAME_LENGTH,
    blob_path,
    catalog_path,
    channel_path,
    validate_asset_name,
    validate_channel_name,
)
from ._release_catalog import (
    _HEX,
    _MAX_CATALOG_BYTES,
    _MAX_CHANNEL_FILE_BYTES,
    _check_mirror,
    _combined_code,
    _Ed25519Verifier,
    _Failure,
    _invalid,
    _join_url,
    _parse_catalog,
    _parse_channel,
    _Pointer,
    _shown,
)
from ._release_files import _file_matches, _install_copy, _umask, _unlink_quietly, _write_atomically
from ._release_http import _MirrorReader, _Redirects
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

_Code = grpc.StatusCode
PathLike = Union[str, "os.PathLike[str]"]


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
        if isinstance(max_attempts, bool) or not isinstance(max_attempts, int) or max_attempts < 1:
            raise ValueError(f"max_attempts: expected a whole number >= 1, not {max_attempts!r}")
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
        self._http = _MirrorReader(urllib.request.build_opener(*handlers), float(timeout_seconds), max_attempts)

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
        got = self._http.get_small(url, _MAX_CHANNEL_FILE_BYTES, etag)
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
                self._http.read_verified(url, sha, pointer.catalog_size_bytes, sink, f"catalog {sha}")
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
                        self._http.read_verified(
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
