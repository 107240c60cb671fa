"""The generated squall.v1 modules, imported in one place.

They are generated at build time (setup.py) into the subpackage squall.v1; a source checkout that
was not built has none, and gets an ImportError saying how to build them.
"""

from typing import Any, Callable

try:
    from squall.v1 import (  # noqa: F401  (re-exported)
        clouds_pb2,
        clouds_pb2_grpc,
        common_pb2,
        ewave_pb2,
        ewave_pb2_grpc,
        ocean_pb2,
        ocean_pb2_grpc,
        server_pb2,
        server_pb2_grpc,
        textures_pb2,
        textures_pb2_grpc,
    )
except ImportError as error:  # pragma: no cover - depends on how the package was installed
    raise ImportError(
        "squall: the generated gRPC modules (squall.v1) are missing: install the package with "
        "`pip install ./client/python` from a squall checkout, or generate them into the "
        "source tree with `python3 client/python/setup.py build_protos` (needs protoc and "
        "grpc_python_plugin). "
        f"Cause: {error}"
    ) from error


def rpc_client(cls: Callable[[Any], Any], channel: Any) -> Any:
    """``cls(channel)``: one of the generated client classes (``squall.v1.*_pb2_grpc.*Stub``) on
    a grpc or grpc.aio channel, typed Any: the generated gRPC modules have no type hints, so
    mypy --strict would otherwise reject each call of their methods as untyped."""
    return cls(channel)


__all__ = [
    "clouds_pb2",
    "clouds_pb2_grpc",
    "common_pb2",
    "ewave_pb2",
    "ewave_pb2_grpc",
    "ocean_pb2",
    "ocean_pb2_grpc",
    "server_pb2",
    "server_pb2_grpc",
    "textures_pb2",
    "textures_pb2_grpc",
    "rpc_client",
]
