"""impostor.release refuses what it cannot trust: a catalog unsigned,
signed by another key or tampered with, bad asset names and client
arguments, keys that are not Ed25519 public keys, and catalogs that name
files outside out_dir. Trees and mirrors: release_mirrors.py.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Dict, Tuple

import grpc
import pytest

from impostor.release import ReleaseClient, ReleaseError
from release_mirrors import (  # noqa: F401 (release, mirrors, _no_proxy: fixtures)
    CHANNEL,
    OAK,
    ROCK,
    Mirror,
    Release,
    _no_proxy,
    assert_verified,
    client,
    key_id,
    mirrors,
    public_pem,
    release,
    sha256,
)


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
