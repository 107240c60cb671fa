"""squall.Client: a channel to squalld and one object per capability (synchronous)."""

from __future__ import annotations

import time
from typing import Any, List, Optional, Sequence, Tuple

import grpc

from squall._calls import (
    CHANNEL_OPTIONS,
    DEFAULT_ADDRESS,
    OWN_CONNECTION_OPTIONS,
    Connection,
    Settings,
    address_of,
    resolve_token,
    retry_options,
    warn_plaintext_token,
)
from squall._convert import flag, shown
from squall._errors import SquallError
from squall._pb import rpc_client, server_pb2, server_pb2_grpc
from squall.clouds import Clouds
from squall.ewave import EWave
from squall.ocean import Ocean
from squall.textures import Textures

# grpc.health.v1.Health/Check (proto/grpc/health/v1/health.proto). Its two one-field messages are
# written in protobuf's wire format here, not generated: a generated module registers
# grpc.health.v1.* in protobuf's default descriptor pool, where grpcio-health-checking's
# grpc_health.v1.health_pb2 registers the same names from a file of another name, and a process
# that imports both fails at the second import.
HEALTH_CHECK = "/grpc.health.v1.Health/Check"
SERVING_STATUS = ("UNKNOWN", "SERVING", "NOT_SERVING", "SERVICE_UNKNOWN")
# The line that opens each block of a PEM file (a certificate, a key).
PEM_BEGIN = b"-----BEGIN "


def _varint(value: int) -> bytes:
    out = bytearray()
    while True:
        out.append((value & 0x7F) | (0x80 if value > 0x7F else 0))
        value >>= 7
        if not value:
            return bytes(out)


def _read_varint(data: bytes, at: int) -> Tuple[int, int]:
    """The varint at data[at:] and the offset after it; ValueError when data ends inside it."""
    value, shift = 0, 0
    while True:
        if at >= len(data):
            raise ValueError("a health response ends inside a varint")
        value |= (data[at] & 0x7F) << shift
        at, shift = at + 1, shift + 7
        if not data[at - 1] & 0x80:
            return value, at


def health_service(service: str) -> str:
    """The service a health check asks about (a str: "" the whole server, "squall.v1.Ocean", ...);
    TypeError naming ``service`` else (gRPC would fail to encode it, as INTERNAL)."""
    if not isinstance(service, str):
        raise TypeError(
            f'service = {shown(service)}: want a service name (a str: "" for the whole server, '
            '"squall.v1.Ocean", ...)'
        )
    return service


def channel_options(
    retries: int, own_connection: bool, options: Sequence[Tuple[str, Any]]
) -> List[Tuple[str, Any]]:
    """The options of a Client's channel: squall's, the retry policy, `options`."""
    result = list(CHANNEL_OPTIONS) + retry_options(retries)
    if flag(own_connection, "own_connection"):
        result += OWN_CONNECTION_OPTIONS
    return result + list(options)


def encode_health_request(service: str) -> bytes:
    """HealthCheckRequest { string service = 1; } as bytes."""
    data = service.encode()
    return b"\x0a" + _varint(len(data)) + data if data else b""


def decode_health_response(data: bytes) -> str:
    """HealthCheckResponse { ServingStatus status = 1; } bytes -> "SERVING", "NOT_SERVING",
    "UNKNOWN", "SERVICE_UNKNOWN" (fields of other numbers skipped, as protobuf does)."""
    status, at = 0, 0
    while at < len(data):
        key, at = _read_varint(data, at)
        wire_type = key & 7
        if wire_type == 0:
            value, at = _read_varint(data, at)
            status = value if key >> 3 == 1 else status
        elif wire_type == 2:
            length, at = _read_varint(data, at)
            at += length
        elif wire_type in (1, 5):
            at += 8 if wire_type == 1 else 4
        else:
            raise ValueError(f"a health response holds wire type {wire_type}")
        if at > len(data):
            raise ValueError("a health response ends inside a field")
    return SERVING_STATUS[status] if status < len(SERVING_STATUS) else "UNKNOWN"


def tls_credentials(
    ca: Optional[str] = None, cert: Optional[str] = None, key: Optional[str] = None
) -> grpc.ChannelCredentials:
    """Channel credentials for a squalld that serves TLS (``--tls-cert`` / ``--tls-key``), as the
    command line's ``--tls-ca`` / ``--tls-cert`` / ``--tls-key``.

    Args:
        ca: PEM file of the CA that signed squalld's certificate; None: the system's roots.
        cert, key: PEM files of this client's certificate chain and private key, for a squalld
            started with ``--tls-client-ca`` (mutual TLS); both or neither.

    Raises:
        FileNotFoundError: a file that does not exist.
        ValueError: cert without key or key without cert; a file that holds no PEM block
            (``-----BEGIN ...``), which gRPC would take and every call then fail UNAVAILABLE.
    """
    if (cert is None) != (key is None):
        raise ValueError("tls_credentials: cert and key go together")

    def read(name: str, path: Optional[str]) -> Optional[bytes]:
        if path is None:
            return None
        with open(path, "rb") as f:
            data = f.read()
        if PEM_BEGIN not in data:
            raise ValueError(
                f"{name} = {path!r}: no PEM block ({PEM_BEGIN.decode()}...) in the file: "
                "want a PEM file"
            )
        return data

    return grpc.ssl_channel_credentials(read("ca", ca), read("key", key), read("cert", cert))


class Client:
    """A client of one squalld.

    Args:
        address: "host:port" of squalld (default 127.0.0.1:50051).
        timeout: deadline of each unary call, s > 0 (default 30); None, inf or more than 1e8 s
            (``squall._calls.MAX_TIMEOUT``, about 3 years): no deadline.
        token: sent on every call as the metadata "authorization: Bearer <token>": a token of
            squalld's --auth-tokens file (or of a gateway in front of it). None: the first word of
            `token_file` if given, else $SQUALL_TOKEN if set, else none is sent (as the squall CLI's
            --token-file and $SQUALL_TOKEN).
        stream_timeout: deadline of each streaming call, s > 0; None (default), inf or more than
            1e8 s: none, streams run until they end or are cancelled.
        request_id: sent as "x-request-id" on every call; squalld shows it in its request log.
        credentials: grpc.ChannelCredentials for a TLS channel (``squall.tls_credentials(ca=...)``
            for a squalld started with --tls-cert, or a gateway's); None: plaintext.
        options: extra gRPC channel options, added to squall's (no client-side message size limit).
        retries: attempts of a call answered UNAVAILABLE (squalld starting or draining, a replica
            gone behind a proxy), with backoff from 0.1 s to 2 s: an integer >= 0, of which at
            most 5 count (0 or 1: no retries). A unary call that comes back CANCELLED with no
            x-squall-replica (unanswered: gRPC ends so a call that reaches a replica as its
            server closes) is sent again too, up to `retries` sends (counted apart from the
            retry policy's attempts), within its deadline.
            gRPC retries only calls the server has not begun to answer, squalld answers
            UNAVAILABLE before it touches a session, and an eWave step carries a retry key that
            squalld answers once: these retries of a step make it once (unless another caller
            steps the session in between; see EWaveSession.step's after_step).
        token_file: a file whose first word is the token, read once here (see `token`).
        own_connection: a TCP connection of its own. By default the Clients of one process to one
            address (with the same options) share one connection, which is what one program
            wants; a load generator wants each of its clients to have its own.

    Attributes:
        ocean: Ocean tiles, streams and samples (squall.ocean.Ocean).
        ewave: eWave sessions (squall.ewave.EWave).
        clouds: cloud volumes and images (squall.clouds.Clouds).
        textures: advected textures (squall.textures.Textures).

    Each method takes ``timeout=`` to override the default for one call (``float("inf")`` or
    more than 1e8 s: none).
    Failures raise squall.SquallError with the gRPC status code and the server's message. The
    client is a context manager; ``close()`` closes its channel.
    """

    def __init__(
        self,
        address: str = DEFAULT_ADDRESS,
        timeout: Optional[float] = 30.0,
        token: Optional[str] = None,
        *,
        stream_timeout: Optional[float] = None,
        request_id: Optional[str] = None,
        credentials: Optional[grpc.ChannelCredentials] = None,
        options: Sequence[Tuple[str, Any]] = (),
        retries: int = 5,
        token_file: Optional[str] = None,
        own_connection: bool = False,
    ) -> None:
        self.address = address_of(address)
        settings = Settings(
            timeout, stream_timeout, resolve_token(token, token_file), request_id, retries
        )
        grpc_options = channel_options(retries, own_connection, options)
        warn_plaintext_token(address, settings.token, credentials is not None)
        if credentials is None:
            channel = grpc.insecure_channel(address, options=grpc_options)
        else:
            channel = grpc.secure_channel(address, credentials, options=grpc_options)
        self._connection = Connection(channel, settings)
        self._server = rpc_client(server_pb2_grpc.ServerStub, channel)
        self._health = channel.unary_unary(
            HEALTH_CHECK,
            request_serializer=encode_health_request,
            response_deserializer=decode_health_response,
        )
        self.ocean = Ocean(self._connection)
        self.ewave = EWave(self._connection)
        self.clouds = Clouds(self._connection)
        self.textures = Textures(self._connection)

    @property
    def channel(self) -> grpc.Channel:
        """The gRPC channel (for squall.v1.*_pb2_grpc client classes of your own)."""
        return self._connection.channel

    def info(self, *, timeout: Optional[float] = None) -> server_pb2.GetInfoResponse:
        """The daemon's version, devices, kernels, FFT backend, limits and readiness
        (Server.GetInfo).
        """
        request = server_pb2.GetInfoRequest()  # the request id goes as x-request-id (any length)
        reply: server_pb2.GetInfoResponse = self._connection.unary(
            "Server.GetInfo", self._server.GetInfo, request, timeout
        )
        return reply

    def health(self, service: str = "", *, timeout: Optional[float] = None) -> str:
        """gRPC health of `service` ("" = the whole server): "SERVING", "NOT_SERVING", ..."""
        request = health_service(service)
        status: str = self._connection.unary("Health.Check", self._health, request, timeout)
        return status

    def wait_until_serving(self, timeout: float = 60.0) -> bool:
        """Polls health until SERVING (True), or False once `timeout` seconds passed."""
        end = time.monotonic() + timeout
        while True:
            try:
                if self.health(timeout=max(0.1, min(2.0, end - time.monotonic()))) == "SERVING":
                    return True
            except SquallError:
                pass  # not listening yet
            if time.monotonic() >= end:
                return False
            time.sleep(0.1)

    def close(self) -> None:
        """Closes the channel (running streams are cancelled); later calls raise RuntimeError."""
        self._connection.settings.closed = True
        self._connection.channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"squall.Client({self.address!r})"
