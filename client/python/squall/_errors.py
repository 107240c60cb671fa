"""squall.SquallError: the one exception type for what the server (or the transport) refuses."""

from __future__ import annotations

from typing import Any, Optional, Tuple, cast

import grpc

# The response metadata key that names the squalld replica that answered (server/rpc/metadata.h).
REPLICA_KEY = "x-squall-replica"


class SquallError(Exception):
    """A call failed: the gRPC status code and the server's message.

    Attributes:
        code: the gRPC status, e.g. ``grpc.StatusCode.INVALID_ARGUMENT``, ``NOT_FOUND``,
            ``RESOURCE_EXHAUSTED``, ``UNAVAILABLE``, ``DEADLINE_EXCEEDED``, ``CANCELLED``.
        message: the server's message; for bad input it names the field path and the allowed range,
            e.g. ``"tile.layers[0].wind_speed = nan must be finite and in (0, 100]"``.
        method: the RPC, e.g. ``"Ocean.GetTile"`` (empty when not known).
        metadata: the failed call's response metadata, initial then trailing, ``(key, value)``
            pairs (``x-squall-replica`` among them when a squalld answered: in the trailers of a
            call refused at once, in the initial metadata of a stream that failed after frames).

    ``str(error)`` reads ``"Ocean.GetTile: INVALID_ARGUMENT: tile.layers[0].wind_speed = nan
    ..."``. Mistakes caught before anything is sent (an unknown enum name, an array of the wrong
    rank) raise ``ValueError`` or ``TypeError`` instead.
    """

    def __init__(
        self,
        code: grpc.StatusCode,
        message: str,
        method: str = "",
        metadata: Tuple[Tuple[str, Any], ...] = (),
    ) -> None:
        self.code = code
        self.message = message
        self.method = method
        self.metadata = tuple(metadata)
        prefix = f"{method}: " if method else ""
        super().__init__(f"{prefix}{code.name}: {message}")

    def __reduce__(self) -> Tuple[Any, ...]:
        """Pickles with every attribute (errors cross process pools as the server sent them)."""
        return (type(self), (self.code, self.message, self.method, self.metadata), self.__dict__)

    @property
    def replica(self) -> str:
        """The squalld replica that refused the call (``x-squall-replica``), or ``""``."""
        return next((str(v) for k, v in self.metadata if k == REPLICA_KEY), "")

    @property
    def code_name(self) -> str:
        """The status code's name, e.g. ``"INVALID_ARGUMENT"``."""
        return self.code.name

    @classmethod
    def from_rpc(cls, error: grpc.RpcError, method: str = "") -> "SquallError":
        """The SquallError of a failed gRPC call (sync or asyncio)."""
        code: Optional[grpc.StatusCode] = None
        details: Optional[str] = None
        metadata: Tuple[Tuple[str, Any], ...] = ()
        # gRPC raises a Call (sync) or an AioRpcError, which has the same methods.
        call = cast(grpc.Call, error)
        try:
            code = call.code()
            details = call.details()
            initial = call.initial_metadata()
            trailers = call.trailing_metadata()
            metadata = tuple((m[0], m[1]) for m in [*(initial or ()), *(trailers or ())])
        except Exception:  # an RpcError that is not a Call
            pass
        return cls(code or grpc.StatusCode.UNKNOWN, details or str(error), method, metadata)


class PlaintextTokenWarning(UserWarning):
    """A client sends its bearer token to a host other than this machine without TLS: anyone on
    the path can read the token and call squalld as its owner. Give ``credentials``
    (``squall.tls_credentials``), or reach squalld through a TLS-terminating proxy."""
