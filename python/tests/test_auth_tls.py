"""The Python client against a real farm that asks for TLS and tokens
(impostor-server --auth token --tls-cert/--tls-key, one local worker): a
bake with a submitter token through TLS, the token from a file or from
$IMPOSTOR_TOKEN, and the refusals (no token, wrong role, plaintext) as
ImpostorError with the server's reason."""
from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Iterator

import grpc
import pytest

import impostor
from farm_process import FarmServer, bin_dir

BOX = "props_pbr/Box/glTF-Binary/Box.glb"
SMALL = dict(frames=4, resolution=128, quality_views=4)


def create_token(data_dir: Path, role: str, name: str) -> str:
    run = subprocess.run([str(bin_dir() / "impostor-server"), "token", "create", f"--data={data_dir}",
                          f"--role={role}", f"--name={name}"], capture_output=True, text=True, check=True)
    return run.stdout.strip()


@pytest.fixture(scope="module")
def secure_farm(tmp_path_factory: pytest.TempPathFactory, pki: Path) -> Iterator[FarmServer]:
    server = FarmServer(tmp_path_factory.mktemp("secure") / "data",
                        extra_args=["--auth=token", f"--tls-cert={pki / 'server.pem'}",
                                    f"--tls-key={pki / 'server.key'}"])
    yield server
    server.stop()


def address(farm: FarmServer) -> str:
    return f"localhost:{farm.port}"  # the name the server's certificate carries


def test_bake_through_tls_with_a_token_file(secure_farm: FarmServer, pki: Path, assets: Path,
                                            tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    token_file = tmp_path / "artist.token"
    token_file.write_text(create_token(secure_farm.data_dir, "submitter", "py-artist") + "\n")
    # The file wins over the environment.
    monkeypatch.setenv("IMPOSTOR_TOKEN", "imp_" + "Q" * 43)
    with impostor.Client(address(secure_farm), token_file=token_file, tls_ca=pki / "ca.pem") as farm:
        result = farm.bake(assets / BOX, tmp_path / "box", **SMALL)
    assert not result.cached
    assert result.manifest["cache_key"] == result.cache_key
    # The server stamps the worker token that baked it into manifest.json.
    installed = json.loads((tmp_path / "box" / "manifest.json").read_text())
    assert installed["baked_by"] == "local-workers"
    assert result.manifest["baked_by"] == "local-workers"


def test_a_reader_token_from_the_environment_fetches(secure_farm: FarmServer, pki: Path, assets: Path,
                                                     tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    submitter = create_token(secure_farm.data_dir, "submitter", "py-ci")
    with impostor.Client(address(secure_farm), token=submitter, tls_ca=pki / "ca.pem") as farm:
        key = farm.bake(assets / BOX, tmp_path / "baked", **SMALL).cache_key
    monkeypatch.setenv("IMPOSTOR_TOKEN", create_token(secure_farm.data_dir, "reader", "py-game"))
    with impostor.Client(address(secure_farm), tls_ca=pki / "ca.pem") as game:
        fetched = game.fetch(key, tmp_path / "fetched")
    assert (tmp_path / "fetched" / "manifest.json").read_bytes() == (tmp_path / "baked" / "manifest.json").read_bytes()
    assert fetched.manifest["cache_key"] == key


def test_no_token_is_unauthenticated_naming_the_reason(secure_farm: FarmServer, pki: Path, assets: Path,
                                                       tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("IMPOSTOR_TOKEN", raising=False)
    with impostor.Client(address(secure_farm), tls_ca=pki / "ca.pem", max_attempts=1) as farm:
        with pytest.raises(impostor.ImpostorError) as caught:
            farm.bake(assets / BOX, tmp_path, **SMALL)
    assert caught.value.code == grpc.StatusCode.UNAUTHENTICATED
    assert "no token" in caught.value.message, caught.value.message
    assert caught.value.rpc is not None and caught.value.server == address(secure_farm)


def test_a_revoked_or_unknown_token_is_unauthenticated(secure_farm: FarmServer, pki: Path, assets: Path,
                                                       tmp_path: Path) -> None:
    with impostor.Client(address(secure_farm), token="imp_" + "Q" * 43, tls_ca=pki / "ca.pem",
                         max_attempts=1) as farm:
        with pytest.raises(impostor.ImpostorError) as caught:
            farm.bake(assets / BOX, tmp_path, **SMALL)
    assert caught.value.code == grpc.StatusCode.UNAUTHENTICATED
    assert "unknown token" in caught.value.message, caught.value.message
    assert "Q" * 43 not in str(caught.value), "the secret is echoed"


def test_a_reader_token_may_not_bake(secure_farm: FarmServer, pki: Path, assets: Path, tmp_path: Path) -> None:
    reader = create_token(secure_farm.data_dir, "reader", "py-viewer")
    with impostor.Client(address(secure_farm), token=reader, tls_ca=pki / "ca.pem", max_attempts=1) as farm:
        with pytest.raises(impostor.ImpostorError) as caught:
            farm.bake(assets / BOX, tmp_path, **SMALL)
    assert caught.value.code == grpc.StatusCode.PERMISSION_DENIED
    assert caught.value.rpc == "FindMissingBlobs"  # the first call of a bake
    assert "needs role submitter or worker or admin" in caught.value.message, caught.value.message
    assert "'py-viewer' has role reader" in caught.value.message, caught.value.message
    assert reader not in str(caught.value)


def test_plaintext_is_refused_by_the_tls_listener(secure_farm: FarmServer) -> None:
    with pytest.raises(impostor.ImpostorError) as caught:
        impostor.Client(address(secure_farm), token="imp_" + "Q" * 43, connect_timeout_seconds=5)
    assert caught.value.code == grpc.StatusCode.UNAVAILABLE and caught.value.rpc == "Connect"


def test_a_quota_refusal_carries_the_servers_reason(tmp_path: Path, assets: Path) -> None:
    # No workers: the first job stays queued and fills the token's quota.
    farm = FarmServer(tmp_path / "quota", local_workers=0,
                      extra_args=["--auth=token", "--token-max-pending-jobs=1"])
    try:
        token = create_token(farm.data_dir, "submitter", "py-quota")
        with impostor.Client(f"127.0.0.1:{farm.port}", token=token, max_attempts=1) as client:
            client.submit(assets / BOX, **SMALL)
            with pytest.raises(impostor.ImpostorError) as caught:
                client.submit(assets / BOX, frames=6, resolution=128, quality_views=4)
    finally:
        farm.stop()
    assert caught.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
    assert caught.value.rpc == "SubmitBake"
    assert caught.value.reason == "TOKEN_PENDING_JOBS", caught.value.server_message
    assert "the limit per token is 1" in caught.value.server_message
