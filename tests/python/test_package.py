"""The package without a daemon: generated modules, the Field codec, enum and message conversion, the
StreamTiles frame assembler, streams and steering streams over fake calls, and the hand-encoded
health messages."""

from __future__ import annotations

import asyncio
import pickle
import struct
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Iterable, List

import grpc
import numpy as np
import pytest

import squall
import squall.aio
from squall import _convert
from squall.client import decode_health_response, encode_health_request
from squall.ocean import TileAssembler
from squall.v1 import common_pb2, ewave_pb2, ocean_pb2, textures_pb2

PROTO_DIR = Path(__file__).resolve().parents[2] / "proto" / "squall" / "v1"


def test_grpc_modules_are_generated_into_the_installed_package() -> None:
    import squall.v1

    package = Path(squall.__file__).parent
    generated = Path(squall.v1.__file__).parent
    assert generated.parent == package
    # one message module and one gRPC module per proto, nothing checked in next to the sources
    for proto in PROTO_DIR.glob("*.proto"):
        assert (generated / f"{proto.stem}_pb2.py").is_file()
        assert (generated / f"{proto.stem}_pb2_grpc.py").is_file()
    from squall.v1 import (
        clouds_pb2_grpc,
        ewave_pb2_grpc,
        ocean_pb2_grpc,
        server_pb2_grpc,
        textures_pb2_grpc,
    )

    assert hasattr(ocean_pb2_grpc, "OceanStub") and hasattr(ewave_pb2_grpc, "EWaveStub")
    assert hasattr(clouds_pb2_grpc, "CloudsStub") and hasattr(textures_pb2_grpc, "TexturesStub")
    assert hasattr(server_pb2_grpc, "ServerStub")
    # proto3 `optional` has presence (protoc >= 3.15)
    layer = ocean_pb2.LayerSpec()
    assert not layer.HasField("peak_enhancement")
    layer.peak_enhancement = 3.3
    assert layer.HasField("peak_enhancement")


def test_field_codec_is_little_endian_x_fastest() -> None:
    a = np.arange(12, dtype=np.float32).reshape(3, 4) * 0.5  # ny = 3, nx = 4
    f = squall.array_to_field(a, "height", "m", spacing=(2.0, 3.0), origin=(1.0, 1.0, 0.0))
    assert (f.nx, f.ny, f.nz, f.dtype) == (4, 3, 0, common_pb2.DTYPE_FLOAT32)
    assert f.data == struct.pack("<12f", *a.ravel().tolist())  # value (i, j) at i + nx j
    assert (f.spacing.x, f.spacing.y, f.spacing.z) == (2.0, 3.0, 0.0)
    back = squall.field_to_array(f)
    assert back.dtype == np.float32 and back.shape == (3, 4) and back.flags.writeable
    assert np.array_equal(back, a)

    h = squall.array_to_field(a, dtype="float16")
    assert h.dtype == common_pb2.DTYPE_FLOAT16
    assert h.data == a.astype("<f2").tobytes()
    assert np.array_equal(squall.field_to_array(h), a.astype(np.float16))

    cube = np.random.default_rng(1).random((2, 3, 4)).astype(np.float32)
    c = squall.array_to_field(cube)
    assert (c.nx, c.ny, c.nz) == (4, 3, 2)
    assert np.array_equal(squall.field_to_array(c), cube)

    with pytest.raises(ValueError, match="data has 8 bytes"):
        squall.field_to_array(common_pb2.Field(nx=4, ny=3, data=b"\0" * 8))
    with pytest.raises(ValueError, match="shape"):
        squall.array_to_field(np.zeros(5))


def test_enum_names() -> None:
    spectrum = ocean_pb2.SpectrumModel.DESCRIPTOR
    assert _convert.enum_value(spectrum, "jonswap") == ocean_pb2.SPECTRUM_MODEL_JONSWAP
    assert (
        _convert.enum_value(spectrum, "pierson-moskowitz")
        == ocean_pb2.SPECTRUM_MODEL_PIERSON_MOSKOWITZ
    )
    assert _convert.enum_value(spectrum, "SPECTRUM_MODEL_TMA") == ocean_pb2.SPECTRUM_MODEL_TMA
    assert _convert.enum_value(spectrum, 6) == ocean_pb2.SPECTRUM_MODEL_MULTIPEAK
    method = textures_pb2.TextureMethod.DESCRIPTOR
    assert (
        _convert.enum_value(method, "lagrangian") == textures_pb2.TEXTURE_METHOD_LAGRANGIAN_GRIDS
    )
    assert (
        _convert.enum_value(method, "eulerian") == textures_pb2.TEXTURE_METHOD_EULERIAN_MULTILAYER
    )
    with pytest.raises(ValueError, match="jonswap"):  # the choices are listed
        _convert.enum_value(spectrum, "jonswop")
    with pytest.raises(ValueError):
        _convert.enum_value(spectrum, 99)


def test_messages_from_mappings() -> None:
    request = _convert.to_message(
        ewave_pb2.EWaveStepRequest,
        {
            "session_id": "ab",
            "inputs": {"dt": 0.1, "obstruction": np.ones((2, 3)), "outputs": ["height", "phi"]},
        },
    )
    assert request.inputs.obstruction.nx == 3 and request.inputs.obstruction.ny == 2
    assert list(request.inputs.outputs) == [
        ewave_pb2.EWAVE_OUTPUT_HEIGHT,
        ewave_pb2.EWAVE_OUTPUT_PHI,
    ]
    spec = _convert.to_message(
        ocean_pb2.GetTileRequest, {"time": 2.5, "tile": {"layers": [{"nx": 8}]}}
    )
    assert spec.time.seconds == 2.5 and spec.tile.layers[0].nx == 8
    # an empty sub-message is present (a oneof member with its defaults)
    source = _convert.to_message(textures_pb2.TextureSource, {"noise": {}})
    assert source.WhichOneof("source") == "noise"
    with pytest.raises(TypeError, match="no field 'wind'"):
        _convert.to_message(ocean_pb2.LayerSpec, {"wind": 3})
    layer = squall.ocean.layer(
        extent=(200, 100), n=(64, 32), peak_enhancement=2.0, partials=[(0.8, 2.0)]
    )
    assert (layer.extent_x, layer.extent_y, layer.nx, layer.ny) == (200, 100, 64, 32)
    assert layer.HasField("peak_enhancement") and not layer.HasField("gravity")
    assert layer.partials[0].significant_wave_height == 2.0


def _piece(name: str, rows: np.ndarray, row_offset: int, full_ny: int) -> ocean_pb2.FieldPiece:
    field = squall.array_to_field(rows, name, "m")
    field.origin.y = float(row_offset)
    return ocean_pb2.FieldPiece(field=field, row_offset=row_offset, full_ny=full_ny)


def test_tile_assembler_joins_pieces_and_checks_order() -> None:
    rng = np.random.default_rng(2)
    a, b = rng.random((6, 4)).astype(np.float32), rng.random((6, 4)).astype(np.float32)
    chunks = [
        ocean_pb2.TileChunk(
            frame_index=0,
            chunk_index=0,
            chunk_count=3,
            pieces=[_piece("a", a, 0, 6), _piece("b", b[:2], 0, 6)],
        ),
        ocean_pb2.TileChunk(
            frame_index=0, chunk_index=1, chunk_count=3, pieces=[_piece("b", b[2:5], 2, 6)]
        ),
        ocean_pb2.TileChunk(
            frame_index=0, chunk_index=2, chunk_count=3, pieces=[_piece("b", b[5:], 5, 6)]
        ),
    ]
    chunks[0].time.seconds = 1.5
    chunks[0].stats.unresolved_slope_variance = 0.25
    assembler = TileAssembler()
    assert assembler.add(chunks[0]) is None and assembler.add(chunks[1]) is None
    tile = assembler.add(chunks[2])
    assert tile is not None and list(tile) == ["a", "b"]
    assert np.array_equal(tile["a"], a) and np.array_equal(tile["b"], b)
    assert tile.time == 1.5 and tile.unresolved_slope_variance == 0.25
    assert tile.origin["b"] == (0.0, 0.0, 0.0)  # the first piece's origin is the field's
    with pytest.raises(squall.SquallError, match="out of sequence") as error:
        TileAssembler().add(chunks[1])
    assert error.value.code == grpc.StatusCode.INTERNAL


def _chunk(
    frame: int, index: int, count: int, *pieces: ocean_pb2.FieldPiece
) -> ocean_pb2.TileChunk:
    return ocean_pb2.TileChunk(
        frame_index=frame, chunk_index=index, chunk_count=count, pieces=pieces
    )


def _frame(frame: int, count: int = 2) -> List[ocean_pb2.TileChunk]:
    """The `count` chunks of one frame: field "h" of `count` rows of 4 values, a row a chunk."""
    rows = np.arange(4 * count, dtype=np.float32).reshape(count, 4) + frame
    return [_chunk(frame, k, count, _piece("h", rows[k : k + 1], k, count)) for k in range(count)]


def test_tile_assembler_refuses_a_frame_begun_before_the_last_is_complete() -> None:
    """Chunk 0 of a frame while another is half-built would drop that frame without a word."""
    for restarted in (_frame(1)[0], _frame(0)[0]):
        assembler = TileAssembler()
        assert assembler.add(_frame(0)[0]) is None
        with pytest.raises(
            squall.SquallError,
            match=rf"frame {restarted.frame_index} began after chunk 0 of the 2 chunks of frame 0",
        ) as error:
            assembler.add(restarted)
        assert error.value.code == grpc.StatusCode.INTERNAL
        assert error.value.method == "Ocean.StreamTiles"


@pytest.mark.parametrize("index", [0, 1, 3])  # back, again, a frame skipped
def test_tile_assembler_wants_each_frame_index_one_more_than_the_last(index: int) -> None:
    assembler = TileAssembler()
    for frame in (0, 1):
        tiles = [assembler.add(c) for c in _frame(frame)]
        assert tiles[0] is None and tiles[1] is not None and tiles[1].frame_index == frame
    with pytest.raises(squall.SquallError, match=rf"frame {index} follows frame 1") as error:
        assembler.add(_frame(index)[0])
    assert error.value.code == grpc.StatusCode.INTERNAL


def test_tile_assembler_checks_each_piece_as_it_arrives() -> None:
    """A piece whose bytes disagree with its header is refused with its chunk, as a SquallError,
    not as a ValueError once the frame is joined."""
    short = _frame(0)
    short[0].pieces[0].field.data = short[0].pieces[0].field.data[:-4]
    with pytest.raises(
        squall.SquallError, match=r"piece of h at row 0 has 12 bytes, want .* \* 4 = 16"
    ) as error:
        TileAssembler().add(short[0])
    assert error.value.code == grpc.StatusCode.INTERNAL
    whole = _chunk(0, 0, 1, _piece("h", np.zeros((2, 4), np.float32), 0, 2))
    whole.pieces[0].field.data += b"\0\0\0\0"
    with pytest.raises(squall.SquallError, match=r"has 36 bytes, want .* = 32"):
        TileAssembler().add(whole)
    mixed = _frame(0)  # the second row sent as float16 (its own bytes agree with its dtype)
    mixed[1].pieces[0].field.CopyFrom(squall.array_to_field(np.ones((1, 4)), "h", dtype="float16"))
    assembler = TileAssembler()
    assert assembler.add(mixed[0]) is None
    with pytest.raises(squall.SquallError, match=r"row 1 has dtype 2 and nz 0, the field dtype 1"):
        assembler.add(mixed[1])
    unknown = _frame(0, 1)
    unknown[0].pieces[0].field.dtype = 7
    with pytest.raises(squall.SquallError, match=r"field h has dtype 7, not float32 or float16"):
        TileAssembler().add(unknown[0])


def test_tile_assembler_finish_refuses_a_half_built_frame() -> None:
    assembler = TileAssembler()
    assert [assembler.add(c) is None for c in _frame(0)] == [True, False]
    assembler.finish()  # between frames: nothing pending
    assert assembler.add(_frame(1)[0]) is None
    with pytest.raises(
        squall.SquallError, match=r"the stream ended after chunk 0 of the 2 chunks of frame 1"
    ) as error:
        assembler.finish()
    assert error.value.code == grpc.StatusCode.INTERNAL
    assembler.finish()  # the half-built frame was reported once and dropped


class FakeCall:
    """A gRPC call that answers `replies` in order, then ends normally: the sync and asyncio
    faces of a server-streaming and a bidirectional call."""

    def __init__(self, replies: Iterable[Any]) -> None:
        self._replies = iter(replies)
        self.written: List[Any] = []
        self.cancelled = False

    def __iter__(self) -> "FakeCall":
        return self

    def __next__(self) -> Any:
        return next(self._replies)

    def __aiter__(self) -> "FakeCall":
        return self

    async def __anext__(self) -> Any:
        try:
            return next(self._replies)
        except StopIteration:
            raise StopAsyncIteration from None

    async def write(self, message: Any) -> None:
        self.written.append(message)

    async def read(self) -> Any:
        return next(self._replies, grpc.aio.EOF)

    def cancel(self) -> bool:
        self.cancelled = True
        return True


def test_an_ocean_stream_that_ends_inside_a_frame_raises() -> None:
    """A stream whose call ends normally with a frame half-built raises SquallError INTERNAL,
    sync and asyncio, instead of stopping as if every frame had come."""
    chunks = _frame(0) + _frame(1)[:1]
    spec = squall.ocean.tile_spec()
    with squall.Client(NOTHING_LISTENS) as client:
        client.ocean._rpc = SimpleNamespace(StreamTiles=lambda request, **_: FakeCall(chunks))
        stream = client.ocean.stream(spec, dt=0.1, frames=2)
        assert next(stream).frame_index == 0
        with pytest.raises(squall.SquallError, match=r"ended after chunk 0 of the 2") as error:
            next(stream)
        assert error.value.code == grpc.StatusCode.INTERNAL
        assert error.value.method == "Ocean.StreamTiles"

    async def read_all() -> List[int]:
        frames: List[int] = []
        async with squall.aio.Client(NOTHING_LISTENS) as aclient:
            aclient.ocean._rpc = SimpleNamespace(
                StreamTiles=lambda request, **_: FakeCall(chunks)
            )
            with pytest.raises(squall.SquallError, match=r"ended after chunk 0 of the 2"):
                async for tile in aclient.ocean.stream(spec, dt=0.1, frames=2):
                    frames.append(tile.frame_index)
        return frames

    assert asyncio.run(read_all()) == [0]


def _texture_replies() -> List[textures_pb2.TextureFrame]:
    """Frames 0 .. 3 of a steering stream; frame 1's plane is a byte short (fails conversion)."""
    replies = [
        textures_pb2.TextureFrame(
            index=i, planes=[squall.array_to_field(np.zeros((2, 2)), "final", "1")]
        )
        for i in range(4)
    ]
    replies[1].planes[0].data = replies[1].planes[0].data[:-1]
    return replies


def test_a_steering_stream_ends_when_a_frame_fails_conversion() -> None:
    """send(frames=3) failing at frame 1 cancels the stream: the next send raises instead of
    returning frame 2, left over from the failed send."""
    call = FakeCall(_texture_replies())
    with squall.Client(NOTHING_LISTENS) as client:
        client.textures._rpc = SimpleNamespace(AdvectInteractive=lambda requests, **_: call)
        stream = client.textures.interactive(size=(8, 8))
        with pytest.raises(ValueError, match=r"planes\.final\.data has 15 bytes"):
            stream.send(frames=3)
        with pytest.raises(squall.SquallError, match="the stream has ended") as error:
            stream.send(frames=1)
        assert error.value.code == grpc.StatusCode.FAILED_PRECONDITION and call.cancelled
        stream.close()


def test_an_asyncio_steering_stream_ends_when_a_frame_fails_conversion() -> None:
    call = FakeCall(_texture_replies())

    async def steer() -> None:
        async with squall.aio.Client(NOTHING_LISTENS) as client:
            client.textures._rpc = SimpleNamespace(AdvectInteractive=lambda **_: call)
            stream = client.textures.interactive(size=(8, 8))
            with pytest.raises(ValueError, match=r"planes\.final\.data has 15 bytes"):
                await stream.send(frames=3)
            with pytest.raises(squall.SquallError, match="the stream has ended") as error:
                await stream.send(frames=1)
            assert error.value.code == grpc.StatusCode.FAILED_PRECONDITION and call.cancelled
            await stream.close()

    asyncio.run(steer())


def test_health_messages() -> None:
    assert encode_health_request("") == b""
    assert encode_health_request("squall.v1.Ocean") == b"\x0a\x0fsquall.v1.Ocean"
    assert decode_health_response(b"\x08\x01") == "SERVING"
    assert decode_health_response(b"\x08\x02") == "NOT_SERVING"
    assert decode_health_response(b"") == "UNKNOWN"
    name = "s" * 200  # a length of two varint bytes
    assert encode_health_request(name) == b"\x0a\xc8\x01" + name.encode()
    unknown_first = b"\x12\x03abc" + b"\x19" + bytes(8) + b"\x08\x02"  # fields 2 and 3, then 1
    assert decode_health_response(unknown_first) == "NOT_SERVING"
    for truncated in (b"\x08", b"\x12\x05ab", b"\x19\x00"):
        with pytest.raises(ValueError):
            decode_health_response(truncated)


def test_error_text() -> None:
    error = squall.SquallError(grpc.StatusCode.NOT_FOUND, "no such session", "EWave.Step")
    assert str(error) == "EWave.Step: NOT_FOUND: no such session"
    assert error.code_name == "NOT_FOUND" and error.message == "no such session"


def test_an_error_pickles_with_its_code_method_and_replica() -> None:
    """Errors cross process pools (concurrent.futures, multiprocessing) as pickles."""
    metadata = (("x-squall-replica", "host:pid7"), ("x-request-id", "r1"))
    error = squall.SquallError(
        grpc.StatusCode.NOT_FOUND, "no such session", "EWave.Step", metadata
    )
    copy = pickle.loads(pickle.dumps(error))
    assert (copy.code, copy.message, copy.method, copy.metadata) == (
        grpc.StatusCode.NOT_FOUND,
        "no such session",
        "EWave.Step",
        metadata,
    )
    assert str(copy) == str(error) and copy.replica == "host:pid7"
    assert squall.SquallError(grpc.StatusCode.INTERNAL, "x").replica == ""


NOTHING_LISTENS = "127.0.0.1:1"


@pytest.mark.parametrize("timeout", [float("nan"), -1.0, 0.0])
def test_a_deadline_that_expires_at_once_is_refused_naming_it(timeout: float) -> None:
    with pytest.raises(ValueError, match=r"^timeout = .*: a number of seconds > 0, inf or None"):
        squall.Client(NOTHING_LISTENS, timeout=timeout)
    with pytest.raises(ValueError, match=r"^stream_timeout = "):
        squall.Client(NOTHING_LISTENS, stream_timeout=timeout)
    with squall.Client(NOTHING_LISTENS) as client, pytest.raises(ValueError, match=r"^timeout = "):
        client.info(timeout=timeout)


@pytest.mark.parametrize("timeout", ["5", True])
def test_a_deadline_that_is_no_number_is_refused_naming_it(timeout: object) -> None:
    with pytest.raises(TypeError, match=r"^timeout must be a number of seconds or None"):
        squall.Client(NOTHING_LISTENS, timeout=timeout)  # type: ignore[arg-type]


def test_a_token_gRPC_cannot_send_is_refused_without_quoting_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """gRPC refuses a metadata value that is not printable ASCII; squall says so first."""
    for token in ("s3cret\n", "s3crét"):
        with pytest.raises(ValueError) as refused:
            squall.Client(NOTHING_LISTENS, token=token)
        assert "s3cr" not in str(refused.value) and "the token" in str(refused.value)
    with pytest.raises(ValueError, match="request_id holds a character"):
        squall.Client(NOTHING_LISTENS, request_id="a\tb")
    monkeypatch.setenv("SQUALL_TOKEN", "s3cret\n")
    with pytest.raises(ValueError, match="the token holds a character"):
        squall.Client(NOTHING_LISTENS)


def test_a_restore_takes_the_bytes_of_a_state() -> None:
    """bytes(5) is five zero bytes: a number is refused, not sent."""
    assert squall.ewave.restore_request(b"\x01\x02").state == b"\x01\x02"
    assert squall.ewave.restore_request(memoryview(b"ab")).state == b"ab"
    assert squall.ewave.restore_request(np.frombuffer(b"xyz", np.uint8)).state == b"xyz"
    with pytest.raises(TypeError, match="state must be the bytes of a state"):
        squall.ewave.restore_request(5)


def test_a_closed_client_says_so() -> None:
    client = squall.Client(NOTHING_LISTENS)
    client.close()
    with pytest.raises(RuntimeError, match="this squall client is closed"):
        client.info()


async def _closed_aio_client() -> None:
    client = squall.aio.Client(NOTHING_LISTENS)
    await client.close()
    await client.info()


def test_a_closed_asyncio_client_says_so() -> None:
    import asyncio

    with pytest.raises(RuntimeError, match="this squall client is closed"):
        asyncio.run(_closed_aio_client())


# What grpcio-health-checking's grpc_health/v1/health_pb2.py registers: grpc.health.v1's
# messages, from a file of another name than proto/grpc/health/v1/health.proto.
OTHER_HEALTH_MODULE = """
from google.protobuf import descriptor_pb2, descriptor_pool

f = descriptor_pb2.FileDescriptorProto(
    name="grpc_health/v1/health.proto", package="grpc.health.v1", syntax="proto3"
)
request = f.message_type.add(name="HealthCheckRequest")
request.field.add(name="service", number=1, type=9, label=1)  # string
f.message_type.add(name="HealthCheckResponse")
descriptor_pool.Default().AddSerializedFile(f.SerializeToString())
"""


def test_squall_imports_beside_another_module_of_the_health_messages() -> None:
    """A process that has grpcio-health-checking's health messages imports squall and checks
    health: squall registers no grpc.health.v1 messages of its own (a generated module of them
    failed this import with a conflict in protobuf's default pool)."""
    script = OTHER_HEALTH_MODULE + """
import squall
import squall.aio
from squall.client import decode_health_response, encode_health_request
assert encode_health_request("squall.v1.Ocean") == b"\\x0a\\x0fsquall.v1.Ocean"
assert decode_health_response(b"\\x08\\x01") == "SERVING"
print("imported")
"""
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert result.returncode == 0 and "imported" in result.stdout, result.stderr
