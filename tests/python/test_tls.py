"""The Python client against a squalld that serves mutual TLS (--tls-cert, --tls-key,
--tls-client-ca), with a CA, a server certificate (SAN IP 127.0.0.1) and a client certificate made by
Debian's openssl for the test."""

from __future__ import annotations

import asyncio
import subprocess
from pathlib import Path
from typing import Dict, Iterator

import grpc
import pytest

import squall
import squall.aio
from conftest import Daemon, _start

KEY = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]


def openssl(*argv: str) -> None:
    subprocess.run(["/usr/bin/openssl", *argv], check=True, capture_output=True)


@pytest.fixture(scope="module")
def certificates(tmp_path_factory) -> Dict[str, str]:
    d = tmp_path_factory.mktemp("tls")
    p = {name: str(d / name) for name in ("ca.pem", "ca.key", "server.pem", "server.key")}
    p.update({name: str(d / name) for name in ("client.pem", "client.key", "server.ext")})
    openssl("req", "-x509", "-keyout", p["ca.key"], "-out", p["ca.pem"], "-days", "1",
            "-subj", "/CN=squall test CA", *KEY)  # fmt: skip
    Path(p["server.ext"]).write_text("subjectAltName=IP:127.0.0.1\n")
    for name, subject in (("server", "/CN=127.0.0.1"), ("client", "/CN=squall test client")):
        csr = str(d / f"{name}.csr")
        openssl("req", "-keyout", p[f"{name}.key"], "-out", csr, "-subj", subject, *KEY)
        extra = ["-extfile", p["server.ext"]] if name == "server" else []
        openssl("x509", "-req", "-in", csr, "-CA", p["ca.pem"], "-CAkey", p["ca.key"],
                "-CAcreateserial", "-out", p[f"{name}.pem"], "-days", "1", *extra)  # fmt: skip
    return p


def client_credentials(c: Dict[str, str]) -> grpc.ChannelCredentials:
    return squall.tls_credentials(ca=c["ca.pem"], cert=c["client.pem"], key=c["client.key"])


@pytest.fixture(scope="module")
def mtls_daemon(certificates) -> Iterator[Daemon]:
    c = certificates
    flags = [
        "--tls-cert",
        c["server.pem"],
        "--tls-key",
        c["server.key"],
        "--tls-client-ca",
        c["ca.pem"],
    ]
    yield from _start(flags, "mtls", credentials=client_credentials(c))


def test_a_client_with_its_certificate_gets_in(mtls_daemon, certificates):
    with squall.Client(mtls_daemon.address, credentials=client_credentials(certificates)) as c:
        assert c.health() == "SERVING"
        tile = c.ocean.tile(squall.ocean.layer(extent=100, n=16), outputs=("height",))
        assert tile["height"].shape == (16, 16)


@pytest.mark.parametrize("who", ["plaintext", "no client certificate"])
def test_others_are_refused(mtls_daemon, certificates, who):
    credentials = None if who == "plaintext" else squall.tls_credentials(ca=certificates["ca.pem"])
    with squall.Client(mtls_daemon.address, timeout=5, credentials=credentials) as c:
        with pytest.raises(squall.SquallError) as refused:
            c.info()
    assert refused.value.code == grpc.StatusCode.UNAVAILABLE


def test_cert_without_key_is_a_usage_error(certificates):
    with pytest.raises(ValueError, match="cert and key go together"):
        squall.tls_credentials(ca=certificates["ca.pem"], cert=certificates["client.pem"])


@pytest.fixture(scope="module")
def token_daemon(tmp_path_factory) -> Iterator[Daemon]:
    tokens = tmp_path_factory.mktemp("auth") / "tokens"
    tokens.write_text("# one token per line, a name may follow\npython-s3cret python\n")
    yield from _start(["--auth-tokens", str(tokens)], "auth")


def test_a_bearer_token_gets_in_and_none_or_a_wrong_one_does_not(token_daemon):
    with squall.Client(token_daemon.address, token="python-s3cret") as c:
        assert c.info().version
    for token in (None, "python-s3cres"):
        with squall.Client(token_daemon.address, token=token) as c:
            with pytest.raises(squall.SquallError) as refused:
                c.info()
            assert refused.value.code == grpc.StatusCode.UNAUTHENTICATED
            assert c.health() == "SERVING"  # health stays open for balancers


def test_the_token_comes_from_a_file_or_squall_token_as_in_the_cli(
    token_daemon, tmp_path, monkeypatch
):
    good, wrong = tmp_path / "good", tmp_path / "wrong"
    good.write_text("python-s3cret python\n")  # the first word, as the CLI's --token-file
    wrong.write_text("python-s3cres\n")
    monkeypatch.setenv("SQUALL_TOKEN", "python-s3cres")
    with squall.Client(token_daemon.address, token_file=str(good)) as c:  # the file wins
        assert c.info().version
    with squall.Client(token_daemon.address) as c:  # the variable's wrong token
        with pytest.raises(squall.SquallError) as refused:
            c.info()
        assert refused.value.code == grpc.StatusCode.UNAUTHENTICATED
    monkeypatch.setenv("SQUALL_TOKEN", "python-s3cret")
    with squall.Client(token_daemon.address) as c:
        assert c.info().version
    with squall.Client(token_daemon.address, token_file=str(wrong)) as c:
        with pytest.raises(squall.SquallError):
            c.info()
    empty = tmp_path / "empty"
    empty.write_text("\n")
    with pytest.raises(ValueError, match="no token"):
        squall.Client(token_daemon.address, token_file=str(empty))


def test_a_token_file_that_fails_opens_no_channel(token_daemon, tmp_path, monkeypatch):
    """The token is read before the channel is made: a missing or empty file leaks no channel."""
    opened = []

    def recording(real):
        def channel(*args, **kwargs):
            opened.append(real(*args, **kwargs))
            return opened[-1]

        return channel

    monkeypatch.setattr(grpc, "insecure_channel", recording(grpc.insecure_channel))
    monkeypatch.setattr(grpc.aio, "insecure_channel", recording(grpc.aio.insecure_channel))
    empty = tmp_path / "empty"
    empty.write_text("\n")

    async def aio_client(token_file: str) -> None:
        squall.aio.Client(token_daemon.address, token_file=token_file)

    for make in (
        lambda f: squall.Client(token_daemon.address, token_file=f),
        lambda f: asyncio.run(aio_client(f)),
    ):
        with pytest.raises(ValueError, match="no token"):
            make(str(empty))
        with pytest.raises(FileNotFoundError):
            make(str(tmp_path / "missing"))
    assert opened == []
    with squall.Client(token_daemon.address, token="python-s3cret") as c:  # the recording works
        assert c.info().version
    assert len(opened) == 1
