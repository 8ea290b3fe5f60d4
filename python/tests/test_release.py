"""impostor.release: fetching impostors by asset name from published release
trees over HTTP, no farm.

A small writer here lays out release trees exactly as
client/delivery/release_format.md says (blobs and the catalog by SHA-256,
the catalog as canonical JSON, the channel file last); http.server serves
them on 127.0.0.1 as mirrors, the first one faulty where a test says so (a
flipped byte, an HTML 200 page, a truncated body, a stall, a 404, ...).
Every test asserts on verified bytes: what lands in out_dir hashes to the
catalog's digest, and nothing else lands there.
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
import subprocess
import threading
import time
import urllib.parse
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Tuple

import grpc
import pytest

import impostor
from impostor.release import FetchedAsset, ReleaseClient, ReleaseError

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


# ---------------------------------------------------------------------------
# Fetching by name


def test_fetch_by_name_verifies_every_file_and_a_second_fetch_downloads_nothing(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path) -> None:
    first, _ = mirrors
    cache = tmp_path / "cache"
    c = client([first], cache)

    catalog = c.catalog()
    assert set(catalog["assets"]) == {OAK, ROCK}
    assert c.catalog_sha256 == release.catalog_sha256 and not c.offline
    # Kept under cache_dir/releases, as served.
    assert (cache / "releases" / "channels" / f"{CHANNEL}.json").read_bytes() == \
        (release.tree.root / "v1/channels/nightly.json").read_bytes()
    assert (cache / "releases" / "catalogs" / release.catalog_sha256).read_bytes() == release.catalog

    oak = c.fetch(OAK, tmp_path / "out")
    assert_verified(oak, release, OAK)
    assert oak.name == OAK and oak.catalog_sha256 == release.catalog_sha256
    assert oak.downloaded_bytes == sum(f["size_bytes"] for f in release.assets[OAK]["files"])
    assert oak.downloaded_files == len(OAK_FILES) + 1
    assert set(oak.sources.values()) == {first.url}
    assert json.loads(oak.manifest.read_bytes())["cache_key"] == oak.cache_key
    for f in release.assets[OAK]["files"]:
        assert sha256((cache / "blobs" / f["sha256"]).read_bytes()) == f["sha256"]
    # Each blob was asked for once (the two empty/tiny files included).
    assert len(first.blob_requests()) == len(OAK_FILES) + 1

    # Again into the same folder: every file is already there.
    first.log.clear()
    again = c.fetch(OAK, tmp_path / "out")
    assert_verified(again, release, OAK)
    assert again.downloaded_bytes == 0 and set(again.sources.values()) == {"out_dir"}
    # By cache key into another folder: from cache_dir/blobs.
    by_key = c.fetch(oak.cache_key, tmp_path / "other")
    assert_verified(by_key, release, OAK)
    assert by_key.name == OAK and by_key.downloaded_bytes == 0 and set(by_key.sources.values()) == {"cache"}
    assert first.blob_requests() == []
    # A file changed in out_dir is replaced; a damaged cache blob is fetched anew.
    (tmp_path / "out" / "orm.png").write_bytes(b"edited")
    orm = release.file(OAK, "orm.png")
    (cache / "blobs" / orm["sha256"]).write_bytes(b"rotten")
    fixed = c.fetch(OAK, tmp_path / "out")
    assert_verified(fixed, release, OAK)
    assert fixed.sources["orm.png"] == first.url and fixed.downloaded_bytes == orm["size_bytes"]

    # A name the catalog lacks.
    with pytest.raises(ReleaseError) as e:
        c.fetch("trees/birch", tmp_path / "birch")
    assert e.value.code == grpc.StatusCode.NOT_FOUND and "trees/birch" in str(e.value)
    assert isinstance(e.value, impostor.ImpostorError)


def test_a_faulty_first_mirror_leaves_each_file_to_the_second(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path) -> None:
    first, second = mirrors
    faults = {"albedo_alpha.png": "flip", "normal_depth.png": "html", "orm.png": "truncate",
              "albedo_alpha.ktx2": "early_close", "normal_depth.ktx2": "stall", "lod1.glb": "404",
              "lod2.glb": "500"}
    for name, fault in faults.items():
        first.faults[release.blob_rel(OAK, name)] = fault
    c = client([first, second], tmp_path / "cache")

    started = time.monotonic()
    oak = c.fetch(OAK, tmp_path / "out")
    assert time.monotonic() - started < 10 * TIMEOUT_S
    assert_verified(oak, release, OAK)
    for name in OAK_FILES:
        rel = release.blob_rel(OAK, name)
        if name in faults:
            # The first mirror was tried, the second gave it, once, whole.
            assert first.requests(rel), name
            assert oak.sources[name] == second.url, name
            assert [(r[1], r[3]) for r in second.requests(rel)] == [("", 200)], name
        else:
            assert oak.sources[name] == first.url and second.requests(rel) == [], name
    assert oak.sources["manifest.json"] == first.url
    # The truncated ones were asked for the rest, which the mirror lacked.
    assert [r[3] for r in first.requests(release.blob_rel(OAK, "orm.png"))] == [200, 416]
    assert [r[3] for r in first.requests(release.blob_rel(OAK, "albedo_alpha.ktx2"))] == [200, 416]
    # The stall cost one timeout, not max_attempts of them.
    assert len(first.requests(release.blob_rel(OAK, "normal_depth.ktx2"))) == 1
    assert no_partials(tmp_path / "cache", tmp_path / "out")


def test_a_cut_transfer_resumes_with_range_on_the_same_mirror(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path) -> None:
    first, second = mirrors
    cut = release.blob_rel(OAK, "albedo_alpha.png")
    cut_no_range = release.blob_rel(OAK, "normal_depth.png")
    first.faults[cut] = "cut"
    first.faults[cut_no_range] = "cut_no_range"

    oak = client([first, second], tmp_path / "cache").fetch(OAK, tmp_path / "out")
    assert_verified(oak, release, OAK)
    assert second.blob_requests() == []
    size = release.file(OAK, "albedo_alpha.png")["size_bytes"]
    log = first.requests(cut)
    assert len(log) == 2 and log[0][1:] == ("", "", 200) and log[1][3] == 206
    resumed_at = int(log[1][1][len("bytes="):-1])
    assert 0 < resumed_at < size
    # A mirror that ignores Range on the resume: its whole file, from zero.
    log = first.requests(cut_no_range)
    assert len(log) == 2 and log[1][1].startswith("bytes=") and log[1][3] == 200


@pytest.mark.parametrize("target,fault", [
    ("channel", "404"), ("channel", "html"), ("channel", "stall"),
    ("catalog", "flip"), ("catalog", "html"), ("catalog", "truncate"),
])
def test_the_channel_and_catalog_come_from_the_next_mirror(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path, target: str, fault: str) -> None:
    first, second = mirrors
    rel = "v1/channels/nightly.json" if target == "channel" else release.catalog_rel()
    first.faults[rel] = fault
    c = client([first, second], tmp_path / "cache")
    assert set(c.catalog()["assets"]) == {OAK, ROCK}
    assert c.catalog_sha256 == release.catalog_sha256 and not c.offline
    assert second.requests(release.catalog_rel())
    assert_verified(c.fetch(ROCK, tmp_path / "out"), release, ROCK)


# ---------------------------------------------------------------------------
# No mirror left


@pytest.mark.parametrize("fault,code", [
    ("flip", grpc.StatusCode.DATA_LOSS),
    ("html", grpc.StatusCode.DATA_LOSS),
    ("truncate", grpc.StatusCode.DATA_LOSS),
    ("early_close", grpc.StatusCode.DATA_LOSS),
    ("404", grpc.StatusCode.NOT_FOUND),
    ("500", grpc.StatusCode.UNAVAILABLE),
    ("stall", grpc.StatusCode.DEADLINE_EXCEEDED),
])
def test_with_only_a_faulty_mirror_the_error_names_file_digest_and_mirror(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path, fault: str,
        code: grpc.StatusCode) -> None:
    first, _ = mirrors
    bad = release.file(OAK, "normal_depth.png")
    first.faults[release.blob_rel(OAK, "normal_depth.png")] = fault
    out = tmp_path / "out"
    with pytest.raises(ReleaseError) as e:
        client([first], tmp_path / "cache").fetch(OAK, out)
    error = e.value
    assert error.code == code
    message = str(error)
    assert "normal_depth.png" in message and bad["sha256"] in message and first.url in message
    assert error.file == "normal_depth.png" and error.digest == bad["sha256"] and error.asset == OAK
    assert len(error.failures) == 1 and error.failures[0].startswith(first.url)
    # Nothing unverified landed: not in out_dir, not in the cache.
    assert not (out / "normal_depth.png").exists()
    assert not (tmp_path / "cache" / "blobs" / bad["sha256"]).exists()
    assert no_partials(out, tmp_path / "cache")
    # What came before it did land, verified.
    good = release.file(OAK, "albedo_alpha.png")
    assert sha256((out / "albedo_alpha.png").read_bytes()) == good["sha256"]


def test_every_mirror_failing_names_each_failure(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path) -> None:
    first, second = mirrors
    rel = release.blob_rel(OAK, "lod1.glb")
    first.faults[rel] = "flip"
    second.faults[rel] = "404"
    with pytest.raises(ReleaseError) as e:
        client([first, second], tmp_path / "cache").fetch(OAK, tmp_path / "out")
    assert e.value.code == grpc.StatusCode.DATA_LOSS
    digest = release.file(OAK, "lod1.glb")["sha256"]
    assert "lod1.glb" in str(e.value) and digest in str(e.value)
    assert "hash to" in e.value.failures[0] and e.value.failures[0].startswith(first.url)
    assert "404" in e.value.failures[1] and e.value.failures[1].startswith(second.url)
    assert not (tmp_path / "out" / "lod1.glb").exists()


# ---------------------------------------------------------------------------
# Offline


def test_offline_a_fresh_client_resolves_names_and_serves_cached_files(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path) -> None:
    first, second = mirrors
    cache = tmp_path / "cache"
    fetched = client([first, second], cache).fetch(OAK, tmp_path / "game1")
    assert fetched.downloaded_bytes > 0
    first.stop()
    second.stop()

    later = client([first, second], cache)
    assert set(later.catalog()["assets"]) == {OAK, ROCK}
    assert later.offline and later.catalog_sha256 == release.catalog_sha256
    oak = later.fetch(OAK, tmp_path / "game2")
    assert_verified(oak, release, OAK)
    assert oak.offline and oak.downloaded_bytes == 0 and set(oak.sources.values()) == {"cache"}
    # A name resolves offline, but files never fetched cannot be served.
    with pytest.raises(ReleaseError) as e:
        later.fetch(ROCK, tmp_path / "rock")
    assert e.value.code == grpc.StatusCode.UNAVAILABLE and e.value.file == "albedo_alpha.png"
    assert first.url in str(e.value) and second.url in str(e.value)
    # A client that never saw the channel has nothing to fall back on.
    with pytest.raises(ReleaseError) as e:
        client([first, second], tmp_path / "empty").catalog()
    assert e.value.code == grpc.StatusCode.UNAVAILABLE
    assert first.url in str(e.value) and second.url in str(e.value)


# ---------------------------------------------------------------------------
# The channel over time


def test_the_channel_is_revalidated_by_etag_and_follows_a_new_publish(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path) -> None:
    first, _ = mirrors
    cache = tmp_path / "cache"
    c = client([first], cache)
    c.catalog()
    c.catalog()  # from memory
    assert len(first.requests("v1/channels/nightly.json")) == 1
    c.catalog(refresh=True)
    log = first.requests("v1/channels/nightly.json")
    assert len(log) == 2 and log[1][2] and log[1][3] == 304
    assert len(first.requests(release.catalog_rel())) == 1

    # A new publish: a third asset.
    assets = dict(release.assets, **{"props/crate": release.tree.asset({"albedo_alpha.png": 3_000}, seed=3)})
    catalog = release.tree.publish(assets)
    assert "props/crate" in c.catalog(refresh=True)["assets"]
    assert c.catalog_sha256 == sha256(catalog)
    assert (cache / "releases" / "catalogs" / sha256(catalog)).read_bytes() == catalog
    assert json.loads((cache / "releases" / "channels" / "nightly.json").read_bytes())["catalog"]["sha256"] == \
        sha256(catalog)
    # A client that has the old catalog in memory finds a new name by refreshing.
    stale = client([first], tmp_path / "cache2")
    stale.catalog()
    assets["props/barrel"] = release.tree.asset({"albedo_alpha.png": 2_000}, seed=4)
    release.tree.publish(assets)
    barrel = stale.fetch("props/barrel", tmp_path / "barrel")
    assert barrel.name == "props/barrel" and barrel.downloaded_files == 2


@pytest.mark.parametrize("which", ["channel", "catalog"])
def test_a_newer_schema_version_is_refused_naming_both(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path, which: str) -> None:
    first, _ = mirrors
    if which == "channel":
        release.tree.publish(release.assets, schema_version=2)
    else:
        release.tree.publish(release.assets, catalog_schema_version=2)
    with pytest.raises(ReleaseError) as e:
        client([first], tmp_path / "cache").catalog()
    assert e.value.code == grpc.StatusCode.FAILED_PRECONDITION
    assert "schema_version 2" in str(e.value) and "(1)" in str(e.value)


# ---------------------------------------------------------------------------
# Signatures


def test_a_signed_catalog_verifies_and_a_tampered_one_is_refused(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path) -> None:
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    key, other = Ed25519PrivateKey.generate(), Ed25519PrivateKey.generate()
    first, _ = mirrors
    good = release.tree.publish(release.assets, sign_key=key)
    cache = tmp_path / "cache"
    signed = client([first], cache, public_key_pem=public_pem(key))
    assert signed.catalog_sha256 == ""
    assert_verified(signed.fetch(OAK, tmp_path / "out"), release, OAK)
    assert signed.catalog_sha256 == sha256(good)

    def refused(cache_dir: Path, pem: bytes = public_pem(key)) -> ReleaseError:
        with pytest.raises(ReleaseError) as e:
            client([first], cache_dir, public_key_pem=pem).catalog()
        assert e.value.code == grpc.StatusCode.PERMISSION_DENIED, e.value
        return e.value

    # Another key's signature.
    assert key_id(key) in str(refused(tmp_path / "c1", public_pem(other)))
    # Tampered: a catalog that says something else, under the old signature.
    evil_assets = json.loads(good)["assets"]
    evil_assets[OAK]["files"][0]["sha256"] = evil_assets[ROCK]["files"][0]["sha256"]
    evil_assets[OAK]["files"][0]["size_bytes"] = evil_assets[ROCK]["files"][0]["size_bytes"]
    evil = release.tree.catalog_bytes(evil_assets)
    release.tree.put_catalog(evil)
    old_signature = json.loads((release.tree.root / "v1/channels/nightly.json").read_bytes())["signature"]
    release.tree.set_channel(CHANNEL, evil, signature=old_signature)
    assert "does not verify" in str(refused(tmp_path / "c2"))
    # Unsigned.
    release.tree.set_channel(CHANNEL, evil)
    assert "not signed" in str(refused(tmp_path / "c3"))
    # A client that verified a catalog before keeps it rather than take a bad one.
    kept = client([first], cache, public_key_pem=public_pem(key))
    assert kept.catalog()["assets"][OAK] == json.loads(good)["assets"][OAK]
    assert kept.offline and kept.catalog_sha256 == sha256(good)
    # Without a key the signature is not looked at.
    unchecked = client([first], tmp_path / "c4")
    unchecked.catalog()
    assert unchecked.catalog_sha256 == sha256(evil)


# ---------------------------------------------------------------------------
# Bad input


@pytest.mark.parametrize("name,words", [
    ("../etc/passwd", ". or .. segment"),
    ("trees/../../x", ". or .. segment"),
    ("/abs/oak", "must not start with /"),
    ("trees//oak", "empty segment"),
    ("trees/oak/", "must not end with /"),
    ("", "must not be empty"),
    ("trees\\oak", "may hold only"),
    ("x" * 201, "the limit is 200"),
])
def test_bad_asset_names_are_refused_naming_the_field(tmp_path: Path, name: str, words: str) -> None:
    c = ReleaseClient(["http://127.0.0.1:9"], CHANNEL, tmp_path / "cache")
    with pytest.raises(ValueError) as e:
        c.fetch(name, tmp_path / "out")
    assert str(e.value).startswith("name_or_key") and words in str(e.value)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("kwargs,field", [
    (dict(channel="../nightly"), "channel"),
    (dict(channel="night/ly"), "channel"),
    (dict(channel=""), "channel"),
    (dict(channel="-nightly"), "channel"),
    (dict(channel="n" * 65), "channel"),
    (dict(mirrors=["ftp://cdn.example.com/r"]), "mirrors[0]"),
    (dict(mirrors=["http://ok.example.com", "file:///srv/release"]), "mirrors[1]"),
    (dict(mirrors=["/srv/release"]), "mirrors[0]"),
    (dict(mirrors=["cdn.example.com/impostors"]), "mirrors[0]"),
    (dict(mirrors=["https://cdn.example.com/r?x=1"]), "mirrors[0]"),
    (dict(timeout_seconds=0), "timeout_seconds"),
    (dict(max_attempts=0), "max_attempts"),
    (dict(public_key_pem=b"not a key"), "public_key_pem"),
])
def test_bad_client_arguments_raise_value_error_naming_the_field(
        tmp_path: Path, kwargs: Dict[str, Any], field: str) -> None:
    args: Dict[str, Any] = dict(mirrors=["https://cdn.example.com/impostors"], channel=CHANNEL,
                                cache_dir=tmp_path / "cache")
    args.update(kwargs)
    with pytest.raises(ValueError) as e:
        ReleaseClient(**args)
    assert str(e.value).startswith(field), str(e.value)


def test_a_private_or_rsa_key_is_not_a_catalog_key(tmp_path: Path) -> None:
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey
    from cryptography.hazmat.primitives.asymmetric.ec import SECP256R1, generate_private_key

    private_pem = Ed25519PrivateKey.generate().private_bytes(
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    ec_pem = generate_private_key(SECP256R1()).public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo)
    for pem, words in ((private_pem, "not a public key"), (ec_pem, "not an Ed25519 public key")):
        with pytest.raises(ValueError) as e:
            ReleaseClient(["http://127.0.0.1:9"], CHANNEL, tmp_path, public_key_pem=pem)
        assert str(e.value).startswith("public_key_pem") and words in str(e.value)


@pytest.mark.parametrize("edit,words", [
    (lambda a: a[OAK]["files"][0].update(name="../../escape.png"), 'name "../../escape.png"'),
    (lambda a: a[OAK]["files"][0].update(name="/tmp/escape.png"), 'name "/tmp/escape.png"'),
    (lambda a: a[OAK]["files"][0].update(name=".hidden"), 'name ".hidden"'),
    (lambda a: a[OAK]["files"][0].update(sha256="XYZ"), "files[0].sha256 must be 64 lowercase hex"),
    (lambda a: a[OAK]["files"][0].update(size_bytes=-1), "files[0].size_bytes must be a whole number"),
    (lambda a: a[OAK]["files"].pop(), "files must list manifest.json"),
    (lambda a: a.update({"../evil": a[OAK]}), '"../evil": has a . or .. segment'),
])
def test_an_untrusted_catalog_cannot_write_outside_out_dir(
        release: Release, mirrors: Tuple[Mirror, Mirror], tmp_path: Path, edit: Any, words: str) -> None:
    first, _ = mirrors
    assets = json.loads(json.dumps(release.assets))
    edit(assets)
    release.tree.publish(assets)
    out = tmp_path / "game" / "out"
    with pytest.raises(ReleaseError) as e:
        client([first], tmp_path / "cache").fetch(OAK, out)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert words in str(e.value) and first.url in str(e.value)
    assert not (tmp_path / "game").exists() and not list(tmp_path.glob("*escape*"))


# ---------------------------------------------------------------------------
# HTTPS, and a tree the real publisher wrote


def test_an_https_mirror_with_a_ca_file(release: Release, pki: Path, tmp_path: Path) -> None:
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    context.load_cert_chain(pki / "server.pem", pki / "server.key")
    mirror = Mirror(release.tree.root, context)
    try:
        oak = client([mirror], tmp_path / "cache", ca_file=pki / "ca.pem").fetch(OAK, tmp_path / "out")
        assert_verified(oak, release, OAK)
        # A CA that did not sign the mirror's certificate: refused, nothing fetched.
        with pytest.raises(ReleaseError) as e:
            client([mirror], tmp_path / "cache2", ca_file=pki / "other.pem").catalog()
        assert e.value.code == grpc.StatusCode.UNAVAILABLE and "CERTIFICATE_VERIFY_FAILED" in str(e.value)
    finally:
        mirror.stop()


def impostor_cli() -> Optional[Path]:
    """The `impostor` CLI of this build, when it has `publish`."""
    candidates = []
    if os.environ.get("IMPOSTOR_BIN_DIR"):
        candidates.append(Path(os.environ["IMPOSTOR_BIN_DIR"]) / "impostor")
    if os.environ.get("IMPOSTOR_SOURCE_DIR"):
        candidates.append(Path(os.environ["IMPOSTOR_SOURCE_DIR"]) / "build" / "bin" / "impostor")
    here = Path(__file__).resolve()
    candidates += [here.parents[2] / "build" / "bin" / "impostor", here.parents[2] / "bin" / "impostor"]
    for cli in candidates:
        if cli.is_file() and os.access(cli, os.X_OK):
            run = subprocess.run([str(cli), "--help"], capture_output=True, text=True, timeout=60)
            if "publish" in run.stdout + run.stderr:
                return cli
    return None


def test_a_tree_published_by_impostor_publish(request: pytest.FixtureRequest, tmp_path: Path) -> None:
    cli = impostor_cli()
    if cli is None:
        pytest.skip("no `impostor` CLI with `publish` in this build (build/bin/impostor)")
    if not os.environ.get("IMPOSTOR_BIN_DIR") or not os.environ.get("IMPOSTOR_TEST_ASSETS_DIR"):
        pytest.skip("publishing needs a farm: IMPOSTOR_BIN_DIR and IMPOSTOR_TEST_ASSETS_DIR (set by ctest)")
    farm = request.getfixturevalue("farm")
    assets_dir = Path(os.environ["IMPOSTOR_TEST_ASSETS_DIR"])
    with impostor.Client(farm.address) as farm_client:
        baked = farm_client.bake(assets_dir / "props_pbr/Box/glTF-Binary/Box.glb", tmp_path / "baked",
                                 frames=4, resolution=128, quality_views=4)
    root = tmp_path / "release"
    run = subprocess.run([str(cli), "publish", f"props/box={baked.cache_key}", "--channel", CHANNEL,
                          "--out", str(root), "--server", farm.address],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    mirror = Mirror(root)
    try:
        box = client([mirror], tmp_path / "cache").fetch("props/box", tmp_path / "out")
    finally:
        mirror.stop()
    assert box.cache_key == baked.cache_key
    manifest = json.loads(box.manifest.read_bytes())
    compared = 0
    for m in manifest["maps"]:
        if m["file"] in box.files:
            data = box.files[m["file"]].read_bytes()
            assert sha256(data) == m["digest"]["hash"] == sha256((baked.dir / m["file"]).read_bytes())
            compared += 1
    # Every file but manifest.json is one of the manifest's maps.
    assert compared == len(box.files) - 1 > 0
    assert box.manifest.read_bytes() == (baked.dir / "manifest.json").read_bytes()
