"""What the client sends with every call, seen by an in-process gRPC server standing in for
squalld: "authorization: Bearer <token>", "x-request-id" and, on a session's calls,
"x-squall-session"."""

from __future__ import annotations

import asyncio
from concurrent import futures
from typing import Dict, List, Tuple

import grpc
import pytest

import squall
import squall.aio
from squall.v1 import ewave_pb2, server_pb2


class Recorder(grpc.GenericRpcHandler):
    """Answers Server.GetInfo and EWave.Step with empty replies, EWave.GetState with NOT_FOUND, and
    records each call's method and metadata."""

    def __init__(self) -> None:
        self.calls: List[Tuple[str, Dict[str, str]]] = []

    def service(self, details: grpc.HandlerCallDetails):
        self.calls.append((details.method, dict(details.invocation_metadata)))
        if details.method == "/squall.v1.Server/GetInfo":
            return grpc.unary_unary_rpc_method_handler(
                lambda request, context: server_pb2.GetInfoResponse(version="fake"),
                request_deserializer=server_pb2.GetInfoRequest.FromString,
                response_serializer=server_pb2.GetInfoResponse.SerializeToString,
            )
        if details.method == "/squall.v1.EWave/Step":
            return grpc.unary_unary_rpc_method_handler(
                lambda request, context: ewave_pb2.EWaveFrame(
                    session_id=request.session_id, step=1
                ),
                request_deserializer=ewave_pb2.EWaveStepRequest.FromString,
                response_serializer=ewave_pb2.EWaveFrame.SerializeToString,
            )
        if details.method == "/squall.v1.EWave/GetState":

            def not_found(request, context):
                context.abort(grpc.StatusCode.NOT_FOUND, "session_id: no session abc")

            return grpc.unary_unary_rpc_method_handler(
                not_found,
                request_deserializer=ewave_pb2.EWaveSessionRequest.FromString,
                response_serializer=ewave_pb2.EWaveStateResponse.SerializeToString,
            )
        return None


@pytest.fixture()
def fake():
    recorder = Recorder()
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=2), handlers=[recorder])
    port = server.add_insecure_port("127.0.0.1:0")
    server.start()
    yield recorder, f"127.0.0.1:{port}"
    server.stop(None)


def test_token_request_id_and_session_metadata(fake) -> None:
    recorder, address = fake
    with squall.Client(address, token="s3cret", request_id="req-7") as client:
        assert client.info().version == "fake"
        frame = client.ewave.attach("abc").step(0.1)
        assert frame.step == 1 and frame.session_id == "abc"
        with pytest.raises(squall.SquallError) as error:
            client.ewave.attach("abc").state()
    assert error.value.code == grpc.StatusCode.NOT_FOUND
    assert (
        error.value.message == "session_id: no session abc"
        and error.value.method == "EWave.GetState"
    )
    (info, info_md), (step, step_md), _ = recorder.calls
    assert info == "/squall.v1.Server/GetInfo" and step == "/squall.v1.EWave/Step"
    for md in (info_md, step_md):
        assert md["authorization"] == "Bearer s3cret" and md["x-request-id"] == "req-7"
    assert "x-squall-session" not in info_md and step_md["x-squall-session"] == "abc"

    recorder.calls.clear()
    with squall.Client(address) as client:  # no token: no authorization header
        client.info()
    assert (
        "authorization" not in recorder.calls[0][1] and "x-request-id" not in recorder.calls[0][1]
    )


def test_aio_sends_the_same_metadata(fake) -> None:
    recorder, address = fake

    async def main():
        async with squall.aio.Client(address, token="t0k") as client:
            await client.info()
            await client.ewave.attach("def").step(0.1)

    asyncio.run(main())
    assert recorder.calls[0][1]["authorization"] == "Bearer t0k"
    assert recorder.calls[1][1]["x-squall-session"] == "def"


def test_unreachable_server_is_unavailable() -> None:
    with squall.Client("127.0.0.1:1", timeout=2) as client:
        with pytest.raises(squall.SquallError) as error:
            client.info()
        assert error.value.code in (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED)
        assert not client.wait_until_serving(0.3)


def test_a_request_id_past_getinfos_128_bytes_goes_as_metadata_only(daemon) -> None:
    """GetInfo.request_id holds at most 128 bytes; the client sends its request id as x-request-id
    on every call, so info() works with a longer one, as every other call does."""
    long_id = "r" * 300
    with squall.Client(daemon.address, request_id=long_id) as client:
        assert client.info().ready

    async def main() -> bool:
        async with squall.aio.Client(daemon.address, request_id=long_id) as client:
            return (await client.info()).ready

    assert asyncio.run(main())
