"""Release trees and mirrors for the impostor.release tests (test_release*.py).

A small writer here lays out release trees exactly as
client/delivery/release_format.md says (blobs and the catalog by SHA-256,
the catalog as canonical JSON, the channel file last); http.server serves
them on 127.0.0.1 as mirrors, the first one faulty where a test says so (a
flipped byte, an HTML 200 page, a truncated body, a stall, a 404, ...).
The fixtures (release, mirrors, _no_proxy) are imported by the test files.
"""
from __future__ import annotations

import base64
import hashlib
import http.server
import json
import os
import random
import socket
import ssl
import threading
import urllib.parse
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Tuple

import pytest

from impostor.release import FetchedAsset, ReleaseClient

# Short, so that a stalled mirror costs little; a stall in the tests lasts
# STALL_S, well past it.
TIMEOUT_S = 1.0
STALL_S = 5.0
CHANNEL = "nightly"
OAK = "trees/oak"
ROCK = "rocks/granite"


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def canonical_json(value: Any) -> bytes:
    """nlohmann::json dump(): keys sorted, no whitespace, UTF-8."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False).encode("utf-8")


# ---------------------------------------------------------------------------
# A release tree writer (release_format.md, format 1)


class ReleaseTree:
    """Writes a release tree under `root` as `impostor publish` does."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.rng = random.Random(40)

    def _write(self, rel: str, data: bytes) -> None:
        path = self.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_bytes(data)
        os.replace(tmp, path)

    def put_blob(self, data: bytes) -> str:
        hex_ = sha256(data)
        path = f"v1/blobs/sha256/{hex_[:2]}/{hex_}"
        if not (self.root / path).exists():
            self._write(path, data)
        return hex_

    def asset(self, sizes: Dict[str, int], *, seed: int = 0) -> Dict[str, Any]:
        """A catalog entry for a result with random files of these sizes,
        plus its manifest.json; every blob written."""
        rng = random.Random(seed)
        cache_key = sha256(f"result {seed} {sorted(sizes.items())}".encode())
        files: List[Dict[str, Any]] = []
        maps: List[Dict[str, Any]] = []
        for name, size in sizes.items():
            data = rng.randbytes(size)
            hex_ = self.put_blob(data)
            semantic = name.rsplit(".", 1)[0]
            media = {"png": "image/png", "ktx2": "image/ktx2", "glb": "model/gltf-binary"}.get(
                name.rsplit(".", 1)[-1], "application/octet-stream")
            files.append({"name": name, "semantic": semantic, "sha256": hex_, "size_bytes": size,
                          "media_type": media, "width": 256, "height": 256, "format": "png_rgba8"})
            maps.append({"semantic": semantic, "file": name, "digest": {"hash": hex_, "size_bytes": size}})
        manifest = json.dumps({"cache_key": cache_key, "layout": "hemi-octahedral", "frames": 12,
                               "resolution": 256, "maps": maps}, indent=2).encode()
        manifest_hex = self.put_blob(manifest)
        files.append({"name": "manifest.json", "semantic": "manifest", "sha256": manifest_hex,
                      "size_bytes": len(manifest), "media_type": "application/json", "width": 0, "height": 0,
                      "format": "json"})
        return {"cache_key": cache_key, "product": "atlas", "layout": "hemi-octahedral", "frames": 12,
                "resolution": 256, "baker_version": "0.2.0-test",
                "manifest": {"sha256": manifest_hex, "size_bytes": len(manifest)}, "files": files}

    def catalog_bytes(self, assets: Dict[str, Any], *, schema_version: int = 1) -> bytes:
        return canonical_json({"schema": "impostor-catalog", "schema_version": schema_version,
                               "created_at": "2026-12-02T01:02:03Z", "baker_version": "0.2.0-test",
                               "assets": assets})

    def put_catalog(self, data: bytes) -> str:
        hex_ = sha256(data)
        self._write(f"v1/catalogs/sha256/{hex_[:2]}/{hex_}", data)
        return hex_

    def set_channel(self, channel: str, catalog: bytes, *, signature: Optional[Dict[str, str]] = None,
                    schema_version: int = 1) -> None:
        """The channel file, last and by rename, naming `catalog`'s digest."""
        pointer: Dict[str, Any] = {"schema": "impostor-channel", "schema_version": schema_version,
                                   "channel": channel,
                                   "catalog": {"sha256": sha256(catalog), "size_bytes": len(catalog)},
                                   "published_at": "2026-12-02T01:02:03Z"}
        if signature is not None:
            pointer["signature"] = signature
        self._write(f"v1/channels/{channel}.json",
                    (json.dumps(pointer, sort_keys=True, indent=2) + "\n").encode())

    def publish(self, assets: Dict[str, Any], channel: str = CHANNEL, *, sign_key: Any = None,
                schema_version: int = 1, catalog_schema_version: int = 1) -> bytes:
        """Blobs are in place (asset() wrote them); the catalog, then the
        channel. Returns the catalog's bytes."""
        catalog = self.catalog_bytes(assets, schema_version=catalog_schema_version)
        self.put_catalog(catalog)
        signature = sign(sign_key, catalog) if sign_key is not None else None
        self.set_channel(channel, catalog, signature=signature, schema_version=schema_version)
        return catalog


def key_id(private_key: Any) -> str:
    from cryptography.hazmat.primitives import serialization
    raw = private_key.public_key().public_bytes(serialization.Encoding.Raw, serialization.PublicFormat.Raw)
    return sha256(raw)[:16]


def sign(private_key: Any, catalog: bytes) -> Dict[str, str]:
    return {"algorithm": "ed25519", "key_id": key_id(private_key),
            "value": base64.b64encode(private_key.sign(catalog)).decode()}


def public_pem(private_key: Any) -> bytes:
    from cryptography.hazmat.primitives import serialization
    return private_key.public_key().public_bytes(serialization.Encoding.PEM,
                                                 serialization.PublicFormat.SubjectPublicKeyInfo)


# ---------------------------------------------------------------------------
# Mirrors: http.server over a release root, with faults by path

HTML_PAGE = (b"<!DOCTYPE html><html><head><title>503</title></head>"
             b"<body><h1>Service temporarily unavailable</h1></body></html>\n")


class Mirror:
    """Serves `root` at http://127.0.0.1:PORT/releases/ (Range, ETag/304).

    faults maps a path under the root ("v1/blobs/...") to what goes wrong:
      "flip"          one byte flipped, status and length right
      "html"          200 with an HTML page
      "truncate"      the file holds half its bytes; Content-Length claims
                      all (a lie) and the connection closes early
      "early_close"   the file holds half its bytes, sent without a
                      Content-Length, then the connection closes
      "stall"         headers, then no byte for STALL_S
      "404", "500"    that status
      "cut"           once: half the body, then the connection closes;
                      served right afterwards (Range honoured)
      "cut_no_range"  once: as "cut"; afterwards Range is ignored (200)
    log: (path, Range header, If-None-Match header, status) per request.
    """

    def __init__(self, root: Path, ssl_context: Optional[ssl.SSLContext] = None) -> None:
        self.root = root
        self.faults: Dict[str, str] = {}
        self.log: List[Tuple[str, str, str, int]] = []
        self.released = threading.Event()
        self._lock = threading.Lock()
        mirror = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, format: str, *args: Any) -> None:
                pass

            def do_GET(self) -> None:
                try:
                    mirror._serve(self)
                except (BrokenPipeError, ConnectionResetError, ssl.SSLError):
                    pass

        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        scheme = "http"
        if ssl_context is not None:
            self.httpd.socket = ssl_context.wrap_socket(self.httpd.socket, server_side=True)
            scheme = "https"
        self.port = self.httpd.server_address[1]
        self.url = f"{scheme}://127.0.0.1:{self.port}/releases"
        self._thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.05},
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        if self._thread.is_alive():
            self.released.set()
            self.httpd.shutdown()
            self.httpd.server_close()
            self._thread.join()

    def requests(self, rel: str) -> List[Tuple[str, str, str, int]]:
        with self._lock:
            return [entry for entry in self.log if entry[0] == rel]

    def blob_requests(self) -> List[Tuple[str, str, str, int]]:
        with self._lock:
            return [entry for entry in self.log if entry[0].startswith("v1/blobs/")]

    def _note(self, h: http.server.BaseHTTPRequestHandler, rel: str, status: int) -> None:
        with self._lock:
            self.log.append((rel, h.headers.get("Range") or "", h.headers.get("If-None-Match") or "", status))

    def _serve(self, h: http.server.BaseHTTPRequestHandler) -> None:
        path = urllib.parse.unquote(urllib.parse.urlsplit(h.path).path)
        rel = path[len("/releases/"):] if path.startswith("/releases/") else ""
        with self._lock:
            fault = self.faults.get(rel, "")
            if fault == "cut":
                del self.faults[rel]
            elif fault == "cut_no_range":
                self.faults[rel] = "no_range"
        file = (self.root / rel).resolve()
        if not rel or self.root.resolve() not in file.parents or not file.is_file() or fault == "404":
            self._note(h, rel, 404)
            h.send_error(404)
            return
        if fault == "500":
            self._note(h, rel, 500)
            h.send_error(500)
            return
        data = file.read_bytes()
        if fault == "html":
            self._note(h, rel, 200)
            h.send_response(200)
            h.send_header("Content-Type", "text/html; charset=utf-8")
            h.send_header("Content-Length", str(len(HTML_PAGE)))
            h.end_headers()
            h.wfile.write(HTML_PAGE)
            return
        if fault == "flip":
            flipped = bytearray(data)
            flipped[len(flipped) // 2] ^= 0x01
            data = bytes(flipped)
        etag = f'"{sha256(data)}"'
        if h.headers.get("If-None-Match") == etag:
            self._note(h, rel, 304)
            h.send_response(304)
            h.send_header("ETag", etag)
            h.end_headers()
            return
        full_size = len(data)
        if fault in ("truncate", "early_close"):
            data = data[: len(data) // 2]
        start = 0
        ranged = h.headers.get("Range", "")
        if ranged.startswith("bytes=") and ranged.endswith("-") and fault != "no_range":
            start = int(ranged[len("bytes="):-1])
            if start >= len(data):
                self._note(h, rel, 416)
                h.send_response(416)
                h.send_header("Content-Range", f"bytes */{len(data)}")
                h.send_header("Content-Length", "0")
                h.end_headers()
                return
        status = 206 if start > 0 else 200
        self._note(h, rel, status)
        h.send_response(status)
        h.send_header("Content-Type", "application/json" if rel.startswith("v1/channels/")
                      else "application/octet-stream")
        h.send_header("Accept-Ranges", "bytes")
        h.send_header("ETag", etag)
        if status == 206:
            h.send_header("Content-Range", f"bytes {start}-{len(data) - 1}/{len(data)}")
        body = data[start:]
        if fault == "truncate":
            h.send_header("Content-Length", str(full_size - start))  # the lie
        elif fault != "early_close":
            h.send_header("Content-Length", str(len(body)))
        h.end_headers()
        if fault == "stall":
            h.wfile.flush()
            self.released.wait(STALL_S)
            return
        if fault in ("cut", "cut_no_range"):
            h.wfile.write(body[: len(body) // 2])
            h.wfile.flush()
            h.close_connection = True
            h.connection.shutdown(socket.SHUT_RDWR)
            return
        h.wfile.write(body)


# ---------------------------------------------------------------------------
# Fixtures

OAK_FILES = {
    "albedo_alpha.png": 150_000,   # several 64 KiB chunks: cuts land mid-file
    "normal_depth.png": 90_000,
    "orm.png": 40_000,
    "albedo_alpha.ktx2": 30_000,
    "normal_depth.ktx2": 20_000,
    "lod1.glb": 12_000,
    "lod2.glb": 8_000,
    "cards.bin": 5_000,
    "tiny.bin": 1,
    "empty.bin": 0,
}


class Release:
    def __init__(self, root: Path) -> None:
        self.tree = ReleaseTree(root)
        self.assets = {OAK: self.tree.asset(OAK_FILES, seed=1),
                       ROCK: self.tree.asset({"albedo_alpha.png": 30_000, "normal_depth.png": 9_000}, seed=2)}
        self.catalog = self.tree.publish(self.assets)

    @property
    def catalog_sha256(self) -> str:
        return sha256(self.catalog)

    def file(self, asset: str, name: str) -> Dict[str, Any]:
        return next(f for f in self.assets[asset]["files"] if f["name"] == name)

    def blob_rel(self, asset: str, name: str) -> str:
        hex_ = self.file(asset, name)["sha256"]
        return f"v1/blobs/sha256/{hex_[:2]}/{hex_}"

    def catalog_rel(self) -> str:
        h = self.catalog_sha256
        return f"v1/catalogs/sha256/{h[:2]}/{h}"


@pytest.fixture(autouse=True)
def _no_proxy(monkeypatch: pytest.MonkeyPatch) -> None:
    # urllib honours http_proxy; the mirrors are local.
    for name in ("no_proxy", "NO_PROXY"):
        monkeypatch.setenv(name, "127.0.0.1,localhost")


@pytest.fixture
def release(tmp_path: Path) -> Release:
    return Release(tmp_path / "release")


@pytest.fixture
def mirrors(release: Release) -> Iterator[Tuple[Mirror, Mirror]]:
    """Two mirrors of the same tree: (first, second)."""
    first, second = Mirror(release.tree.root), Mirror(release.tree.root)
    yield first, second
    first.stop()
    second.stop()


def client(mirror_list: List[Mirror], cache: Path, **kwargs: Any) -> ReleaseClient:
    kwargs.setdefault("timeout_seconds", TIMEOUT_S)
    return ReleaseClient([m.url for m in mirror_list], CHANNEL, cache, **kwargs)


def assert_verified(fetched: FetchedAsset, release: Release, asset: str) -> None:
    """out_dir holds exactly the asset's files, each with its digest."""
    entry = release.assets[asset]
    assert list(fetched.files) == [f["name"] for f in entry["files"]]
    for f in entry["files"]:
        path = fetched.files[f["name"]]
        assert path == fetched.dir / f["name"]
        data = path.read_bytes()
        assert len(data) == f["size_bytes"] and sha256(data) == f["sha256"], f["name"]
    assert fetched.manifest == fetched.dir / "manifest.json"
    assert fetched.cache_key == entry["cache_key"]
    assert no_partials(fetched.dir)


def no_partials(*dirs: Path) -> bool:
    return not [p for d in dirs if d.exists() for p in d.rglob("*") if p.name.endswith(".part")]
