"""squall.SquallError: the one exception type for what the server (or the transport) refuses."""

from __future__ import annotations

from typing import Optional

import grpc


class SquallError(Exception):
    """A call failed: the gRPC status code and the server's message.

    Attributes:
        code: the gRPC status, e.g. ``grpc.StatusCode.INVALID_ARGUMENT``, ``NOT_FOUND``,
            ``RESOURCE_EXHAUSTED``, ``UNAVAILABLE``, ``DEADLINE_EXCEEDED``, ``CANCELLED``.
        message: the server's message; for bad input it names the field path and the allowed range,
            e.g. ``"tile.layers[0].wind_speed = nan must be finite and in (0, 100]"``.
        method: the RPC, e.g. ``"Ocean.GetTile"`` (empty when not known).

    ``str(error)`` reads ``"Ocean.GetTile: INVALID_ARGUMENT: tile.layers[0].wind_speed = nan
    ..."``. Mistakes caught before anything is sent (an unknown enum name, an array of the wrong
    rank) raise ``ValueError`` or ``TypeError`` instead.
    """

    def __init__(self, code: grpc.StatusCode, message: str, method: str = "") -> None:
        self.code = code
        self.message = message
        self.method = method
        prefix = f"{method}: " if method else ""
        super().__init__(f"{prefix}{code.name}: {message}")

    @property
    def code_name(self) -> str:
        """The status code's name, e.g. ``"INVALID_ARGUMENT"``."""
        return self.code.name

    @classmethod
    def from_rpc(cls, error: grpc.RpcError, method: str = "") -> "SquallError":
        """The SquallError of a failed gRPC call (sync or asyncio)."""
        code: Optional[grpc.StatusCode] = None
        details: Optional[str] = None
        try:
            code = error.code()  # type: ignore[attr-defined]
            details = error.details()  # type: ignore[attr-defined]
        except Exception:  # an RpcError that is not a Call
            pass
        return cls(code or grpc.StatusCode.UNKNOWN, details or str(error), method)
