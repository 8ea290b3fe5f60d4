"""impostor.release: fetching impostors by asset name from published release
trees over HTTP, no farm: through faulty mirrors, offline, as the channel
moves on, over HTTPS, and from a tree `impostor publish` wrote.

The trees and mirrors are release_mirrors.py's (the first mirror faulty
where a test says so). Every test asserts on verified bytes: what lands in
out_dir hashes to the catalog's digest, and nothing else lands there.
"""
from __future__ import annotations

import json
import os
import ssl
import subprocess
import time
from pathlib import Path
from typing import Optional, Tuple

import grpc
import pytest

import impostor
from impostor.release import ReleaseError
from release_mirrors import (  # noqa: F401 (release, mirrors, _no_proxy: fixtures)
    CHANNEL,
    OAK,
    OAK_FILES,
    ROCK,
    TIMEOUT_S,
    Mirror,
    Release,
    _no_proxy,
    assert_verified,
    client,
    mirrors,
    no_partials,
    release,
    sha256,
)


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
