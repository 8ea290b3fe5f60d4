"""The files of a glTF model: the entry file and every buffer and image it
refers to by relative URI (the Python twin of client/transfer/mesh_files.cc), and
their digests."""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import struct
import urllib.parse
from pathlib import Path
from typing import Any, List, Set

import grpc

from .errors import ImpostorError

_GLB_MAGIC = 0x46546C67  # "glTF"
_GLB_JSON_CHUNK = 0x4E4F534A  # "JSON"
# The JSON of any sane glTF is far smaller; the cap keeps a corrupt length
# field from making us read gigabytes.
_MAX_JSON_BYTES = 256 << 20
_HASH_CHUNK_BYTES = 1 << 20


@dataclasses.dataclass(frozen=True)
class MeshFile:
    """One file of a model: its path relative to the entry's folder ('/'-separated;
    the entry's bare name for the entry itself), where it is, and its digest."""

    relative_path: str
    local_path: Path
    hash: str
    size_bytes: int


@dataclasses.dataclass(frozen=True)
class MeshFiles:
    """The entry file first, then the files it refers to, each once."""

    entry: MeshFile
    files: List[MeshFile]

    def all(self) -> List[MeshFile]:
        return [self.entry, *self.files]


def _invalid(message: str) -> ImpostorError:
    return ImpostorError(grpc.StatusCode.INVALID_ARGUMENT, message)


def digest_file(path: Path) -> "tuple[str, int]":
    """(lowercase hex SHA-256, size in bytes) of the file's contents."""
    sha = hashlib.sha256()
    size = 0
    with open(path, "rb") as f:
        while chunk := f.read(_HASH_CHUNK_BYTES):
            sha.update(chunk)
            size += len(chunk)
    return sha.hexdigest(), size


def _glb_json(model: Path) -> bytes:
    name = str(model)
    with open(model, "rb") as f:
        header = f.read(20)
        if len(header) < 20:
            raise _invalid(f"{name}: corrupt GLB header: file is {len(header)} bytes, shorter than a GLB header")
        magic, version, total, json_len, chunk_type = struct.unpack("<5I", header)
        if magic != _GLB_MAGIC:
            raise _invalid(f'{name}: corrupt GLB header: magic is not "glTF"')
        if version != 2:
            raise _invalid(f"{name}: corrupt GLB header: version {version}, only glTF 2 is supported")
        if chunk_type != _GLB_JSON_CHUNK:
            raise _invalid(f"{name}: corrupt GLB header: first chunk is not JSON")
        if json_len > _MAX_JSON_BYTES:
            raise _invalid(f"{name}: corrupt GLB header: JSON chunk length {json_len} is too large")
        if json_len + 20 > total:
            raise _invalid(
                f"{name}: corrupt GLB header: JSON chunk of {json_len} bytes overruns the declared length {total}"
            )
        data = f.read(json_len)
        if len(data) < json_len:
            raise _invalid(f"{name}: truncated GLB: JSON chunk of {json_len} bytes but the file ends first")
        return data


def _uri_to_relative_path(uri: str, user: str) -> str:
    quoted = f'{user} "{uri}"'
    # A scheme ("http:", "file:", or a Windows drive "C:") before any '/'.
    colon, slash = uri.find(":"), uri.find("/")
    if colon > 0 and uri[0].isalpha() and (slash < 0 or colon < slash):
        raise _invalid(f"{quoted}: absolute URIs are not supported; files must be relative to the model")
    decoded = urllib.parse.unquote(uri, errors="strict")
    if not decoded:
        raise _invalid(f"{quoted}: empty URI")
    if decoded[0] in "/\\":
        raise _invalid(f"{quoted}: absolute paths are not allowed")
    if "\\" in decoded:
        raise _invalid(f'{quoted}: "\\" is not allowed in paths')
    parts = []
    for part in decoded.split("/"):
        if part == "..":
            raise _invalid(f'{quoted}: ".." is not allowed; files must lie inside the model\'s directory')
        if part and part != ".":
            parts.append(part)
    path = "/".join(parts)
    if not path:
        raise _invalid(f"{quoted}: empty path")
    if len(path.encode()) > 1024:
        raise _invalid(f"{quoted}: path longer than 1024 bytes")
    return path


def _check_stays_inside(folder: Path, rel: str, follow: bool, user: str, model_name: str) -> None:
    if follow:
        return
    root = folder.resolve()
    resolved = (folder / rel).resolve()
    if resolved.is_relative_to(root) and resolved != root:
        return
    link = folder
    for part in Path(rel).parts:
        link = link / part
        if link.is_symlink() and not link.resolve().is_relative_to(root):
            raise ImpostorError(
                grpc.StatusCode.PERMISSION_DENIED,
                f"{link} ({user} of {model_name}) is a symbolic link to {os.readlink(link)}, outside the "
                f"model's folder {root}; pass follow_symlinks=True to upload it anyway",
            )
    raise ImpostorError(
        grpc.StatusCode.PERMISSION_DENIED,
        f"{folder / rel} ({user} of {model_name}) resolves to {resolved}, outside the model's folder {root}",
    )


def _mesh_file(relative_path: str, local_path: Path) -> MeshFile:
    digest, size = digest_file(local_path)
    return MeshFile(relative_path, local_path, digest, size)


def collect_mesh_files(model: "str | os.PathLike[str]", follow_symlinks: bool = False) -> MeshFiles:
    """Reads the model's glTF JSON and hashes it and every file it refers to.

    Raises ImpostorError: NOT_FOUND (the model or a file it refers to is
    missing), INVALID_ARGUMENT (not a .gltf/.glb, malformed glTF, a URI that
    is absolute or leaves the model's folder), PERMISSION_DENIED (a symbolic
    link out of the folder without follow_symlinks).
    """
    path = Path(model)
    name = str(path)
    if not path.exists():
        raise ImpostorError(grpc.StatusCode.NOT_FOUND, f"model {name} not found")
    if not path.is_file():
        raise _invalid(f"model {name} is not a regular file")
    ext = path.suffix.lower()
    if ext not in (".gltf", ".glb"):
        raise _invalid(f'model {name}: expected a .gltf or .glb file, got "{ext}"')
    if ext == ".glb":
        text = _glb_json(path)
    else:
        if path.stat().st_size > _MAX_JSON_BYTES:
            raise _invalid(f"{name}: glTF JSON of {path.stat().st_size} bytes is too large")
        text = path.read_bytes()
    try:
        gltf: Any = json.loads(text)
    except (ValueError, UnicodeDecodeError):
        raise _invalid(f"{name}: invalid JSON") from None
    if not isinstance(gltf, dict):
        raise _invalid(f"{name}: glTF JSON is not an object")

    folder = path.parent
    seen: Set[str] = set()
    files: List[MeshFile] = []
    for array_name in ("buffers", "images"):
        items = gltf.get(array_name)
        if items is None:
            continue
        if not isinstance(items, list):
            raise _invalid(f'{name}: "{array_name}" is not an array')
        for i, item in enumerate(items):
            user = f"{array_name}[{i}].uri"
            if not isinstance(item, dict):
                raise _invalid(f"{name}: {array_name}[{i}] is not an object")
            uri = item.get("uri")
            if uri is None:
                continue  # GLB buffer 0 or an image in a bufferView
            if not isinstance(uri, str):
                raise _invalid(f"{name}: {user} is not a string")
            if uri.startswith("data:"):
                continue  # embedded
            rel = _uri_to_relative_path(uri, user)
            if rel in seen:
                continue  # several users of one file
            seen.add(rel)
            local = folder / rel
            if not local.is_file():
                raise ImpostorError(
                    grpc.StatusCode.NOT_FOUND, f'file {local} not found (used by {user} "{uri}" of {name})'
                )
            _check_stays_inside(folder, rel, follow_symlinks, user, name)
            files.append(_mesh_file(rel, local))
    return MeshFiles(_mesh_file(path.name, path), files)
