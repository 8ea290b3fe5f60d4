"""KTX2 results (docs/ktx2.md) through the Python client against a real
impostor-server and worker: texture_format="ktx2" bakes, and fetch brings
the manifest's .ktx2 files with verified digests; bad values are refused
naming the field."""
from __future__ import annotations

import json
from pathlib import Path

import grpc
import pytest

import impostor
from conftest import sha256_file
from farm_process import FarmServer

BOX = "props_pbr/Box/glTF-Binary/Box.glb"
# 4 frames x 32 px tiles: two mip levels (32 and 16 px tiles), both block-aligned.
SMALL_KTX2 = dict(frames=4, resolution=128, quality_views=0, texture_format="ktx2")
KTX2_IDENTIFIER = b"\xabKTX 20\xbb\r\n\x1a\n"


@pytest.fixture(scope="module")
def client(farm: FarmServer) -> impostor.Client:
    with impostor.Client(farm.address) as c:
        yield c


@pytest.fixture(scope="module")
def ktx2_bake(client: impostor.Client, assets: Path, tmp_path_factory: pytest.TempPathFactory):
    return client.bake(assets / BOX, tmp_path_factory.mktemp("ktx2"), **SMALL_KTX2)


def test_ktx2_bake_fetches_the_manifests_ktx2_files_verified(ktx2_bake) -> None:
    result = ktx2_bake
    # contact_sheet.png stays a PNG: it is for people.
    maps = {m["semantic"]: m for m in result.manifest["maps"] if m["file"] != "contact_sheet.png"}
    assert set(maps) == {"albedo_alpha", "normal_depth", "depth", "orm"}
    for m in maps.values():
        assert m["file"].endswith(".ktx2"), m
        assert m["codec"] == "uastc" and m["levels"] == 2, m
        path = result.dir / m["file"]
        assert path in result.files
        assert path.stat().st_size == m["digest"]["size_bytes"], m["file"]
        assert sha256_file(path) == m["digest"]["hash"], m["file"]
        head = path.read_bytes()[:12 + 4 * 4]
        assert head[:12] == KTX2_IDENTIFIER, m["file"]
        # KTX2 header: vkFormat, typeSize, pixelWidth, pixelHeight (little endian).
        assert int.from_bytes(head[20:24], "little") == m["width"] == 128
        assert int.from_bytes(head[24:28], "little") == m["height"] == 128
    assert not any(p.suffix == ".png" and p.name != "contact_sheet.png" for p in result.files)
    assert json.loads(result.fetched.manifest_path.read_text()) == result.manifest


def test_ktx2_and_png_of_the_same_request_are_different_results(client, assets, ktx2_bake) -> None:
    png = client.lookup(assets / BOX, **{**SMALL_KTX2, "texture_format": "png"})
    assert png.cache_key != ktx2_bake.cache_key
    again = client.lookup(assets / BOX, **SMALL_KTX2)
    assert again.found and again.cache_key == ktx2_bake.cache_key


def test_fetch_of_a_ktx2_result_again_reuses_every_file(client, ktx2_bake) -> None:
    again = client.fetch(ktx2_bake.cache_key, ktx2_bake.dir)
    assert again.bytes_downloaded == 0 and again.bytes_reused > 0
    assert [p.name for p in again.files] == [p.name for p in ktx2_bake.files]


@pytest.mark.parametrize(
    "settings, field",
    [
        (dict(texture_format="ktx"), "texture_format"),
        (dict(texture_format="KTX2 "), "texture_format"),
        (dict(texture_format="ktx2", albedo_codec="bc7"), "albedo_codec"),
    ],
    ids=["unknown-format", "misspelt-format", "unknown-albedo-codec"],
)
def test_bad_texture_format_is_refused_naming_the_field(client, assets, settings, field) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        client.submit(assets / BOX, **settings)
    e = caught.value
    assert e.code == grpc.StatusCode.INVALID_ARGUMENT, e
    assert e.message.startswith(f"{field}:") and "expected" in e.message, e.message
    assert not e.is_rpc_error


def test_ktx2_with_texture_array_carries_the_servers_refusal(client, assets) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        client.submit(assets / BOX, frames=4, resolution=128, texture_format="ktx2", texture_array=True)
    e = caught.value
    assert e.code == grpc.StatusCode.INVALID_ARGUMENT and e.is_rpc_error, e
    assert "texture" in e.server_message, e.server_message
