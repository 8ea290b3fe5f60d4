"""The release format's names and documents, for impostor.release: asset and
channel names, the paths of a release tree, the channel file and catalog
parsers (untrusted documents: every field checked) and the catalog's
Ed25519 signature check (client/delivery/release_format.md). No I/O.
"""
from __future__ import annotations

import base64
import binascii
import dataclasses
import hashlib
import json
import re
import urllib.parse
from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Type, Union

import grpc

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

_HEX = re.compile(r"[0-9a-f]{64}\Z")
_ASSET_NAME_CHARS = re.compile(r"[A-Za-z0-9._/-]+\Z")
_CHANNEL_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*\Z")

_Code = grpc.StatusCode


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
# One source's failure (impostor.release turns them into a ReleaseError)


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

