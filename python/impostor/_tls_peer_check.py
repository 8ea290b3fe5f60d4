"""Why a TLS server's certificate fails verification, in words: the Python
twin of common/net/tls_peer_check.cc (keep the sentences in step). gRPC reports
every verification failure as "certificate verify failed", whether the
certificate expired, is not valid yet, comes from another CA or does not
carry the name dialled; the fixes differ (renew it on the server, fix a
clock, give the right tls_ca, dial another name). This makes a TLS handshake
of its own with the standard `ssl` module, trusting only the CA given, and
reads OpenSSL's verification result from it.

Only called after gRPC has reported a TLS failure; blocks for at most about
`timeout_seconds`; never raises. Thread-safe (no shared state)."""
from __future__ import annotations

import calendar
import importlib
import os
import socket
import ssl
import tempfile
import time
from typing import Any, NamedTuple, Optional, Tuple

# OpenSSL's X509_V_ERR_* codes (openssl/x509_vfy.h), as
# ssl.SSLCertVerificationError.verify_code carries them.
_UNABLE_TO_GET_ISSUER_CERT = 2
_CERT_SIGNATURE_FAILURE = 7
_CERT_NOT_YET_VALID = 9
_CERT_HAS_EXPIRED = 10
_DEPTH_ZERO_SELF_SIGNED_CERT = 18
_SELF_SIGNED_CERT_IN_CHAIN = 19
_UNABLE_TO_GET_ISSUER_CERT_LOCALLY = 20
_UNABLE_TO_VERIFY_LEAF_SIGNATURE = 21
_INVALID_PURPOSE = 26
_HOSTNAME_MISMATCH = 62
_IP_ADDRESS_MISMATCH = 64

_FOREIGN_ISSUER = {
    _UNABLE_TO_GET_ISSUER_CERT,
    _CERT_SIGNATURE_FAILURE,
    _DEPTH_ZERO_SELF_SIGNED_CERT,
    _SELF_SIGNED_CERT_IN_CHAIN,
    _UNABLE_TO_GET_ISSUER_CERT_LOCALLY,
    _UNABLE_TO_VERIFY_LEAF_SIGNATURE,
}


class _PeerFacts(NamedTuple):
    """What the sentences quote from the server's certificate."""

    not_before: str  # "2026-11-22 14:26:11 UTC", or "?"
    not_after: str
    issuer: str  # RFC 4514, as OpenSSL's XN_FLAG_RFC2253 prints it: "CN=other CA,O=Studio"


_UNKNOWN = _PeerFacts("?", "?", "?")


def diagnose_server_certificate(
    target: str,
    ca_pem: bytes,
    cert_file: "Optional[str | os.PathLike[str]]",
    key_file: "Optional[str | os.PathLike[str]]",
    timeout_seconds: float,
) -> str:
    """`target` is HOST:PORT or [IPV6]:PORT (any other gRPC target: ""); the
    certificate must carry HOST (the client has no server-name override).
    `cert_file`/`key_file`: the client's certificate for mutual TLS, so a
    server that insists on one still shows its own. Returns a sentence such
    as "the server's certificate expired on 2026-11-22 14:26:11 UTC; it must
    be renewed on the server (--tls-cert, --tls-key)", or "" when the
    certificate verifies or the check cannot tell (no connection, no
    certificate, an unreadable CA)."""
    try:
        return _diagnose(target, ca_pem, cert_file, key_file, timeout_seconds)
    except Exception:  # noqa: BLE001 - a diagnosis must never hide gRPC's own account
        return ""


def _diagnose(
    target: str,
    ca_pem: bytes,
    cert_file: "Optional[str | os.PathLike[str]]",
    key_file: "Optional[str | os.PathLike[str]]",
    timeout_seconds: float,
) -> str:
    address = _split_host_port(target)
    if address is None:
        return ""
    host, port = address
    deadline = time.monotonic() + timeout_seconds
    # cadata (PEM text) and nothing else: no system roots, as gRPC trusts
    # only root_certificates when it is given.
    verifying = ssl.create_default_context(cadata=ca_pem.decode("ascii"))
    try:
        _handshake(_with_client_side(verifying, cert_file, key_file), host, port, deadline)
        return ""  # it verifies here: gRPC failed for another reason
    except ssl.SSLCertVerificationError as e:
        code = int(e.verify_code)
        message = str(e.verify_message)
    if code in (_HOSTNAME_MISMATCH, _IP_ADDRESS_MISMATCH):
        return f"the server's certificate does not carry the name {host}; connect to it by a name it carries"
    if code == _INVALID_PURPOSE:
        return "the server's certificate is not one for servers (its extendedKeyUsage lacks serverAuth)"
    if code not in _FOREIGN_ISSUER and code not in (_CERT_HAS_EXPIRED, _CERT_NOT_YET_VALID):
        return f"the server's certificate does not verify: {message}"
    # A failed handshake shows no certificate; a second one that verifies
    # nothing does, for the dates and the issuer.
    trusting = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    trusting.check_hostname = False
    trusting.verify_mode = ssl.CERT_NONE
    der = _handshake(_with_client_side(trusting, cert_file, key_file), host, port, deadline)
    facts = _peer_facts(der) if der else _UNKNOWN
    if code == _CERT_HAS_EXPIRED:
        return (
            f"the server's certificate expired on {facts.not_after}; it must be renewed on the server "
            "(--tls-cert, --tls-key)"
        )
    if code == _CERT_NOT_YET_VALID:
        return (
            f"the server's certificate is not valid until {facts.not_before}; is this machine's clock "
            "(or the server's) right?"
        )
    return f"the server's certificate (issuer {facts.issuer}) is not signed by the CA given (tls_ca)"


def _split_host_port(target: str) -> Optional[Tuple[str, int]]:
    """(host, port) of HOST:PORT or [IPV6]:PORT; None for anything else
    (dns:///..., unix:..., a bare IPv6 address)."""
    if target.startswith("["):
        host, close, rest = target[1:].partition("]")
        if not close or not rest.startswith(":"):
            return None
        port = rest[1:]
    else:
        host, colon, port = target.rpartition(":")
        if not colon or ":" in host:
            return None
    if not host or not port.isdigit():
        return None
    return host, int(port)


def _with_client_side(
    context: ssl.SSLContext,
    cert_file: "Optional[str | os.PathLike[str]]",
    key_file: "Optional[str | os.PathLike[str]]",
) -> ssl.SSLContext:
    # gRPC servers insist on HTTP/2.
    context.set_alpn_protocols(["h2"])
    if cert_file is not None and key_file is not None:
        context.load_cert_chain(cert_file, key_file)
    return context


def _handshake(context: ssl.SSLContext, host: str, port: int, deadline: float) -> Optional[bytes]:
    """One handshake with `host` as the name to check; the server's
    certificate (DER) or None. Raises ssl.SSLCertVerificationError when
    verification fails, OSError when out of time or refused."""
    left = deadline - time.monotonic()
    if left <= 0:
        raise TimeoutError("no time left")
    with socket.create_connection((host, port), timeout=left) as raw:
        # The socket timeout bounds each read; the deadline bounds the whole.
        raw.settimeout(max(0.01, deadline - time.monotonic()))
        # No SNI for an IP address (RFC 6066); ssl then checks the IP SAN.
        with context.wrap_socket(raw, server_hostname=host) as tls:
            return tls.getpeercert(binary_form=True)


def _peer_facts(der: bytes) -> _PeerFacts:
    """The certificate's dates and issuer, read with the `cryptography`
    package where it is installed (it is no dependency of this package), else
    with the decoder CPython's ssl module carries; "?" for what neither can
    read."""
    try:
        return _peer_facts_cryptography(der)
    except ImportError:
        pass
    except Exception:  # noqa: BLE001 - a certificate it cannot parse
        return _UNKNOWN
    try:
        return _peer_facts_stdlib(der)
    except Exception:  # noqa: BLE001
        return _UNKNOWN


def _peer_facts_cryptography(der: bytes) -> _PeerFacts:
    # import_module: mypy checks this module with or without the package.
    x509: Any = importlib.import_module("cryptography.x509")
    cert = x509.load_der_x509_certificate(der)
    # *_utc since cryptography 42 (the naive ones are deprecated there).
    not_before = getattr(cert, "not_valid_before_utc", None) or cert.not_valid_before
    not_after = getattr(cert, "not_valid_after_utc", None) or cert.not_valid_after
    return _PeerFacts(
        _format_utc(calendar.timegm(not_before.utctimetuple())),
        _format_utc(calendar.timegm(not_after.utctimetuple())),
        str(cert.issuer.rfc4514_string())[:200],
    )


# OpenSSL's short names, which XN_FLAG_RFC2253 prints.
_SHORT_NAMES = {
    "commonName": "CN",
    "organizationName": "O",
    "organizationalUnitName": "OU",
    "countryName": "C",
    "localityName": "L",
    "stateOrProvinceName": "ST",
    "streetAddress": "STREET",
    "domainComponent": "DC",
    "userId": "UID",
}


def _peer_facts_stdlib(der: bytes) -> _PeerFacts:
    # _ssl._test_decode_cert is private but in every CPython 3 (its own
    # tests use it); it reads a PEM file only.
    decode = getattr(importlib.import_module("_ssl"), "_test_decode_cert", None)
    if decode is None:
        return _UNKNOWN
    with tempfile.TemporaryDirectory(prefix="impostor-peer-") as d:
        path = os.path.join(d, "peer.pem")
        with open(path, "w", encoding="ascii") as f:
            f.write(ssl.DER_cert_to_PEM_cert(der))
        decoded: Any = decode(path)
    # Most significant RDN last, as RFC 4514 writes it.
    issuer = ",".join(
        "+".join(f"{_SHORT_NAMES.get(key, key)}={value}" for key, value in rdn)
        for rdn in reversed(decoded["issuer"])
    )
    return _PeerFacts(
        _format_utc(ssl.cert_time_to_seconds(decoded["notBefore"])),
        _format_utc(ssl.cert_time_to_seconds(decoded["notAfter"])),
        issuer[:200],
    )


def _format_utc(unix_seconds: int) -> str:
    """common/net/tls_files.h's FormatUtc."""
    return time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(unix_seconds))
