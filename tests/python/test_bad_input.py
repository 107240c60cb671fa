"""A bad input sweep of every squalld RPC: malformed requests are refused, and harm nothing.

For every RPC (Server, Ocean, EWave, Clouds, Textures) a table of malformed requests, each a fresh
VALID base request with one field broken (NaN / inf, zero or negative sizes, grids past
--max-grid-cells, maps whose data is not nx * ny values, enum values outside the enum, unknown,
empty, 1 MiB or newline-carrying ids, malformed x-squall-session metadata, forged state bytes),
sent through the raw generated stubs. Each case asserts:

- the gRPC status code (INVALID_ARGUMENT, NOT_FOUND, RESOURCE_EXHAUSTED, as validate.h, limits.h
  and the protos prescribe), and for a stream the error raised while consuming it, after the
  frames of the messages before the bad one;
- that the status message names the offending field (the path the server's validation prints,
  e.g. "tile.layers[0].wind_speed");
- that the message stays short (< 2000 characters, also for a 1 MiB id) and on one line.

After the sweep the daemon must still be running and SERVING (gRPC health), answer the same normal
requests of every service with the same bytes as before the sweep (an ocean tile, samples and
stream, an eWave session's frames, a cloud render, texture frames, a river bake, a deformation),
still hold the eWave session the bad steps were aimed at unchanged (a failed step does not
advance it), give out both of its --max-streams slots at once (no slot leaked by a refused stream),
and its request log must hold no line forged by a newline in a client's string.

A second, smaller table holds finite but extreme values (1e300, 1e-300, t0 = 1e19, ...): either a
refusal naming the field or a prompt reply with only finite numbers is right. They run on a
throwaway squalld: a runaway handler (such values once made some compute forever) cannot then hold
the sweep's daemon.

Input that the server accepts where it should not, or answers badly (a crash, INTERNAL, NaN, no
answer, a message naming the wrong field or quoting a client's string whole), would be kept with the
correct expectation and marked xfail(strict=True), its reason saying what the server does instead;
every such case found so far has been fixed.

The sweep runs on a squalld of its own (module scope, started with conftest's helper): a crash or a
leaked slot then cannot spill into other modules' shared daemon, and small limits
(--max-grid-cells 65536, --max-streams 2) make the oversize cases and the slot check cheap.
"""

from __future__ import annotations

import dataclasses
import math
import re
import struct
import zlib
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence, Tuple

import grpc
import numpy as np
import pytest
from google.protobuf.message import Message

import squall
from squall._calls import CHANNEL_OPTIONS
from squall._convert import is_repeated
from squall.v1 import (
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

from conftest import Daemon, _start

MAX_GRID_CELLS = 65536  # this module's --max-grid-cells: 256 x 256
TIMEOUT = 60.0
INVALID = grpc.StatusCode.INVALID_ARGUMENT
NOT_FOUND = grpc.StatusCode.NOT_FOUND
EXHAUSTED = grpc.StatusCode.RESOURCE_EXHAUSTED
NAN, INF = math.nan, math.inf
U32 = 4294967295  # the largest uint32: refusals echo it as sent

BIG_ID = "0123456789abcdef" * (1 << 16)  # 1 MiB of hex digits
UNKNOWN_ID = "0123456789abcdef" * 2  # well-formed (32 hex digits), never handed out
NEWLINE_ID = "0123456789abcdef\nFORGED log line: a client's newline"
FORGED = "FORGED"  # no line of the daemon's log may start with it

# A change breaks a fresh base request in place: change(request, env). It may take ids from the Env
# (FromEnv values); env is None where the request needs none.
Change = Callable[[Any, Optional["Env"]], None]
Metadata = Tuple[Tuple[str, str], ...]


# ---- building requests ---------------------------------------------------------------------


def vec3(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> common_pb2.Vec3:
    return common_pb2.Vec3(x=x, y=y, z=z)


def vec2(x: float, y: float) -> textures_pb2.Vec2:
    return textures_pb2.Vec2(x=x, y=y)


def grid_field(
    nx: int,
    ny: int,
    value: float = 0.0,
    *,
    values: Optional[np.ndarray] = None,
    dtype: int = common_pb2.DTYPE_FLOAT32,
) -> common_pb2.Field:
    """An nx x ny Field of `values` (row-major, x fastest), or of `value` everywhere."""
    numpy_type = np.float16 if dtype == common_pb2.DTYPE_FLOAT16 else np.float32
    array = np.full((ny, nx), value) if values is None else np.asarray(values)
    return common_pb2.Field(
        nx=nx, ny=ny, dtype=dtype, data=np.ascontiguousarray(array, dtype=numpy_type).tobytes()
    )


_STEP = re.compile(r"^(\w+)(?:\[(\d+)\])?$")


def _steps(path: str) -> List[Tuple[str, Optional[int]]]:
    steps = []
    for token in path.split("."):
        match = _STEP.match(token)
        assert match, f"bad path step {token!r} in {path!r}"
        steps.append((match.group(1), None if match.group(2) is None else int(match.group(2))))
    return steps


def _target(request: Any, at: int) -> Any:
    """The message a change applies to: the request, or message `at` of a bidi stream's list."""
    return request[at] if isinstance(request, list) else request


def _walk(message: Any, steps: Sequence[Tuple[str, Optional[int]]]) -> Any:
    for name, index in steps:
        message = getattr(message, name)
        if index is not None:
            message = message[index]
    return message


@dataclasses.dataclass(frozen=True)
class FromEnv:
    """A value known once the daemon runs: the Env attribute of that name (an id)."""

    attribute: str


def put(path: str, given: Any, at: int = 0) -> Change:
    """Sets the field at `path` ("tile.layers[0].wind_speed", "outputs[1]") to `given`: a scalar,
    a message (copied in), a list (replaces a repeated field) or a FromEnv."""

    def change(request: Any, env: Optional[Env]) -> None:
        value = getattr(env, given.attribute) if isinstance(given, FromEnv) else given
        *parents, (name, index) = _steps(path)
        parent = _walk(_target(request, at), parents)
        if index is not None:
            container = getattr(parent, name)
            if isinstance(value, Message):
                container[index].CopyFrom(value)
            else:
                container[index] = value
        elif isinstance(value, Message):
            getattr(parent, name).CopyFrom(value)
        elif isinstance(value, list):
            container = getattr(parent, name)
            del container[:]
            container.extend(value)
        else:
            setattr(parent, name, value)

    return change


def drop(path: str, at: int = 0) -> Change:
    """Clears the field at `path` (unsets a message, an optional or a oneof member)."""

    def change(request: Any, env: Optional[Env]) -> None:
        *parents, (name, _) = _steps(path)
        _walk(_target(request, at), parents).ClearField(name)

    return change


def also(*changes: Change) -> Change:
    def change(request: Any, env: Optional[Env]) -> None:
        for c in changes:
            c(request, env)

    return change


def patch(offset: int, fmt: str, *values: Any) -> Change:
    """Overwrites bytes of an EWaveRestoreRequest's state at `offset` with struct `fmt` values."""

    def change(request: ewave_pb2.EWaveRestoreRequest, env: Optional[Env]) -> None:
        state = bytearray(request.state)
        struct.pack_into(fmt, state, offset, *values)
        request.state = bytes(state)

    return change


def resumed_with_another_dt(
    request: textures_pb2.AdvectTextureRequest, env: Optional[Env]
) -> None:
    """Resumes the frame-2 checkpoint of checkpointed_request() in that request with another dt."""
    assert env is not None
    request.CopyFrom(checkpointed_request())
    request.dt = 2 * request.dt if request.HasField("dt") else 0.1
    request.resume_state = env.checkpoint


# request_checkpoint.h: magic, format, the request's fingerprint (16 bytes), then the checksum
CHECKPOINT_HEADER = 24


def fnv1a(data: bytes) -> int:
    """64-bit FNV-1a (common/fnv1a.h), the checksum of a texture checkpoint's state."""
    h = 0xCBF29CE484222325
    for byte in data:
        h = ((h ^ byte) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def with_state(checkpoint: bytes, state: bytes) -> bytes:
    """`checkpoint`'s header (its checksum made again) with the advection state `state`."""
    return checkpoint[: CHECKPOINT_HEADER - 8] + struct.pack("<Q", fnv1a(state)) + state


def checkpoint_state_replaced(state: bytes) -> Change:
    """Resumes checkpointed_request() from its frame-2 checkpoint with the advection state after
    its header replaced by `state` (and a checksum that matches it)."""

    def change(request: textures_pb2.AdvectTextureRequest, env: Optional[Env]) -> None:
        assert env is not None
        request.CopyFrom(checkpointed_request())
        request.resume_state = with_state(env.checkpoint, state)

    return change


def flipped_checkpoint(byte: int) -> Change:
    """Resumes checkpointed_request() from its frame-2 checkpoint, one bit of `byte` flipped."""

    def change(request: textures_pb2.AdvectTextureRequest, env: Optional[Env]) -> None:
        assert env is not None
        damaged = bytearray(env.checkpoint)
        damaged[byte] ^= 0x04
        request.CopyFrom(checkpointed_request())
        request.resume_state = bytes(damaged)

    return change


def forged_checkpoint(index: int) -> Change:
    """Resumes checkpointed_request() from its frame-2 checkpoint with the frame index in it (an
    int64 after the header, the uint32 version and the uint8 "started" flag, as restore() of
    eulerian.cpp and lagrangian.cpp read it) forged, and its checksum made again to match."""

    def change(request: textures_pb2.AdvectTextureRequest, env: Optional[Env]) -> None:
        assert env is not None
        state = bytearray(env.checkpoint[CHECKPOINT_HEADER:])
        struct.pack_into("<q", state, 5, index)
        request.CopyFrom(checkpointed_request())
        request.resume_state = with_state(env.checkpoint, bytes(state))

    return change


def png_chunk(kind: bytes, data: bytes) -> bytes:
    crc = zlib.crc32(kind + data) & 0xFFFFFFFF
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)


def png_header(width: int, height: int) -> bytes:
    """A PNG whose header claims width x height 8-bit grey pixels, followed by almost no image
    data: enough for a reader to learn the size before it reads any row."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + png_chunk(b"IHDR", ihdr)
        + png_chunk(b"IDAT", zlib.compress(b"\0"))
        + png_chunk(b"IEND", b"")
    )


# ---- valid base requests (each call builds a fresh one) --------------------------------------


def ocean_layer() -> ocean_pb2.LayerSpec:
    return ocean_pb2.LayerSpec(
        extent_x=100.0,
        extent_y=100.0,
        nx=16,
        ny=16,
        spectrum=ocean_pb2.SPECTRUM_MODEL_JONSWAP,
        spreading=ocean_pb2.SPREADING_MODEL_MITSUYASU,
        dispersion=ocean_pb2.DISPERSION_MODEL_DEEP,
        wind_speed=10.0,
        wind_direction=0.3,
        fetch=1e5,
        depth=100.0,
        seed=3,
    )


def ocean_tile() -> ocean_pb2.TileSpec:
    return ocean_pb2.TileSpec(layers=[ocean_layer()], choppiness=1.0)


def get_tile_request() -> ocean_pb2.GetTileRequest:
    return ocean_pb2.GetTileRequest(
        tile=ocean_tile(),
        time=common_pb2.SimTime(seconds=1.5),
        outputs=[ocean_pb2.TILE_OUTPUT_HEIGHT, ocean_pb2.TILE_OUTPUT_DISPLACEMENT_X],
    )


def stream_tiles_request(frames: int = 2) -> ocean_pb2.StreamTilesRequest:
    return ocean_pb2.StreamTilesRequest(
        tile=ocean_tile(),
        t0=common_pb2.SimTime(seconds=0.5),
        dt=0.25,
        frame_count=frames,
        outputs=[ocean_pb2.TILE_OUTPUT_HEIGHT],
    )


def sample_surface_request() -> ocean_pb2.SampleSurfaceRequest:
    return ocean_pb2.SampleSurfaceRequest(
        tile=ocean_tile(),
        time=common_pb2.SimTime(seconds=2.0),
        points=[vec3(1.0, 2.0), vec3(50.0, 60.0)],
    )


EWAVE_N, EWAVE_DX = 16, 0.05


def ewave_config() -> ewave_pb2.EWaveConfig:
    return ewave_pb2.EWaveConfig(
        nx=EWAVE_N, ny=EWAVE_N, dx=EWAVE_DX, dy=EWAVE_DX, source_scale=1.0
    )


def create_session_request() -> ewave_pb2.EWaveCreateSessionRequest:
    return ewave_pb2.EWaveCreateSessionRequest(config=ewave_config())


def step_request(session_id: str) -> ewave_pb2.EWaveStepRequest:
    return ewave_pb2.EWaveStepRequest(
        session_id=session_id,
        inputs=ewave_pb2.EWaveInputs(
            dt=0.02,
            shapes=[
                ewave_pb2.EWaveShape(
                    circle=ewave_pb2.EWaveCircle(center_x=0.4, center_y=0.4, radius=0.1)
                )
            ],
            outputs=[ewave_pb2.EWAVE_OUTPUT_HEIGHT, ewave_pb2.EWAVE_OUTPUT_PHI],
        ),
    )


def ewave_map(value: float = 1.0) -> common_pb2.Field:
    return grid_field(EWAVE_N, EWAVE_N, value)


def cloud_model() -> clouds_pb2.CloudModel:
    return clouds_pb2.CloudModel(
        voxel_size=1.0, spheres=[clouds_pb2.SphereSpec(center=vec3(), radius=4.0)]
    )


def render_settings() -> clouds_pb2.RenderSettings:
    return clouds_pb2.RenderSettings(
        camera=clouds_pb2.CameraSpec(
            eye=vec3(0, -30, 0), look_at=vec3(), up=vec3(0, 0, 1), width=8, height=8
        ),
        step=0.5,
        wavelengths=[550e-9],
        extinction=[0.1],
        albedo=[0.9],
        lights=[
            clouds_pb2.LightSpec(
                kind=clouds_pb2.LIGHT_KIND_DIRECTIONAL, direction=vec3(1, 1, -1), intensity=[1.0]
            )
        ],
        shadow=clouds_pb2.SHADOW_MODE_NONE,
    )


def stream_evolution_request() -> clouds_pb2.StreamEvolutionRequest:
    return clouds_pb2.StreamEvolutionRequest(
        model=cloud_model(),
        evolution=clouds_pb2.EvolutionSpec(drift=vec3(1, 0, 0)),
        times=[0.0, 1.0],
        settings=render_settings(),
    )


def uniform_velocity(vx: float = 0.1) -> textures_pb2.VelocitySpec:
    return textures_pb2.VelocitySpec(
        named=textures_pb2.AnalyticVelocity(
            kind=textures_pb2.AnalyticVelocity.KIND_UNIFORM, velocity_x=vx
        )
    )


def grid_velocity() -> textures_pb2.VelocitySpec:
    """A 4 x 4 node grid of one frame, uniform (0.1, 0) du/s."""
    return textures_pb2.VelocitySpec(
        grid=textures_pb2.VelocityGrid(
            nx=4,
            ny=4,
            spacing=vec2(1 / 3, 1 / 3),
            frames=[
                textures_pb2.VelocityGridFrame(
                    time=0.0, u=grid_field(4, 4, 0.1), v=grid_field(4, 4, 0.0)
                )
            ],
        )
    )


def image_source(n: int = 8) -> textures_pb2.TextureSource:
    return textures_pb2.TextureSource(
        image=textures_pb2.ImageTexture(channels=[grid_field(n, n, 0.5), grid_field(n, n, 0.25)])
    )


def advect_request(frames: int = 2) -> textures_pb2.AdvectTextureRequest:
    return textures_pb2.AdvectTextureRequest(
        method=textures_pb2.TEXTURE_METHOD_NAIVE,
        velocity=uniform_velocity(),
        texture=textures_pb2.TextureSource(noise=textures_pb2.NoiseTexture(bands=2)),
        output=textures_pb2.TextureOutput(width=16, height=16),
        frames=frames,
        dt=0.1,
    )


def checkpointed_request() -> textures_pb2.AdvectTextureRequest:
    """advect_request() of 6 frames, every other frame with its checkpoint."""
    request = advect_request(frames=6)
    request.checkpoint_every = 2
    return request


def advect_controls() -> List[textures_pb2.TextureControl]:
    """A start message asking for one frame, then a steering message asking for one more."""
    return [
        textures_pb2.TextureControl(start=advect_request(frames=0), frames=1),
        textures_pb2.TextureControl(dt=0.2, frames=1),
    ]


def river() -> textures_pb2.RiverVelocity:
    """One straight channel along +x between y = 0 and y = 1, Q = 1 du^2/s."""
    return textures_pb2.RiverVelocity(
        channels=[
            textures_pb2.RiverChannel(
                left_bank=textures_pb2.Polyline(points=[vec2(0, 1), vec2(1, 1)]),
                right_bank=textures_pb2.Polyline(points=[vec2(0, 0), vec2(1, 0)]),
                flow_rate=1.0,
            )
        ]
    )


def bake_request() -> textures_pb2.BakeVelocityRequest:
    return textures_pb2.BakeVelocityRequest(
        river=river(),
        nx=16,
        ny=16,
        region=textures_pb2.TextureRegion(x0=0.0, y0=-0.5, x1=1.0, y1=1.5),
    )


DEFORM_N = 16


def deform_image(n: int = DEFORM_N) -> textures_pb2.ImageTexture:
    j, i = np.mgrid[0:n, 0:n]
    return textures_pb2.ImageTexture(
        channels=[grid_field(n, n, values=0.5 + 0.5 * np.sin(0.7 * i + 0.3 * j))]
    )


def rigidity(n: int = DEFORM_N) -> common_pb2.Field:
    j, i = np.mgrid[0:n, 0:n]
    inside = (i + 0.5 - n / 2) ** 2 + (j + 0.5 - n / 2) ** 2 < (n / 4) ** 2
    return grid_field(n, n, values=np.where(inside, 1.0, -1.0))


def deform_request(frames: int = 2) -> textures_pb2.DeformTextureRequest:
    return textures_pb2.DeformTextureRequest(
        texture=deform_image(),
        rigidity=rigidity(),
        control=textures_pb2.DEFORM_CONTROL_CONSTANT,
        d_mu=0.1,
        frames=frames,
        substeps=2,
    )


def deform_controls() -> List[textures_pb2.DeformControl]:
    return [
        textures_pb2.DeformControl(start=deform_request(frames=0), frames=1),
        textures_pb2.DeformControl(d_mu=0.2, frames=1),
    ]


# ---- the daemon, the ids the sweep aims at, and the normal replies it must keep --------------


@dataclasses.dataclass
class Env:
    daemon: Daemon
    channel: grpc.Channel
    session: str  # the eWave session the bad steps aim at
    state: bytes  # its GetState before the sweep
    run_session: str  # stepped by the good first message of the EWave.Run cases
    volume: str  # a stored cloud volume
    checkpoint: bytes  # checkpoint of frame 2 of checkpointed_request()
    before: Dict[str, List[bytes]]  # reference_replies() before the sweep


def reference_replies(channel: grpc.Channel, volume: str) -> Dict[str, List[bytes]]:
    """Normal requests of every service and the bytes they answer (all deterministic)."""
    ocean = ocean_pb2_grpc.OceanStub(channel)
    ewave = ewave_pb2_grpc.EWaveStub(channel)
    clouds = clouds_pb2_grpc.CloudsStub(channel)
    textures = textures_pb2_grpc.TexturesStub(channel)
    replies: Dict[str, List[bytes]] = {}
    tile = ocean.GetTile(get_tile_request(), timeout=TIMEOUT)
    replies["Ocean.GetTile"] = [f.data for f in tile.fields] + [
        struct.pack("<d", tile.stats.unresolved_slope_variance)
    ]
    chunks = ocean.StreamTiles(stream_tiles_request(), timeout=TIMEOUT)
    replies["Ocean.StreamTiles"] = [p.field.data for c in chunks for p in c.pieces]
    samples = ocean.SampleSurface(sample_surface_request(), timeout=TIMEOUT)
    replies["Ocean.SampleSurface"] = [samples.SerializeToString(deterministic=True)]
    session = ewave.CreateSession(create_session_request(), timeout=TIMEOUT).session_id
    try:
        frames = [ewave.Step(step_request(session), timeout=TIMEOUT) for _ in range(3)]
        replies["EWave.Step"] = [f.data for frame in frames for f in frame.fields]
        replies["EWave.GetState"] = [
            ewave.GetState(
                ewave_pb2.EWaveSessionRequest(session_id=session), timeout=TIMEOUT
            ).state
        ]
    finally:
        ewave.CloseSession(ewave_pb2.EWaveSessionRequest(session_id=session), timeout=TIMEOUT)
    stored = clouds.Render(
        clouds_pb2.RenderRequest(volume_id=volume, settings=render_settings()), timeout=TIMEOUT
    )
    inline = clouds.Render(
        clouds_pb2.RenderRequest(model=cloud_model(), settings=render_settings()), timeout=TIMEOUT
    )
    replies["Clouds.Render"] = [stored.image.data, inline.image.data]
    frames = textures.AdvectTexture(advect_request(), timeout=TIMEOUT)
    replies["Textures.AdvectTexture"] = [p.data for f in frames for p in f.planes]
    baked = textures.BakeVelocity(bake_request(), timeout=TIMEOUT)
    replies["Textures.BakeVelocity"] = [baked.u.data, baked.v.data, baked.fluid.data]
    deformed = textures.DeformTexture(deform_request(), timeout=TIMEOUT)
    replies["Textures.DeformTexture"] = [p.data for f in deformed for p in f.planes]
    return replies


@pytest.fixture(scope="module")
def sweep_daemon() -> Iterator[Daemon]:
    flags = ["--max-grid-cells", str(MAX_GRID_CELLS), "--max-streams", "2"]
    yield from _start(flags, "bad-input")


@pytest.fixture(scope="module")
def env(sweep_daemon: Daemon) -> Iterator[Env]:
    options = list(CHANNEL_OPTIONS) + [
        ("grpc.enable_retries", 0),  # the raw status of each call, never a retried one
        ("grpc.max_metadata_size", 16 << 20),  # an overlong status message arrives as sent
    ]
    channel = grpc.insecure_channel(sweep_daemon.address, options=options)
    ewave = ewave_pb2_grpc.EWaveStub(channel)
    clouds = clouds_pb2_grpc.CloudsStub(channel)
    session = ewave.CreateSession(create_session_request(), timeout=TIMEOUT).session_id
    for _ in range(2):
        ewave.Step(step_request(session), timeout=TIMEOUT)
    state = ewave.GetState(ewave_pb2.EWaveSessionRequest(session_id=session), timeout=TIMEOUT)
    run_session = ewave.CreateSession(create_session_request(), timeout=TIMEOUT).session_id
    volume = clouds.BuildVolume(
        clouds_pb2.BuildVolumeRequest(model=cloud_model(), keep=True), timeout=TIMEOUT
    ).summary.volume_id
    textures = textures_pb2_grpc.TexturesStub(channel)
    frames = list(textures.AdvectTexture(checkpointed_request(), timeout=TIMEOUT))
    checkpoint = frames[2].checkpoint
    before = reference_replies(channel, volume)
    yield Env(sweep_daemon, channel, session, state.state, run_session, volume, checkpoint, before)
    for close in (
        lambda: ewave.CloseSession(ewave_pb2.EWaveSessionRequest(session_id=session), timeout=10),
        lambda: ewave.CloseSession(
            ewave_pb2.EWaveSessionRequest(session_id=run_session), timeout=10
        ),
        lambda: clouds.ReleaseVolume(
            clouds_pb2.ReleaseVolumeRequest(volume_id=volume), timeout=10
        ),
    ):
        try:
            close()
        except grpc.RpcError:
            pass  # the daemon may be gone: test_daemon_is_unharmed says so
    channel.close()


# ---- the RPCs, their base requests, and how a call is made -----------------------------------

UNARY, SERVER_STREAM, BIDI = "unary", "server stream", "bidi stream"

RPCS: Dict[str, Tuple[Any, str, str]] = {
    "Server.GetInfo": (server_pb2_grpc.ServerStub, "GetInfo", UNARY),
    "Ocean.GetTile": (ocean_pb2_grpc.OceanStub, "GetTile", UNARY),
    "Ocean.StreamTiles": (ocean_pb2_grpc.OceanStub, "StreamTiles", SERVER_STREAM),
    "Ocean.SampleSurface": (ocean_pb2_grpc.OceanStub, "SampleSurface", UNARY),
    "EWave.CreateSession": (ewave_pb2_grpc.EWaveStub, "CreateSession", UNARY),
    "EWave.Step": (ewave_pb2_grpc.EWaveStub, "Step", UNARY),
    "EWave.Run": (ewave_pb2_grpc.EWaveStub, "Run", BIDI),
    "EWave.GetState": (ewave_pb2_grpc.EWaveStub, "GetState", UNARY),
    "EWave.Restore": (ewave_pb2_grpc.EWaveStub, "Restore", UNARY),
    "EWave.CloseSession": (ewave_pb2_grpc.EWaveStub, "CloseSession", UNARY),
    "Clouds.BuildVolume": (clouds_pb2_grpc.CloudsStub, "BuildVolume", UNARY),
    "Clouds.Render": (clouds_pb2_grpc.CloudsStub, "Render", UNARY),
    "Clouds.StreamEvolution": (clouds_pb2_grpc.CloudsStub, "StreamEvolution", SERVER_STREAM),
    "Clouds.ReleaseVolume": (clouds_pb2_grpc.CloudsStub, "ReleaseVolume", UNARY),
    "Textures.AdvectTexture": (textures_pb2_grpc.TexturesStub, "AdvectTexture", SERVER_STREAM),
    "Textures.AdvectInteractive": (textures_pb2_grpc.TexturesStub, "AdvectInteractive", BIDI),
    "Textures.BakeVelocity": (textures_pb2_grpc.TexturesStub, "BakeVelocity", UNARY),
    "Textures.DeformTexture": (textures_pb2_grpc.TexturesStub, "DeformTexture", SERVER_STREAM),
    "Textures.DeformInteractive": (textures_pb2_grpc.TexturesStub, "DeformInteractive", BIDI),
}

# The valid request of each RPC (a list of messages for a bidi stream); every case breaks one
# field of a fresh one.
BASES: Dict[str, Callable[[Env], Any]] = {
    "Server.GetInfo": lambda env: server_pb2.GetInfoRequest(request_id="bad-input-sweep"),
    "Ocean.GetTile": lambda env: get_tile_request(),
    "Ocean.StreamTiles": lambda env: stream_tiles_request(),
    "Ocean.SampleSurface": lambda env: sample_surface_request(),
    "EWave.CreateSession": lambda env: create_session_request(),
    "EWave.Step": lambda env: step_request(env.session),
    # a good step of another session, then the (broken) step of the sweep's session
    "EWave.Run": lambda env: [step_request(env.run_session), step_request(env.session)],
    "EWave.GetState": lambda env: ewave_pb2.EWaveSessionRequest(session_id=env.session),
    "EWave.Restore": lambda env: ewave_pb2.EWaveRestoreRequest(state=env.state),
    # (every CloseSession case replaces the id: none closes the sweep's session)
    "EWave.CloseSession": lambda env: ewave_pb2.EWaveSessionRequest(session_id=env.session),
    "Clouds.BuildVolume": lambda env: clouds_pb2.BuildVolumeRequest(model=cloud_model()),
    "Clouds.Render": lambda env: clouds_pb2.RenderRequest(
        volume_id=env.volume, settings=render_settings()
    ),
    "Clouds.StreamEvolution": lambda env: stream_evolution_request(),
    "Clouds.ReleaseVolume": lambda env: clouds_pb2.ReleaseVolumeRequest(volume_id=env.volume),
    "Textures.AdvectTexture": lambda env: advect_request(),
    "Textures.AdvectInteractive": lambda env: advect_controls(),
    "Textures.BakeVelocity": lambda env: bake_request(),
    "Textures.DeformTexture": lambda env: deform_request(),
    "Textures.DeformInteractive": lambda env: deform_controls(),
}


@dataclasses.dataclass(frozen=True)
class Case:
    rpc: str  # "Service.Method"
    name: str
    change: Change  # applied to a fresh base request
    code: grpc.StatusCode
    field: str  # the status message must contain it
    metadata: Metadata = ()
    frames: Optional[int] = None  # replies a stream sends before the error
    xfail: str = ""  # what the server does instead (a known server bug)

    def param(self) -> Any:
        marks = [pytest.mark.xfail(strict=True, reason=self.xfail)] if self.xfail else []
        return pytest.param(self, id=f"{self.rpc}-{self.name}", marks=marks)


def send(env: Env, case: Case) -> Tuple[List[Any], Optional[grpc.RpcError]]:
    """Sends the case's request and consumes the reply; returns the replies and the error."""
    stub, method, kind = RPCS[case.rpc]
    request = BASES[case.rpc](env)
    case.change(request, env)
    call = getattr(stub(env.channel), method)
    received: List[Any] = []
    try:
        if kind == UNARY:
            received.append(call(request, timeout=TIMEOUT, metadata=case.metadata))
        else:
            stream_request = iter(request) if kind == BIDI else request
            for reply in call(stream_request, timeout=TIMEOUT, metadata=case.metadata):
                received.append(reply)
    except grpc.RpcError as error:
        return received, error
    return received, None


def forget(env: Env, replies: Sequence[Any]) -> None:
    """Closes a session or releases a volume that a wrongly accepted request created."""
    for reply in replies:
        if isinstance(reply, ewave_pb2.EWaveSessionResponse) and reply.session_id:
            request = ewave_pb2.EWaveSessionRequest(session_id=reply.session_id)
            ewave_pb2_grpc.EWaveStub(env.channel).CloseSession(request, timeout=TIMEOUT)
        if isinstance(reply, clouds_pb2.BuildVolumeResponse) and reply.summary.volume_id:
            request = clouds_pb2.ReleaseVolumeRequest(volume_id=reply.summary.volume_id)
            clouds_pb2_grpc.CloudsStub(env.channel).ReleaseVolume(request, timeout=TIMEOUT)


# ---- the table ---------------------------------------------------------------------------------


def bad(
    rpc: str,
    name: str,
    change: Change,
    field: str,
    code: grpc.StatusCode = INVALID,
    **options: Any,
) -> Case:
    return Case(rpc, name, change, code, field, **options)


def tetrahedron(y2: float) -> clouds_pb2.MeshSpec:
    """A closed mesh of four vertices, the third at (0, y2, 0)."""
    return clouds_pb2.MeshSpec(
        vertices=[0, 0, 0, 4, 0, 0, 0, y2, 0, 0, 0, 4],
        triangles=[0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3],
    )


def nothing(request: Any, env: Optional[Env]) -> None:
    """No change: the request is valid, the case breaks its metadata."""


def session_metadata(value: str) -> Metadata:
    return (("x-squall-session", value),)


SESSION, VOLUME = FromEnv("session"), FromEnv("volume")  # live ids, of the other kind

CASES: List[Case] = []

# Server.GetInfo has one input, request_id ("free text, at most 128 characters"). A newline in it
# is accepted and must not forge a log line (test_newline_in_request_id_stays_in_its_log_line).
R = "Server.GetInfo"
CASES += [
    bad(
        R,
        "request_id_1MiB",
        put("request_id", BIG_ID),
        "request_id",
    ),
]

R = "Ocean.GetTile"
L0 = "tile.layers[0]"
CASES += [
    bad(R, "wind_speed_nan", put(f"{L0}.wind_speed", NAN), f"{L0}.wind_speed"),
    bad(R, "wind_speed_negative", put(f"{L0}.wind_speed", -1.0), f"{L0}.wind_speed"),
    bad(R, "extent_x_inf", put(f"{L0}.extent_x", INF), f"{L0}.extent_x"),
    bad(R, "extent_y_zero", put(f"{L0}.extent_y", 0.0), f"{L0}.extent_y"),
    bad(R, "fetch_negative", put(f"{L0}.fetch", -3.0), f"{L0}.fetch"),
    bad(R, "nx_odd", put(f"{L0}.nx", 15), f"{L0}.nx"),
    bad(R, "nx_zero", put(f"{L0}.nx", 0), f"{L0}.nx"),
    bad(
        R,
        "float16_too_narrow",  # heights of about 1e7 m: float16 would carry them as inf
        also(
            put(f"{L0}.extent_x", 1e6),
            put(f"{L0}.extent_y", 1e6),
            put(f"{L0}.spectrum", ocean_pb2.SPECTRUM_MODEL_PHILLIPS),
            put(f"{L0}.phillips_amplitude", 1000.0),
            put(f"{L0}.wind_speed", 100.0),
            put(f"{L0}.gravity", 1e-6),
            put("dtype", common_pb2.DTYPE_FLOAT16),
        ),
        "is past float16's largest finite value, 65504: ask for DTYPE_FLOAT32",
    ),
    bad(R, "ny_zero", put(f"{L0}.ny", 0), f"{L0}.ny = 0 must be even and >= 2"),
    bad(
        R,
        "layer_grid_oversize",
        also(put(f"{L0}.nx", 512), put(f"{L0}.ny", 512)),
        f"{L0}.nx * {L0}.ny",
        EXHAUSTED,
    ),
    bad(
        R,
        "output_grid_oversize",
        put("tile.output", ocean_pb2.OutputGrid(nx=1024, ny=1024)),
        "tile.output.nx * tile.output.ny",
        EXHAUSTED,
    ),
    bad(
        R,
        "output_nx_zero",
        put("tile.output", ocean_pb2.OutputGrid(nx=0, ny=16)),
        "tile.output.nx",
    ),
    bad(
        R,
        "output_extent_nan",
        put("tile.output", ocean_pb2.OutputGrid(extent_x=NAN, extent_y=100.0)),
        "tile.output.extent_x",
    ),
    bad(R, "spectrum_unknown_enum", put(f"{L0}.spectrum", 42), f"{L0}.spectrum"),
    bad(R, "spreading_unknown_enum", put(f"{L0}.spreading", 42), f"{L0}.spreading"),
    bad(R, "dispersion_unknown_enum", put(f"{L0}.dispersion", 42), f"{L0}.dispersion"),
    bad(R, "dispersion_unspecified", put(f"{L0}.dispersion", 0), f"{L0}.dispersion"),
    bad(R, "peak_enhancement_below_1", put(f"{L0}.peak_enhancement", 0.5), "peak_enhancement"),
    bad(R, "gravity_zero", put(f"{L0}.gravity", 0.0), f"{L0}.gravity"),
    bad(R, "drift_x_too_fast", put(f"{L0}.drift_x", 1000.0), f"{L0}.drift_x"),
    bad(R, "k_max_below_k_min", also(put(f"{L0}.k_min", 2.0), put(f"{L0}.k_max", 1.0)), "k_max"),
    bad(R, "k_max_zero_in_single_precision", put(f"{L0}.k_max", 1e-300), "k_max = 1e-300"),
    bad(
        R,
        "partials_without_multipeak",
        put(
            f"{L0}.partials",
            [ocean_pb2.PartialSpectrum(peak_frequency=1.0, significant_wave_height=1.0)],
        ),
        f"{L0}.partials",
    ),
    bad(
        R,
        "multipeak_without_partials",
        put(f"{L0}.spectrum", ocean_pb2.SPECTRUM_MODEL_MULTIPEAK),
        f"{L0}.partials",
    ),
    bad(R, "no_layers", put("tile.layers", []), "tile.layers"),
    bad(R, "nine_layers", put("tile.layers", [ocean_layer()] * 9), "tile.layers"),
    bad(R, "choppiness_huge", put("tile.choppiness", 1e9), "tile.choppiness"),
    bad(R, "whitecap_threshold_nan", put("tile.whitecap_threshold", NAN), "whitecap_threshold"),
    bad(R, "whitecap_decay_zero", put("tile.whitecap_decay_time", 0.0), "whitecap_decay_time"),
    bad(R, "pixel_scale_negative", put("tile.pixel_scale", -1.0), "tile.pixel_scale"),
    bad(R, "time_nan", put("time.seconds", NAN), "time.seconds"),
    bad(R, "outputs_empty", put("outputs", []), "outputs"),
    bad(R, "outputs_unknown_enum", put("outputs[0]", 99), "outputs[0]"),
    bad(R, "outputs_unspecified", put("outputs[1]", 0), "outputs[1]"),
    bad(R, "outputs_twice", put("outputs[1]", ocean_pb2.TILE_OUTPUT_HEIGHT), "outputs[1]"),
    bad(R, "dtype_unknown_enum", put("dtype", 7), "dtype"),
]

R = "Ocean.StreamTiles"
CASES += [
    bad(R, "dt_zero", put("dt", 0.0), "dt = "),
    bad(R, "dt_nan", put("dt", NAN), "dt = "),
    bad(R, "dt_negative", put("dt", -0.25), "dt = "),
    bad(R, "t0_inf", put("t0.seconds", INF), "t0.seconds"),
    bad(
        R,
        "last_frame_past_the_time_range",
        also(put("dt", 1e8), put("frame_count", 12)),
        "frame_count",
    ),
    bad(
        R,
        "endless_stream_past_the_time_range",
        also(put("dt", 1e9), put("frame_count", 0)),
        "frame_index",
    ),
    bad(R, "wind_speed_inf", put(f"{L0}.wind_speed", INF), f"{L0}.wind_speed"),
    bad(
        R,
        "layer_grid_oversize",
        also(put(f"{L0}.nx", 1024), put(f"{L0}.ny", 128)),
        f"{L0}.nx * {L0}.ny",
        EXHAUSTED,
    ),
    bad(R, "outputs_unspecified", put("outputs[0]", 0), "outputs[0]"),
    bad(R, "dtype_unknown_enum", put("dtype", 3), "dtype"),
]

R = "Ocean.SampleSurface"
CASES += [
    bad(R, "no_points", put("points", []), "points"),
    bad(R, "point_x_nan", put("points[1].x", NAN), "points[1].x"),
    bad(R, "point_y_inf", put("points[0].y", -INF), "points[0].y"),
    bad(R, "time_inf", put("time.seconds", INF), "time.seconds"),
    bad(R, "gravity_negative", put(f"{L0}.gravity", -9.81), f"{L0}.gravity"),
    bad(
        R,
        "shallow_depth_zero",
        also(put(f"{L0}.dispersion", ocean_pb2.DISPERSION_MODEL_SHALLOW), put(f"{L0}.depth", 0.0)),
        f"{L0}.depth",
    ),
    bad(
        R,
        "layer_grid_oversize",
        also(put(f"{L0}.nx", 512), put(f"{L0}.ny", 512)),
        f"{L0}.nx * {L0}.ny",
        EXHAUSTED,
    ),
    bad(R, "spectrum_unknown_enum", put(f"{L0}.spectrum", -5), f"{L0}.spectrum"),
]

R = "EWave.CreateSession"
CASES += [
    bad(R, "dx_nan", put("config.dx", NAN), "config.dx"),
    bad(R, "dy_zero", put("config.dy", 0.0), "config.dy"),
    bad(R, "dx_negative", put("config.dx", -0.05), "config.dx"),
    bad(R, "nx_zero", put("config.nx", 0), "config.nx = 0 must be in [2, 1073741824]"),
    bad(R, "nx_one", put("config.nx", 1), "config.nx = 1 must be in [2, 1073741824]"),
    bad(
        R,
        "grid_oversize",
        also(put("config.nx", 512), put("config.ny", 512)),
        "config.nx * config.ny",
        EXHAUSTED,
    ),
    bad(R, "dispersion_unknown_enum", put("config.dispersion", 9), "config.dispersion"),
    bad(R, "gravity_negative", put("config.gravity", -9.81), "config.gravity"),
    bad(
        R,
        "shallow_depth_zero",
        put("config.dispersion", ocean_pb2.DISPERSION_MODEL_SHALLOW),
        "config.depth",
    ),
    bad(R, "capillary_length_nan", put("config.capillary_length", NAN), "capillary_length"),
    bad(R, "trim_width_too_wide", put("config.trim_width", 1e9), "config.trim_width"),
    bad(R, "trim_alpha_zero", put("config.trim_alpha", 0.0), "config.trim_alpha"),
    bad(R, "friction_time_negative", put("config.friction_time", -1.0), "config.friction_time"),
    bad(R, "source_scale_inf", put("config.source_scale", INF), "config.source_scale"),
    bad(R, "displacement_scale_nan", put("config.displacement_scale", NAN), "displacement_scale"),
    bad(R, "start_time_nan", put("config.start_time.seconds", NAN), "config.start_time.seconds"),
    bad(
        R,
        "initial_height_wrong_nx",
        put("config.initial_height", grid_field(EWAVE_N - 1, EWAVE_N)),
        "config.initial_height.nx",
    ),
    bad(
        R,
        "initial_height_short_data",
        also(
            put("config.initial_height", ewave_map(0.0)),
            put("config.initial_height.data", bytes(4 * EWAVE_N * EWAVE_N - 4)),
        ),
        "config.initial_height.data",
    ),
    bad(
        R,
        "initial_phi_nan",
        put("config.initial_phi", ewave_map(NAN)),
        "config.initial_phi[0]",
    ),
    bad(
        R,
        "initial_height_3d",
        put("config.initial_height", common_pb2.Field(nx=EWAVE_N, ny=EWAVE_N, nz=2)),
        "config.initial_height.nz",
    ),
    bad(
        R,
        "initial_height_dtype_unknown_enum",
        also(put("config.initial_height", ewave_map(0.0)), put("config.initial_height.dtype", 5)),
        "config.initial_height.dtype",
    ),
    bad(
        R,
        "initial_ocean_wind_nan",
        also(
            put("config.initial_ocean", ocean_tile()),
            put("config.initial_ocean.layers[0].wind_speed", NAN),
        ),
        "config.initial_ocean.layers[0].wind_speed",
    ),
    bad(
        R,
        "initial_ocean_with_initial_height",
        also(
            put("config.initial_ocean", ocean_tile()),
            put("config.initial_height", ewave_map(0.0)),
        ),
        "config.initial_ocean",
    ),
    bad(
        R,
        "proposed_id_not_hex",
        nothing,
        "x-squall-session",
        metadata=session_metadata("not-a-session-id"),
    ),
    bad(
        R,
        "proposed_id_uppercase",
        nothing,
        "x-squall-session",
        metadata=session_metadata(UNKNOWN_ID.upper()),
    ),
]

R = "EWave.Step"
CASES += [
    bad(R, "dt_zero", put("inputs.dt", 0.0), "inputs.dt"),
    bad(R, "dt_nan", put("inputs.dt", NAN), "inputs.dt"),
    bad(R, "dt_inf", put("inputs.dt", INF), "inputs.dt"),
    bad(
        R,
        "obstruction_wrong_nx",
        put("inputs.obstruction", grid_field(EWAVE_N - 1, EWAVE_N, 1.0)),
        "inputs.obstruction.nx",
    ),
    bad(
        R,
        "obstruction_wrong_ny",
        put("inputs.obstruction", grid_field(EWAVE_N, 2 * EWAVE_N, 1.0)),
        "inputs.obstruction.ny",
    ),
    bad(
        R,
        "obstruction_short_data",
        also(
            put("inputs.obstruction", ewave_map()),
            put("inputs.obstruction.data", bytes(4 * EWAVE_N * EWAVE_N - 2)),
        ),
        "inputs.obstruction.data",
    ),
    bad(R, "obstruction_above_1", put("inputs.obstruction", ewave_map(2.0)), "inputs.obstruction"),
    bad(R, "obstruction_nan", put("inputs.obstruction", ewave_map(NAN)), "inputs.obstruction[0]"),
    bad(
        R,
        "obstruction_dtype_unknown_enum",
        also(put("inputs.obstruction", ewave_map()), put("inputs.obstruction.dtype", 3)),
        "inputs.obstruction.dtype",
    ),
    bad(
        R,
        "source_height_inf",
        put(
            "inputs.source_height",
            grid_field(EWAVE_N, EWAVE_N, values=np.where(np.eye(EWAVE_N) > 0, INF, 0.0)),
        ),
        "inputs.source_height[0]",
    ),
    bad(R, "drift_x_nan", put("inputs.drift_x", NAN), "inputs.drift_x"),
    bad(
        R,
        "drift_field_x_alone",
        put("inputs.drift_field_x", ewave_map(0.1)),
        "inputs.drift_field_x",
    ),
    bad(
        R,
        "ambient_ocean_and_height",
        also(
            put("inputs.ambient_ocean", ocean_tile()),
            put("inputs.ambient_height", ewave_map(0.0)),
        ),
        "inputs.ambient_ocean",
    ),
    bad(
        R,
        "circle_radius_negative",
        put("inputs.shapes[0].circle.radius", -0.1),
        "inputs.shapes[0].circle.radius",
    ),
    bad(
        R,
        "ellipse_heading_inf",
        put(
            "inputs.shapes[0]",
            ewave_pb2.EWaveShape(
                ellipse=ewave_pb2.EWaveEllipse(
                    center_x=0.4, center_y=0.4, semi_axis_a=0.1, semi_axis_b=0.05, heading=INF
                )
            ),
        ),
        "inputs.shapes[0].ellipse.heading",
    ),
    bad(
        R,
        "box_half_width_zero",
        put(
            "inputs.shapes[0]",
            ewave_pb2.EWaveShape(
                box=ewave_pb2.EWaveBox(center_x=0.4, center_y=0.4, half_length=0.1)
            ),
        ),
        "inputs.shapes[0].box.half_width",
    ),
    bad(
        R,
        "polygon_two_vertices",
        put(
            "inputs.shapes[0]",
            ewave_pb2.EWaveShape(
                polygon=ewave_pb2.EWavePolygon(vertices=[vec3(0.1, 0.1), vec3(0.3, 0.3)])
            ),
        ),
        "inputs.shapes[0].polygon.vertices",
    ),
    bad(
        R,
        "ellipse_past_1e9_m",  # its rasterization squares the semi-axes
        put(
            "inputs.shapes[0]",
            ewave_pb2.EWaveShape(
                ellipse=ewave_pb2.EWaveEllipse(semi_axis_a=1e155, semi_axis_b=0.05)
            ),
        ),
        "inputs.shapes[0].ellipse.semi_axis_a = 1e+155 must be finite and in (0, 1e+09]",
    ),
    bad(
        R,
        "polygon_vertex_past_1e9_m",
        put(
            "inputs.shapes[0]",
            ewave_pb2.EWaveShape(
                polygon=ewave_pb2.EWavePolygon(
                    vertices=[vec3(-3e19, -3e19), vec3(3e19, -3e19), vec3(0, 3e19)]
                )
            ),
        ),
        "inputs.shapes[0].polygon.vertices[0].x = -3e+19 must be finite and in [-1e+09, 1e+09]",
    ),
    bad(R, "shape_unset", put("inputs.shapes[0]", ewave_pb2.EWaveShape()), "inputs.shapes[0]"),
    bad(
        R,
        "shapes_1025",
        lambda r, env: r.inputs.shapes.extend([r.inputs.shapes[0]] * 1024),
        "inputs.shapes",
    ),
    bad(R, "outputs_unknown_enum", put("inputs.outputs[0]", 99), "inputs.outputs[0]"),
    bad(
        R,
        "outputs_twice",
        put("inputs.outputs[1]", ewave_pb2.EWAVE_OUTPUT_HEIGHT),
        "inputs.outputs[1]",
    ),
    bad(R, "dtype_unknown_enum", put("inputs.dtype", 9), "inputs.dtype"),
    bad(R, "session_unknown", put("session_id", UNKNOWN_ID), "session_id", NOT_FOUND),
    bad(R, "session_empty", put("session_id", ""), "session_id"),
    bad(R, "session_1MiB", put("session_id", BIG_ID), "session_id", NOT_FOUND),
    bad(R, "session_newline", put("session_id", NEWLINE_ID), "session_id", NOT_FOUND),
    bad(R, "session_is_a_volume_id", put("session_id", VOLUME), "session_id", NOT_FOUND),
]

R = "EWave.Run"  # message 0 steps another session; message 1 is the broken one
CASES += [
    bad(R, "dt_negative", put("inputs.dt", -1.0, at=1), "Run message 1: inputs.dt", frames=1),
    bad(
        R,
        "obstruction_wrong_nx",
        put("inputs.obstruction", grid_field(3, EWAVE_N, 1.0), at=1),
        "inputs.obstruction.nx",
        frames=1,
    ),
    bad(
        R,
        "source_phi_nan",
        put("inputs.source_phi", ewave_map(NAN), at=1),
        "inputs.source_phi[0]",
        frames=1,
    ),
    bad(
        R,
        "outputs_unknown_enum",
        put("inputs.outputs[0]", 42, at=1),
        "inputs.outputs[0]",
        frames=1,
    ),
    bad(
        R,
        "session_unknown",
        put("session_id", UNKNOWN_ID, at=1),
        "session_id",
        NOT_FOUND,
        frames=1,
    ),
    bad(R, "session_1MiB", put("session_id", BIG_ID, at=1), "session_id", NOT_FOUND, frames=1),
    bad(R, "session_empty", put("session_id", "", at=1), "session_id", frames=1),
]

for R in ("EWave.GetState", "EWave.CloseSession"):
    CASES += [
        bad(R, "session_unknown", put("session_id", UNKNOWN_ID), "session_id", NOT_FOUND),
        bad(R, "session_empty", put("session_id", ""), "session_id"),
        bad(R, "session_1MiB", put("session_id", BIG_ID), "session_id", NOT_FOUND),
        bad(R, "session_newline", put("session_id", NEWLINE_ID), "session_id", NOT_FOUND),
        bad(R, "session_is_a_volume_id", put("session_id", VOLUME), "session_id", NOT_FOUND),
    ]


# The header of an eWave state (ewave_state_format.h): magic, then 8-byte members; after the fields, the
# u64 length of the ambient ocean and its bytes.
STATE_NX, STATE_NY, STATE_DX, STATE_DISPERSION, STATE_TIME, STATE_FIELDS = 8, 16, 24, 40, 144, 152
STATE_TRIM, STATE_MASK_PHI, STATE_STEP = 72, 112, 136


def resized_state(nx: int, ny: int) -> Change:
    """The state's header with grid nx x ny, zero fields of that size and no ambient ocean (a
    version-2 state says so with a length of 0)."""

    def change(request: ewave_pb2.EWaveRestoreRequest, env: Optional[Env]) -> None:
        header = bytearray(request.state[:STATE_FIELDS])
        struct.pack_into("<qq", header, STATE_NX, nx, ny)
        no_ambient = b"" if header.startswith(b"SQEWAVE1") else struct.pack("<Q", 0)
        request.state = bytes(header) + bytes(2 * 4 * nx * ny) + no_ambient

    return change


R = "EWave.Restore"
CASES += [
    bad(R, "state_empty", put("state", b""), "state"),
    bad(R, "state_garbage", put("state", b"not an eWave state at all" * 10), "state"),
    bad(R, "state_bad_magic", patch(0, "<8s", b"SQEWAVE9"), "state"),
    bad(R, "state_truncated", lambda r, env: setattr(r, "state", r.state[:-4]), "state"),
    bad(R, "state_field_nan", patch(STATE_FIELDS, "<f", NAN), "state.fields[0]"),
    bad(R, "state_field_1e30", patch(STATE_FIELDS + 4, "<f", 1e30), "state.fields[1]"),
    bad(R, "state_grid_zero", patch(STATE_NX, "<q", 0), "state.grid"),
    bad(R, "state_dx_nan", patch(STATE_DX, "<d", NAN), "state.dx"),
    bad(R, "state_time_nan", patch(STATE_TIME, "<d", NAN), "state.time"),
    bad(R, "state_time_out_of_range", patch(STATE_TIME, "<d", 1e10), "state.time"),
    bad(R, "state_dispersion_unknown_enum", patch(STATE_DISPERSION, "<q", 9), "state.dispersion"),
    # Past the 32 bits of the enum it becomes: no known model once its high bits are dropped.
    bad(R, "state_dispersion_2_pow_40", patch(STATE_DISPERSION, "<q", 2**40), "state.dispersion"),
    bad(
        R,
        "state_dispersion_2_pow_32_plus_2",
        patch(STATE_DISPERSION, "<q", 2**32 + 2),
        "state.dispersion",
    ),
    bad(R, "state_trim_2", patch(STATE_TRIM, "<q", 2), "state.trim = 2 must be 0 or 1"),
    bad(R, "state_mask_phi_minus_1", patch(STATE_MASK_PHI, "<q", -1), "state.mask_phi = -1"),
    # A step count must never wrap: after_step compares against it.
    bad(
        R,
        "state_step_wraps",
        patch(STATE_STEP, "<Q", 2**64 - 1),
        "state.step = 18446744073709551615",
    ),
    bad(R, "state_grid_oversize", resized_state(512, 512), "state.nx * state.ny", EXHAUSTED),
    bad(
        R,
        "proposed_id_not_hex",
        nothing,
        "x-squall-session",
        metadata=session_metadata("zz" * 16),
    ),
]

R = "Clouds.BuildVolume"
CASES += [
    bad(R, "voxel_size_zero", put("model.voxel_size", 0.0), "model.voxel_size"),
    bad(R, "voxel_size_nan", put("model.voxel_size", NAN), "model.voxel_size"),
    bad(
        R,
        "voxel_size_tiny",
        put("model.voxel_size", 1e-3),
        "max_active_voxels",
        EXHAUSTED,
    ),
    bad(R, "skin_negative", put("model.skin", -1.0), "model.skin"),
    bad(R, "radius_nan", put("model.spheres[0].radius", NAN), "model.spheres[0].radius"),
    bad(R, "radius_zero", put("model.spheres[0].radius", 0.0), "model.spheres[0].radius"),
    bad(R, "center_inf", put("model.spheres[0].center.x", INF), "model.spheres[0].center.x"),
    bad(R, "center_far_away", put("model.spheres[0].center.z", 1e12), "model.spheres[0].center"),
    bad(R, "no_shapes", put("model.spheres", []), "spheres"),
    bad(
        R,
        "ellipsoid_radius_negative",
        put(
            "model.ellipsoids",
            [clouds_pb2.EllipsoidSpec(center=vec3(), radii=vec3(2, -1, 2))],
        ),
        "model.ellipsoids[0].radii.y",
    ),
    bad(
        R,
        "mesh_three_vertices",
        put(
            "model.meshes",
            [clouds_pb2.MeshSpec(vertices=[0, 0, 0, 1, 0, 0, 0, 1, 0], triangles=[0, 1, 2] * 4)],
        ),
        "model.meshes[0].vertices",
    ),
    bad(
        R,
        "mesh_index_out_of_range",
        put(
            "model.meshes",
            [
                clouds_pb2.MeshSpec(
                    vertices=[0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1],
                    triangles=[0, 1, 2, 0, 1, 3, 0, 2, 3, 1, 2, 99],
                )
            ],
        ),
        "model.meshes[0].triangles[11]",
    ),
    # vertices is a flat list of x, y, z: the y of the third vertex is vertices[7].
    bad(
        R,
        "mesh_vertex_nan",
        put("model.meshes", [tetrahedron(y2=NAN)]),
        "model.meshes[0].vertices[7] = nan",
    ),
    bad(
        R,
        "mesh_vertex_far",
        put("model.meshes", [tetrahedron(y2=4e9)]),
        "model.meshes[0].vertices[6..8] = (0, 4e+09, 0)",
    ),
    bad(
        R,
        "mesh_obj_garbage",
        put("model.meshes", [clouds_pb2.MeshSpec(obj=b"v 1 2\nf 1 2 x\n")]),
        "model.meshes[0].obj",
    ),
    # An OBJ mesh is named by its text, not by the flat fields it was not sent in.
    bad(
        R,
        "mesh_obj_three_vertices",
        put("model.meshes", [clouds_pb2.MeshSpec(obj=b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")]),
        "model.meshes[0].obj has 3 vertices",
    ),
    bad(
        R,
        "mesh_obj_one_face",
        put(
            "model.meshes",
            [clouds_pb2.MeshSpec(obj=b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n")],
        ),
        "model.meshes[0].obj has 1 triangles (its faces fanned)",
    ),
    bad(
        R,
        "mesh_obj_vertex_far",
        put(
            "model.meshes",
            [
                clouds_pb2.MeshSpec(
                    obj=b"v 0 0 0\nv 4 0 0\nv 0 4e9 0\nv 0 0 4\n"
                    b"f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
                )
            ],
        ),
        "model.meshes[0].obj vertex 3 = (0, 4e+09, 0)",
    ),
    bad(R, "max_active_voxels_zero", put("model.max_active_voxels", 0), "max_active_voxels"),
    bad(
        R,
        "max_active_voxels_exceeded",
        put("model.max_active_voxels", 10),
        "max_active_voxels",
        EXHAUSTED,
    ),
    bad(R, "advection_scheme_unknown_enum", put("model.advection.scheme", 7), "advection.scheme"),
    bad(R, "pyroclastic_layers_9", put("model.pyroclastic.layers", 9), "pyroclastic.layers"),
    bad(
        R,
        "pyroclastic_layers_uint32_max",
        put("model.pyroclastic.layers", U32),
        f"model.pyroclastic.layers = {U32} ",  # as sent
    ),
    bad(
        R,
        "advection_substeps_uint32_max",
        put("model.advection.substeps", U32),
        f"model.advection.substeps = {U32} ",
    ),
    bad(
        R,
        "noise_octaves_zero",
        put("model.pyroclastic.noise.octaves", 0),
        "model.pyroclastic.noise.octaves",
    ),
    bad(
        R,
        "particle_bias_2",
        put(
            "model.particles",
            [clouds_pb2.ParticleSpec(center=vec3(), radius=2.0, bias=2.0)],
        ),
        "model.particles[0].bias",
    ),
    bad(R, "lapse_rate_1", put("model.temperature.lapse_rate", 1.0), "temperature.lapse_rate"),
    bad(
        R,
        "keep_with_proposed_id_not_hex",
        put("keep", True),
        "x-squall-session",
        metadata=session_metadata("cloud-" + "x" * 32),
    ),
]

R = "Clouds.Render"
CAM = "settings.camera"
CASES += [
    bad(R, "settings_unset", drop("settings"), "settings.camera is unset"),
    bad(R, "camera_unset", drop("settings.camera"), "settings.camera is unset"),
    bad(R, "width_zero", put(f"{CAM}.width", 0), f"{CAM}.width"),
    bad(R, "width_8193", put(f"{CAM}.width", 8193), f"{CAM}.width"),
    bad(R, "width_uint32_max", put(f"{CAM}.width", U32), f"{CAM}.width = {U32} "),  # as sent
    bad(R, "height_uint32_max", put(f"{CAM}.height", U32), f"{CAM}.height = {U32} "),
    bad(R, "height_zero", put(f"{CAM}.height", 0), f"{CAM}.height"),
    bad(
        R,
        "image_oversize",
        also(put(f"{CAM}.width", 8192), put(f"{CAM}.height", 8192)),
        "RenderResponse.image",
        EXHAUSTED,
    ),
    bad(R, "eye_nan", put(f"{CAM}.eye.y", NAN), f"{CAM}.eye.y"),
    bad(R, "look_at_is_eye", put(f"{CAM}.look_at", vec3(0, -30, 0)), f"{CAM}.look_at"),
    bad(R, "up_parallel", put(f"{CAM}.up", vec3(0, 1, 0)), f"{CAM}.up"),
    bad(R, "fov_180", put(f"{CAM}.vertical_fov_deg", 180.0), f"{CAM}.vertical_fov_deg"),
    bad(R, "step_zero", put("settings.step", 0.0), "settings.step"),
    bad(R, "step_nan", put("settings.step", NAN), "settings.step"),
    bad(R, "step_tiny", put("settings.step", 1e-9), "settings.step", EXHAUSTED),
    bad(R, "substeps_9", put("settings.substeps", 9), "settings.substeps"),
    bad(R, "substeps_uint32_max", put("settings.substeps", U32), f"settings.substeps = {U32} "),
    bad(R, "min_transmittance_1", put("settings.min_transmittance", 1.0), "min_transmittance"),
    bad(R, "shadow_step_negative", put("settings.shadow_step", -1.0), "settings.shadow_step"),
    bad(
        R,
        "shadow_step_tiny",
        also(
            put("settings.shadow", clouds_pb2.SHADOW_MODE_DIRECT),
            put("settings.shadow_step", 1e-9),
        ),
        "settings.shadow_step",
        EXHAUSTED,
    ),
    # Below the least normal float32, which the device would take for 0.
    bad(R, "step_subnormal", put("settings.step", 1e-40), "settings.step = 1e-40"),
    bad(R, "shadow_step_subnormal", put("settings.shadow_step", 1e-300), "settings.shadow_step = 1e-300"),
    bad(R, "wavelength_1m", put("settings.wavelengths[0]", 1.0), "settings.wavelengths[0]"),
    bad(
        R,
        "nine_wavelengths",
        also(
            put("settings.wavelengths", [550e-9] * 9),
            put("settings.extinction", [0.1] * 9),
            put("settings.albedo", [0.9] * 9),
            put("settings.lights[0].intensity", [1.0] * 9),
        ),
        "settings.wavelengths",
    ),
    bad(R, "extinction_count", put("settings.extinction", [0.1, 0.1]), "settings.extinction"),
    bad(R, "extinction_negative", put("settings.extinction[0]", -0.1), "settings.extinction[0]"),
    bad(R, "albedo_1_5", put("settings.albedo[0]", 1.5), "settings.albedo[0]"),
    bad(
        R,
        "light_intensity_negative",
        put("settings.lights[0].intensity[0]", -1.0),
        "settings.lights[0].intensity[0]",
    ),
    bad(
        R,
        "light_intensity_count",
        put("settings.lights[0].intensity", []),
        "settings.lights[0].intensity",
    ),
    bad(
        R,
        "light_direction_zero",
        put("settings.lights[0].direction", vec3()),
        "settings.lights[0].direction",
    ),
    bad(
        R,
        "light_position_inf",
        put("settings.lights[0].position.x", INF),
        "settings.lights[0].position.x",
    ),
    bad(
        R,
        "light_kind_unknown_enum",
        put("settings.lights[0].kind", 9),
        "settings.lights[0].kind",
    ),
    bad(
        R,
        "five_lights",
        lambda r, env: r.settings.lights.extend([r.settings.lights[0]] * 4),
        "settings.lights",
    ),
    bad(R, "phase_kind_unknown_enum", put("settings.phase.kind", 9), "settings.phase.kind"),
    bad(R, "phase_g1_1", put("settings.phase.g1", 1.0), "settings.phase.g1"),
    bad(R, "shadow_unknown_enum", put("settings.shadow", 9), "settings.shadow"),
    bad(
        R,
        "shadow_map_size_two_entries",
        put("settings.shadow_map_size", [64, 64]),
        "settings.shadow_map_size",
    ),
    bad(
        R,
        "shadow_map_size_1",
        put("settings.shadow_map_size", [1, 64, 64]),
        "settings.shadow_map_size[0]",
    ),
    bad(
        R,
        "shadow_map_size_uint32_max",
        put("settings.shadow_map_size", [64, U32, 64]),
        f"settings.shadow_map_size[1] = {U32} ",
    ),
    bad(R, "volume_unknown", put("volume_id", "cloud-" + UNKNOWN_ID), "volume_id", NOT_FOUND),
    bad(R, "volume_1MiB", put("volume_id", BIG_ID), "volume_id", NOT_FOUND),
    bad(R, "volume_newline", put("volume_id", NEWLINE_ID), "volume_id", NOT_FOUND),
    bad(R, "volume_is_a_session_id", put("volume_id", SESSION), "volume_id", NOT_FOUND),
    bad(R, "no_volume_no_model", put("volume_id", ""), "volume_id"),
    bad(
        R,
        "model_voxel_size_negative",
        also(put("model", cloud_model()), put("model.voxel_size", -1.0)),
        "model.voxel_size",
    ),
]

R = "Clouds.StreamEvolution"
CASES += [
    bad(R, "settings_unset", drop("settings"), "settings.camera is unset"),
    bad(R, "no_times", put("times", []), "times"),
    bad(R, "time_nan", put("times[1]", NAN), "times[1]"),
    bad(R, "times_1001", put("times", [0.0] * 1001), "times"),
    bad(R, "drift_nan", put("evolution.drift.x", NAN), "evolution.drift.x"),
    bad(R, "amplitude_rate_inf", put("evolution.amplitude_rate", INF), "evolution.amplitude_rate"),
    bad(
        R,
        "advection_rate_negative",
        put("evolution.advection_rate", -1e-9),
        "evolution.advection_rate = -1e-09",
    ),
    bad(
        R,
        "advection_time_past_its_range",
        also(put("evolution.advection_rate", 1e3), put("times[1]", 2e3)),
        "model at times[1].advection.time",
    ),
    bad(R, "settings_step_zero", put("settings.step", 0.0), "settings.step"),
    bad(R, "settings_width_zero", put("settings.camera.width", 0), "settings.camera.width"),
    bad(
        R, "model_radius_negative", put("model.spheres[0].radius", -1.0), "model.spheres[0].radius"
    ),
]

R = "Clouds.ReleaseVolume"
CASES += [
    bad(R, "volume_unknown", put("volume_id", "cloud-" + UNKNOWN_ID), "volume_id", NOT_FOUND),
    bad(R, "volume_empty", put("volume_id", ""), "volume_id", NOT_FOUND),
    bad(R, "volume_is_a_session_id", put("volume_id", SESSION), "volume_id", NOT_FOUND),
    bad(
        R,
        "volume_1MiB",
        put("volume_id", BIG_ID),
        "volume_id",
        NOT_FOUND,
    ),
    bad(
        R,
        "volume_newline",
        put("volume_id", NEWLINE_ID),
        "volume_id",
        NOT_FOUND,
    ),
]

R = "Textures.AdvectTexture"
VG = "request.velocity.grid"
CASES += [
    bad(R, "dt_nan", put("dt", NAN), "request.dt"),
    bad(R, "dt_zero", put("dt", 0.0), "request.dt"),
    bad(R, "t0_inf", put("t0", INF), "request.t0"),
    bad(R, "frames_zero", put("frames", 0), "request.frames"),
    bad(R, "substeps_65", put("substeps", 65), "request.substeps"),
    bad(R, "method_unknown_enum", put("method", 9), "request.method"),
    bad(
        R,
        "velocity_kind_unknown_enum",
        put("velocity.named.kind", 99),
        "request.velocity.named.kind",
    ),
    bad(
        R,
        "velocity_x_nan",
        put("velocity.named.velocity_x", NAN),
        "request.velocity.named.velocity_x",
    ),
    bad(
        R,
        "sink_epsilon_zero",
        also(
            put("velocity.named.kind", textures_pb2.AnalyticVelocity.KIND_SINK),
            put("velocity.named.epsilon", 0.0),
        ),
        "request.velocity.named.epsilon",
    ),
    bad(R, "output_width_zero", put("output.width", 0), "request.output.width"),
    bad(
        R,
        "output_oversize",
        also(put("output.width", 512), put("output.height", 512)),
        "request.output.width * request.output.height",
        EXHAUSTED,
    ),
    bad(
        R,
        "region_x1_below_x0",
        put("output.region", textures_pb2.TextureRegion(x0=1.0, y0=0.0, x1=0.5, y1=1.0)),
        "request.output.region.x1",
    ),
    bad(R, "planes_unknown_enum", put("output.planes", [99]), "request.output.planes[0]"),
    bad(R, "output_dtype_unknown_enum", put("output.dtype", 5), "request.output.dtype"),
    bad(R, "noise_bands_zero", put("texture.noise.bands", 0), "request.texture.noise.bands"),
    bad(
        R,
        "noise_spin_of_still_noise",
        put("texture.noise.spin", 2.0),
        "request.texture.noise.spin = 2 must be unset: time_varying is false",
    ),
    bad(
        R,
        "noise_bands_uint32_max",
        put("texture.noise.bands", U32),
        f"request.texture.noise.bands = {U32} ",  # as sent
    ),
    bad(
        R,
        "lut_channels_uint32_max",
        also(
            put("texture.final_function", textures_pb2.FINAL_FUNCTION_LUT),
            put("texture.lut.table", [0.0, 1.0]),
            put("texture.lut.channels", U32),
        ),
        f"request.texture.lut.channels = {U32} ",
    ),
    bad(
        R,
        "lagrangian_grid_res_uint32_max",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_LAGRANGIAN_GRIDS),
            put("lagrangian.grid_res", U32),
        ),
        f"request.lagrangian.grid_res = {U32} ",
    ),
    bad(R, "noise_base_cells_65", put("texture.noise.base_cells", 65), "noise.base_cells"),
    bad(R, "texture_scale_zero", put("texture.scale", 0.0), "request.texture.scale"),
    bad(R, "final_function_unknown_enum", put("texture.final_function", 9), "final_function"),
    bad(
        R,
        "lut_one_entry",
        also(
            put("texture.final_function", textures_pb2.FINAL_FUNCTION_LUT),
            put("texture.lut", textures_pb2.FinalLookup(table=[0.5])),
        ),
        "request.texture.lut.table",
    ),
    bad(
        R,
        "grid_u_wrong_nx",
        also(put("velocity", grid_velocity()), put("velocity.grid.frames[0].u", grid_field(3, 4))),
        f"{VG}.frames[0].u.nx",
    ),
    bad(
        R,
        "grid_v_short_data",
        also(
            put("velocity", grid_velocity()),
            put("velocity.grid.frames[0].v.data", bytes(4 * 16 - 4)),
        ),
        f"{VG}.frames[0].v.data",
    ),
    bad(
        R,
        "grid_u_nan",
        also(
            put("velocity", grid_velocity()),
            put("velocity.grid.frames[0].u", grid_field(4, 4, NAN)),
        ),
        f"{VG}.frames[0].u[0]",
    ),
    bad(
        R,
        "grid_mask_nan",
        also(put("velocity", grid_velocity()), put("velocity.grid.mask", grid_field(4, 4, NAN))),
        f"{VG}.mask[0] = nan must be finite",
    ),
    bad(
        R,
        "image_channels_uint32_max",
        put(
            "texture",
            textures_pb2.TextureSource(
                image=textures_pb2.ImageTexture(channels=[common_pb2.Field(nx=U32, ny=U32)])
            ),
        ),
        "request.texture.image.channels[0].nx * request.texture.image.channels[0].ny",
        EXHAUSTED,
    ),
    bad(
        R,
        "grid_times_not_increasing",
        also(
            put("velocity", grid_velocity()),
            lambda r, env: r.velocity.grid.frames.extend([r.velocity.grid.frames[0]]),
        ),
        f"{VG}.frames[1].time",
    ),
    bad(
        R,
        "grid_no_frames",
        also(put("velocity", grid_velocity()), put("velocity.grid.frames", [])),
        f"{VG}.frames",
    ),
    bad(
        R,
        "grid_spacing_zero",
        also(put("velocity", grid_velocity()), put("velocity.grid.spacing.x", 0.0)),
        f"{VG}.spacing.x",
    ),
    bad(
        R,
        "grid_extrapolation_unknown_enum",
        also(put("velocity", grid_velocity()), put("velocity.grid.extrapolation", 4)),
        f"{VG}.extrapolation",
    ),
    bad(
        R,
        "grid_oversize",
        put(
            "velocity",
            textures_pb2.VelocitySpec(
                grid=textures_pb2.VelocityGrid(
                    nx=300,
                    ny=300,
                    spacing=vec2(0.01, 0.01),
                    frames=[
                        textures_pb2.VelocityGridFrame(
                            u=grid_field(300, 300, dtype=common_pb2.DTYPE_FLOAT16),
                            v=grid_field(300, 300, dtype=common_pb2.DTYPE_FLOAT16),
                        )
                    ],
                )
            ),
        ),
        f"{VG}.nx * {VG}.ny",
        EXHAUSTED,
    ),
    bad(
        R,
        "image_channels_disagree",
        also(put("texture", image_source()), put("texture.image.channels[1]", grid_field(8, 7))),
        "request.texture.image.channels[1].ny",
    ),
    bad(
        R,
        "image_nan",
        also(
            put("texture", image_source()), put("texture.image.channels[0]", grid_field(8, 8, NAN))
        ),
        "request.texture.image.channels[0]",
    ),
    bad(
        R,
        "image_empty_channel",
        also(
            put("texture", image_source()),
            put("texture.image.channels", [common_pb2.Field(dtype=common_pb2.DTYPE_FLOAT32)]),
        ),
        "request.texture.image",
    ),
    bad(
        R,
        "image_png_garbage",
        put("texture", textures_pb2.TextureSource(image=textures_pb2.ImageTexture(png=b"GIF89a"))),
        "request.texture.image.png",
    ),
    bad(
        R,
        "image_png_oversize",
        put(
            "texture",
            textures_pb2.TextureSource(
                image=textures_pb2.ImageTexture(png=png_header(1000, 1000))
            ),
        ),
        "request.texture.image.png",
        EXHAUSTED,
    ),
    bad(
        R,
        "image_png_wider_than_libpngs_default_limit",
        put(
            "texture",
            textures_pb2.TextureSource(
                image=textures_pb2.ImageTexture(png=png_header(2**31 - 1, 1))
            ),
        ),
        "request.texture.image.png width * request.texture.image.png height = 2147483647 cells",
        EXHAUSTED,
    ),
    bad(
        R,
        "image_pixels8_short_data",
        put(
            "texture",
            textures_pb2.TextureSource(
                image=textures_pb2.ImageTexture(
                    pixels8=textures_pb2.Pixels8(width=8, height=8, channels=3, data=bytes(100))
                )
            ),
        ),
        "request.texture.image.pixels8.data",
    ),
    bad(
        R,
        "image_pixels8_oversize",
        put(
            "texture",
            textures_pb2.TextureSource(
                image=textures_pb2.ImageTexture(
                    pixels8=textures_pb2.Pixels8(width=100000, height=100000, channels=1)
                )
            ),
        ),
        "request.texture.image.pixels8.width * request.texture.image.pixels8.height",
        EXHAUSTED,
    ),
    bad(
        R,
        "image_two_sources",
        also(put("texture", image_source()), put("texture.image.png", png_header(8, 8))),
        "request.texture.image",
    ),
    bad(
        R,
        "ewave_session_unknown",
        put("velocity.ewave_session", UNKNOWN_ID),
        "request.velocity.ewave_session",
        NOT_FOUND,
    ),
    bad(
        R,
        "ewave_session_1MiB",
        put("velocity.ewave_session", BIG_ID),
        "request.velocity.ewave_session",
        NOT_FOUND,
    ),
    bad(
        R,
        "ewave_session_newline",
        put("velocity.ewave_session", NEWLINE_ID),
        "request.velocity.ewave_session",
        NOT_FOUND,
    ),
    bad(
        R,
        "ocean_wind_nan",
        also(
            put("velocity.ocean", ocean_tile()),
            put("velocity.ocean.layers[0].wind_speed", NAN),
        ),
        "request.velocity.ocean.layers[0].wind_speed",
    ),
    bad(
        R,
        "ocean_read_past_sim_time",  # the current of the step to frame 2 is read up to 1e9 + 0.05 s
        also(
            put("velocity.ocean", ocean_tile()),
            put("t0", 1e9 - 0.15),
            put("frames", 3),
        ),
        "request.velocity.ocean follows an ocean surface, which is evaluated within +-1e+09 s: "
        "request.frames = 3 at dt = 0.1 s from t0 = 999999999.85000002 s reaches t = 1000000000.05",
        frames=0,
    ),
    bad(
        R,
        "river_bank_nan",
        also(
            put("velocity.river", river()),
            put("velocity.river.channels[0].left_bank.points[0].x", NAN),
        ),
        "request.velocity.river.channels[0].left_bank.points[0].x",
    ),
    bad(
        R,
        "lagrangian_d_tiny",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_LAGRANGIAN_GRIDS),
            put("lagrangian.d", 1e-3),
        ),
        "request.lagrangian.d",
        EXHAUSTED,
    ),
    bad(
        R,
        "lagrangian_alpha_1",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_LAGRANGIAN_GRIDS),
            put("lagrangian.alpha", 1.0),
        ),
        "request.lagrangian.alpha",
    ),
    bad(
        R,
        "lagrangian_beta_0",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_LAGRANGIAN_GRIDS),
            put("lagrangian.beta", 0.0),
        ),
        "request.lagrangian.beta",
    ),
    bad(
        R,
        "eulerian_latencies_decreasing",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_EULERIAN_MULTILAYER),
            put("eulerian.latencies", [2.0, 1.0]),
        ),
        "request.eulerian.latencies[1]",
    ),
    bad(R, "eulerian_grid_nx_1", put("eulerian.grid_nx", 1), "request.eulerian.grid_nx"),
    bad(
        R,
        "eulerian_grid_ny_uint32_max",
        put("eulerian.grid_ny", U32),
        f"request.eulerian.grid_ny = {U32} ",
    ),
    bad(
        R,
        "eulerian_phases_uint32_max",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_EULERIAN_MULTILAYER),
            put("eulerian.phases", U32),
        ),
        f"request.eulerian.phases = {U32} ",
    ),
    bad(
        R,
        "eulerian_grid_oversize",
        also(put("eulerian.grid_nx", 4096), put("eulerian.grid_ny", 4096)),
        "request.eulerian.grid_nx * request.eulerian.grid_ny",
        EXHAUSTED,
    ),
    bad(R, "eulerian_blend_unknown_enum", put("eulerian.blend", 9), "request.eulerian.blend"),
    bad(
        R,
        "resume_state_garbage",
        put("resume_state", b"\x01ga"),
        "request.resume_state is not a texture checkpoint",
    ),
    bad(
        R,
        "resume_state_header_then_garbage",
        checkpoint_state_replaced(b"garbage"),
        "resume_state has an unknown version",
    ),
    bad(
        R,
        "resume_state_header_only",
        checkpoint_state_replaced(b""),
        "it holds no advection state",
    ),
    bad(
        R,
        "resume_state_one_bit_flipped",
        flipped_checkpoint(CHECKPOINT_HEADER + 5),  # in the frame index
        "request.resume_state is damaged: its state does not match its checksum",
    ),
    bad(
        R,
        "resume_state_index_negative",
        forged_checkpoint(-2),
        "resume_state holds frame index",
    ),
    bad(
        R,
        "resume_state_index_2e32",
        forged_checkpoint(1 << 32),
        "resume_state holds frame index",
    ),
    bad(
        R,
        "resume_state_of_another_dt",
        resumed_with_another_dt,
        "request.resume_state is the checkpoint of another request",
    ),
]

R = "Textures.AdvectInteractive"  # message 0 starts (one frame), message 1 steers (one frame)
CASES += [
    bad(R, "no_start", drop("start"), "control[0].start", frames=0),
    bad(
        R,
        "start_twice",
        put("start", advect_request(frames=0), at=1),
        "control[1].start",
        frames=1,
    ),
    bad(R, "start_frames_5", put("start.frames", 5), "control[0].start.frames", frames=0),
    bad(
        R,
        "start_checkpoint_every",
        put("start.checkpoint_every", 1),
        "control[0].start.checkpoint_every",
        frames=0,
    ),
    bad(
        R,
        "start_resume_state",
        put("start.resume_state", b"\x01"),
        "control[0].start.resume_state",
        frames=0,
    ),
    bad(
        R, "start_method_unknown_enum", put("start.method", 9), "control[0].start.method", frames=0
    ),
    bad(
        R,
        "start_output_oversize",
        also(put("start.output.width", 1024), put("start.output.height", 1024)),
        "control[0].start.output",
        EXHAUSTED,
        frames=0,
    ),
    bad(R, "frames_2000", put("frames", 2000, at=1), "control[1].frames", frames=1),
    bad(
        R,
        "first_dt_nan",
        put("dt", NAN),
        "control[0].dt",
        frames=0,
    ),
    bad(R, "dt_negative", put("dt", -1.0, at=1), "control[1].dt", frames=1),
    bad(R, "dt_nan", put("dt", NAN, at=1), "control[1].dt", frames=1),
    bad(R, "substeps_zero", put("substeps", 0, at=1), "control[1].substeps", frames=1),
    bad(R, "final_scale_inf", put("final_scale", INF, at=1), "control[1].final_scale", frames=1),
    bad(
        R,
        "spin_with_image",
        also(put("start.texture", image_source()), put("spin", 1.0, at=1)),
        "control[1].spin",
        frames=1,
    ),
    bad(
        R,
        "ocean_read_past_sim_time",  # message 1's step reads the current past 1e9 s
        also(put("start.velocity.ocean", ocean_tile()), put("start.t0", 1e9 - 0.15)),
        "control[0].start.velocity.ocean follows an ocean surface, which is evaluated within "
        "+-1e+09 s: the texture's clock reaches t = ",
        frames=1,
    ),
    bad(
        R,
        "spin_of_still_noise",  # the start's noise has time_varying false
        put("spin", 1.0, at=1),
        "control[1].spin = 1 must be unset: the noise is still",
        frames=1,
    ),
    bad(
        R,
        "velocity_kind_unknown_enum",
        also(put("velocity", uniform_velocity(), at=1), put("velocity.named.kind", 99, at=1)),
        "control[1].velocity.named.kind",
        frames=1,
    ),
    bad(
        R,
        "velocity_ewave_session_unknown",
        put("velocity", textures_pb2.VelocitySpec(ewave_session=UNKNOWN_ID), at=1),
        "control[1].velocity.ewave_session",
        NOT_FOUND,
        frames=1,
    ),
]

R = "Textures.BakeVelocity"
CH = "request.river.channels[0]"
CASES += [
    bad(R, "region_unset", drop("region"), "request.region"),
    bad(R, "region_x0_nan", put("region.x0", NAN), "request.region.x0"),
    bad(R, "region_y1_below_y0", put("region.y1", -1.0), "request.region.y1"),
    bad(R, "nx_1", put("nx", 1), "request.nx"),
    bad(R, "ny_zero", put("ny", 0), "request.ny"),
    bad(R, "nx_5000", put("nx", 5000), "request.nx"),
    bad(R, "ny_uint32_max", put("ny", U32), f"request.ny = {U32} "),  # as sent
    bad(
        R,
        "grid_oversize",
        also(put("nx", 4096), put("ny", 4096)),
        "request.nx * request.ny",
        EXHAUSTED,
    ),
    bad(R, "dtype_unknown_enum", put("dtype", 9), "request.dtype"),
    bad(
        R,
        "bank_point_nan",
        put("river.channels[0].left_bank.points[1].x", NAN),
        f"{CH}.left_bank.points[1].x",
    ),
    bad(
        R,
        "bank_one_point",
        put("river.channels[0].right_bank.points", [vec2(0, 0)]),
        f"{CH}.right_bank.points",
    ),
    bad(
        R,
        "bank_point_repeated",
        put("river.channels[0].left_bank.points", [vec2(0, 1), vec2(0, 1), vec2(1, 1)]),
        f"{CH}.left_bank.points[1]",
    ),
    bad(R, "flow_rate_zero", put("river.channels[0].flow_rate", 0.0), f"{CH}.flow_rate"),
    bad(R, "no_channels", put("river.channels", []), "request.river.channels"),
    bad(R, "p_9", put("river.p", 9.0), "request.river.p"),
    bad(
        R,
        "search_radius_negative",
        put("river.search_radius", -1.0),
        "request.river.search_radius",
    ),
    bad(
        R,
        "junction_index_out_of_range",
        put("river.junctions", [textures_pb2.RiverJunction(upstream=[0], downstream=[7, 8])]),
        "request.river.junctions[0].downstream[0]",
    ),
    bad(
        R,
        "junction_index_uint32_max",
        put("river.junctions", [textures_pb2.RiverJunction(upstream=[0], downstream=[U32, 0])]),
        f"request.river.junctions[0].downstream[0] = {U32} ",
    ),
    bad(
        R,
        "obstacle_two_points",
        put(
            "river.obstacles",
            [
                textures_pb2.RiverObstacle(
                    outline=textures_pb2.Polyline(points=[vec2(0.5, 0.5), vec2(0.6, 0.5)])
                )
            ],
        ),
        "request.river.obstacles[0].outline.points",
    ),
]

R = "Textures.DeformTexture"
CASES += [
    bad(
        R,
        "chart_nan",
        put("chart", grid_field(DEFORM_N, DEFORM_N, NAN)),
        "request.chart[0] = nan must be finite",
    ),
    bad(
        R,
        "image_channels_oversize",
        put("texture.channels", [common_pb2.Field(nx=5000, ny=5000)]),
        "request.texture.channels[0].nx * request.texture.channels[0].ny",
        EXHAUSTED,
    ),
    bad(
        R,
        "rigidity_2",
        put("rigidity", grid_field(DEFORM_N, DEFORM_N, 2.0)),
        "request.rigidity[0]",
    ),
    bad(
        R,
        "rigidity_nan",
        put("rigidity", grid_field(DEFORM_N, DEFORM_N, NAN)),
        "request.rigidity[0]",
    ),
    bad(R, "rigidity_wrong_nx", put("rigidity", grid_field(8, DEFORM_N)), "request.rigidity.nx"),
    bad(R, "rigidity_unset", drop("rigidity"), "request.rigidity"),
    bad(
        R,
        "rigidity_short_data",
        put("rigidity.data", bytes(4 * DEFORM_N * DEFORM_N - 4)),
        "request.rigidity.data",
    ),
    bad(
        R,
        "texture_3x3",
        also(put("texture", deform_image(3)), put("rigidity", grid_field(3, 3, 0.0))),
        "request.texture is 3 x 3 texels",
    ),
    bad(
        R,
        "texture_short_data",
        put("texture.channels[0].data", bytes(10)),
        "request.texture.channels[0].data",
    ),
    bad(
        R,
        "texture_pixels8_oversize",
        put(
            "texture",
            textures_pb2.ImageTexture(
                pixels8=textures_pb2.Pixels8(width=70000, height=70000, channels=1)
            ),
        ),
        "request.texture.pixels8.width * request.texture.pixels8.height",
        EXHAUSTED,
    ),
    bad(R, "chart_wrong_ny", put("chart", grid_field(DEFORM_N, 4, 1.0)), "request.chart.ny"),
    bad(R, "control_unknown_enum", put("control", 9), "request.control"),
    bad(R, "d_mu_1000", put("d_mu", 1000.0), "request.d_mu"),
    bad(R, "d_mu_nan", put("d_mu", NAN), "request.d_mu"),
    bad(R, "kappa_inf", put("kappa", INF), "request.kappa"),
    bad(R, "map_unset", put("control", textures_pb2.DEFORM_CONTROL_MAP), "request.d_mu_map"),
    bad(
        R,
        "map_wrong_nx",
        also(
            put("control", textures_pb2.DEFORM_CONTROL_MAP),
            put("d_mu_map", grid_field(DEFORM_N + 1, DEFORM_N)),
        ),
        "request.d_mu_map.nx",
    ),
    bad(
        R,
        "deformation_start_det_negative",
        also(
            put("control", textures_pb2.DEFORM_CONTROL_ISOTROPIC),
            put("deformation_start", textures_pb2.Tensor2(xx=-1.0, yy=1.0)),
        ),
        "request.deformation_start",
    ),
    bad(
        R,
        "deformation_end_nan",
        put("deformation_end", textures_pb2.Tensor2(xx=1.0, yy=NAN)),
        "request.deformation_end.yy",
    ),
    bad(
        R,
        "stroke_radius_zero",
        put("strokes", [textures_pb2.BrushStroke(center=vec2(8, 8), strength=1.0)]),
        "request.strokes[0].radius",
    ),
    bad(
        R,
        "stroke_radius_1e-30",  # 2 r^2 underflows float
        put(
            "strokes",
            [textures_pb2.BrushStroke(center=vec2(4.5, 4.5), radius=1e-30, strength=1.0)],
        ),
        "request.strokes[0].radius",
    ),
    bad(
        R,
        "strokes_257",
        put("strokes", [textures_pb2.BrushStroke(center=vec2(8, 8), radius=2.0)] * 257),
        "request.strokes",
    ),
    bad(R, "frames_zero", put("frames", 0), "request.frames"),
    bad(R, "dt_zero", put("dt", 0.0), "request.dt"),
    bad(R, "substeps_101", put("substeps", 101), "request.substeps"),
    bad(R, "stack_levels_17", put("stack_levels", 17), "request.stack_levels"),
    bad(
        R,
        "stack_oversize",
        also(
            put("texture", deform_image(64)),
            put("rigidity", rigidity(64)),
            put("stack_levels", 16),
        ),
        "request.stack_levels",
        EXHAUSTED,
    ),
    bad(R, "tolerance_1", put("tolerance", 1.0), "request.tolerance"),
    bad(R, "max_iterations_zero", put("max_iterations", 0), "request.max_iterations"),
    bad(R, "planes_unknown_enum", put("planes", [9]), "request.planes[0]"),
    bad(R, "dtype_unknown_enum", put("dtype", 9), "request.dtype"),
]

R = "Textures.DeformInteractive"  # message 0 starts (one frame), message 1 steers (one frame)
CASES += [
    bad(R, "no_start", drop("start"), "control[0].start", frames=0),
    bad(R, "start_frames_3", put("start.frames", 3), "control[0].start.frames", frames=0),
    bad(
        R,
        "start_twice",
        put("start", deform_request(frames=0), at=1),
        "control[1].start",
        frames=1,
    ),
    bad(
        R,
        "start_rigidity_2",
        put("start.rigidity", grid_field(DEFORM_N, DEFORM_N, 2.0)),
        "control[0].start.rigidity",
        frames=0,
    ),
    bad(R, "frames_2000", put("frames", 2000, at=1), "control[1].frames", frames=1),
    bad(R, "d_mu_nan", put("d_mu", NAN, at=1), "control[1].d_mu", frames=1),
    bad(R, "d_mu_1000", put("d_mu", -1000.0, at=1), "control[1].d_mu", frames=1),
    bad(
        R,
        "map_wrong_nx",
        also(
            put("start.control", textures_pb2.DEFORM_CONTROL_MAP),
            put("start.d_mu_map", grid_field(DEFORM_N, DEFORM_N, 0.1)),
            put("d_mu_map", grid_field(DEFORM_N - 1, DEFORM_N), at=1),
        ),
        "control[1].d_mu_map.nx",
        frames=1,
    ),
    bad(
        R,
        "deformation_det_zero",
        also(
            put("start.control", textures_pb2.DEFORM_CONTROL_ISOTROPIC),
            put("deformation", textures_pb2.Tensor2(xx=1.0, xy=1.0, yx=1.0, yy=1.0), at=1),
        ),
        "control[1].deformation",
        frames=1,
    ),
    bad(
        R,
        "stroke_radius_negative",
        also(
            put("start.control", textures_pb2.DEFORM_CONTROL_BRUSH),
            put("strokes", [textures_pb2.BrushStroke(center=vec2(8, 8), radius=-1.0)], at=1),
        ),
        "control[1].strokes[0].radius",
        frames=1,
    ),
]


# ---- the tests -------------------------------------------------------------------------------


def test_every_rpc_has_cases() -> None:
    per_rpc = {rpc: sum(c.rpc == rpc for c in CASES) for rpc in RPCS}
    assert per_rpc["Server.GetInfo"] >= 1  # its only input is request_id
    assert all(n >= 3 for rpc, n in per_rpc.items() if rpc != "Server.GetInfo"), per_rpc
    for table in (CASES, EXTREMES):
        names = [f"{c.rpc}-{c.name}" for c in table]
        assert len(names) == len(set(names)), "case names must be unique"
    assert {e.rpc for e in EXTREMES} <= set(EXTREME_BASES) | {"EWave.CreateSession", "EWave.Step"}


@pytest.mark.parametrize("case", [c.param() for c in CASES])
def test_bad_input(env: Env, case: Case) -> None:
    received, error = send(env, case)
    if error is None:
        forget(env, received)
        pytest.fail(f"{case.rpc} accepted the malformed request ({len(received)} replies)")
    code, details = error.code(), error.details() or ""
    shown = details if len(details) < 600 else details[:600] + "..."
    assert code == case.code, f"{code.name}: {shown}"
    assert case.field in details, f"the message does not name {case.field!r}: {shown}"
    assert len(details) < 2000, f"a {len(details)}-character message: {shown}"
    assert "\n" not in details, f"a message of several lines: {shown}"
    if case.frames is not None:
        assert len(received) == case.frames, f"{len(received)} frames before the error"


def test_newline_in_request_id_stays_in_its_log_line(env: Env) -> None:
    """GetInfo takes any request_id (free text); a newline in it must not forge a log line."""
    request = server_pb2.GetInfoRequest(request_id=f"sweep\n{FORGED} request id=evil status=OK")
    reply = server_pb2_grpc.ServerStub(env.channel).GetInfo(request, timeout=TIMEOUT)
    assert reply.ready
    log = env.daemon.log()
    assert "sweep\\x0aFORGED" in log  # the request line shows it escaped
    assert not [line for line in log.splitlines() if line.startswith(FORGED)]


# A request gRPC cannot decode as the method's message, as a client with a broken encoder (or a proxy
# mangling bodies) would send it: an unterminated varint, a field longer than the message, no message.
UNDECODABLE: Dict[str, Optional[bytes]] = {
    "garbled_varint": b"\xff\xff\xff",
    "truncated_field": b"\x0a\x05ab",  # field 1, 5 bytes announced, 2 sent
    "no_message": None,
}


def one_request_methods() -> List[Tuple[str, str]]:
    """(path, request type) of every method that takes one request: squall's unary and
    server-streaming RPCs, and the health service squalld serves."""
    modules = [server_pb2, ocean_pb2, ewave_pb2, clouds_pb2, textures_pb2]
    squall_methods = [
        (f"/{service.full_name}/{method.name}", method.input_type.full_name)
        for module in modules
        for service in module.DESCRIPTOR.services_by_name.values()
        for method in service.methods
        if not method.client_streaming
    ]
    health = "grpc.health.v1.HealthCheckRequest"  # no generated module: see squall.client
    return squall_methods + [(f"/grpc.health.v1.Health/{m}", health) for m in ("Check", "Watch")]


@pytest.mark.parametrize("payload", sorted(UNDECODABLE))
@pytest.mark.parametrize("path,request_type", one_request_methods())
def test_undecodable_request_is_invalid_argument_naming_its_type(
    env: Env, path: str, request_type: str, payload: str
) -> None:
    """gRPC's own answer to a request it cannot decode is INTERNAL with no message, which blames the
    server; squalld answers INVALID_ARGUMENT naming the message type it expected. (A client stream's
    undecodable message reads as the end of the client's stream in gRPC's synchronous API.)"""
    body = UNDECODABLE[payload]
    messages = [] if body is None else [body]
    call = env.channel.stream_stream(path)  # raw bytes either way; a stream call can send none
    with pytest.raises(grpc.RpcError) as raised:
        list(call(iter(messages), timeout=TIMEOUT))
    error = raised.value
    assert error.code() == grpc.StatusCode.INVALID_ARGUMENT, f"{error.code()}: {error.details()}"
    assert f"request: not a {request_type} in protobuf's wire format" in error.details()


def test_daemon_is_unharmed(env: Env) -> None:
    """After the sweep: alive, SERVING, the same replies, the target session unchanged, both stream
    slots free, no forged log line."""
    assert env.daemon.running(), env.daemon.log()[-3000:]
    with squall.Client(env.daemon.address, timeout=30) as client:
        assert client.health() == "SERVING"
        assert client.info().ready
    after = reference_replies(env.channel, env.volume)
    assert after.keys() == env.before.keys()
    for rpc, replies in env.before.items():
        assert after[rpc] == replies, f"{rpc} answers differently after the sweep"
    ewave = ewave_pb2_grpc.EWaveStub(env.channel)
    state = ewave.GetState(ewave_pb2.EWaveSessionRequest(session_id=env.session), timeout=TIMEOUT)
    assert state.state == env.state, "a refused step changed the session"
    frame = ewave.Step(step_request(env.session), timeout=TIMEOUT)
    assert frame.step == 3  # two steps before the sweep, none during it
    # both --max-streams slots: no refused stream kept one
    ocean = ocean_pb2_grpc.OceanStub(env.channel)
    streams = [
        ocean.StreamTiles(stream_tiles_request(frames=0), timeout=TIMEOUT) for _ in range(2)
    ]
    try:
        for stream in streams:
            assert next(stream).frame_index == 0
    finally:
        for stream in streams:
            stream.cancel()
    log = env.daemon.log()
    assert not [line for line in log.splitlines() if line.startswith(FORGED)]


# ---- finite but extreme values -----------------------------------------------------------------
#
# Either answer is right: a refusal (INVALID_ARGUMENT or RESOURCE_EXHAUSTED naming the field, as for
# malformed input) or a prompt reply whose numbers are all finite. Some of these once made squalld
# compute without end (and ignore the client's deadline), so they run on a throwaway squalld of their
# own, those last; its short grace period ends it quickly should one run away again.

EXTREME_TIMEOUT = 4.0  # s; every one of these answers in well under 0.1 s when it answers at all


@dataclasses.dataclass(frozen=True)
class Extreme:
    rpc: str
    name: str
    change: Change
    field: str  # a refusal must name it
    xfail: str = ""

    def param(self) -> Any:
        marks = [pytest.mark.xfail(strict=True, reason=self.xfail)] if self.xfail else []
        return pytest.param(self, id=f"{self.rpc}-{self.name}", marks=marks)


E_LAYER = "tile.layers[0]"
EXTREMES: List[Extreme] = [
    Extreme(
        "Ocean.GetTile",
        "layer_extent_1e-300",
        also(put(f"{E_LAYER}.extent_x", 1e-300), put(f"{E_LAYER}.extent_y", 1e-300)),
        f"{E_LAYER}.extent_x",
    ),
    Extreme(
        "Ocean.GetTile",
        "time_1e300",
        put("time.seconds", 1e300),
        "time.seconds",
    ),
    Extreme(
        "Ocean.GetTile",
        "phillips_amplitude_1e300",
        also(
            put(f"{E_LAYER}.spectrum", ocean_pb2.SPECTRUM_MODEL_PHILLIPS),
            put(f"{E_LAYER}.phillips_amplitude", 1e300),
        ),
        f"{E_LAYER}.phillips_amplitude",
    ),
    Extreme("Ocean.SampleSurface", "point_x_1e300", put("points[0].x", 1e300), "points[0].x"),
    Extreme(
        "EWave.CreateSession",
        "nx_1",
        put("config.nx", 1),
        "config.nx",
    ),
    Extreme(
        "EWave.CreateSession",
        "gravity_1e300",
        put("config.gravity", 1e300),
        "config.gravity",
    ),
    Extreme(
        "EWave.CreateSession",
        "dx_1e-300",
        also(put("config.dx", 1e-300), put("config.dy", 1e-300)),
        "config.dx",
    ),
    Extreme(
        "EWave.CreateSession",
        "displacement_scale_1e308",
        put("config.displacement_scale", 1e308),
        "config.displacement_scale",
    ),
    Extreme(
        "EWave.Step",
        "dt_1e300",
        put("inputs.dt", 1e300),
        "inputs.dt",
    ),
    Extreme(
        "EWave.Step",
        "drift_x_1e308",
        put("inputs.drift_x", 1e308),
        "inputs.drift_x",
    ),
    Extreme("EWave.Step", "drift_x_1e30", put("inputs.drift_x", 1e30), "inputs.drift_x"),
    Extreme(
        "Clouds.BuildVolume",
        "sphere_radius_1e-100",
        put("model.spheres[0].radius", 1e-100),
        "model.spheres[0].radius",
    ),
    Extreme(
        "Clouds.Render", "eye_1e30", put("settings.camera.eye.y", -1e30), "settings.camera.eye"
    ),
    Extreme(
        "Clouds.Render",
        "noise_frequency_1e300",
        also(
            put("model.pyroclastic.layers", 1),
            put("model.pyroclastic.amplitude", 1.0),
            put("model.pyroclastic.noise.frequency", 1e300),
        ),
        "model.pyroclastic.noise.frequency",
    ),
    Extreme(
        "Textures.AdvectTexture",
        "lagrangian_velocity_1e300",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_LAGRANGIAN_GRIDS),
            put("velocity.named.velocity_x", 1e300),
        ),
        "request.velocity.named.velocity_x",
    ),
    Extreme(
        "Textures.AdvectTexture",
        "eulerian_velocity_1e300",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_EULERIAN_MULTILAYER),
            put("velocity.named.velocity_x", 1e300),
        ),
        "request.velocity.named.velocity_x",
    ),
    Extreme(
        "Textures.AdvectTexture",
        "taylor_green_period_1e-300",
        put(
            "velocity.named",
            textures_pb2.AnalyticVelocity(
                kind=textures_pb2.AnalyticVelocity.KIND_TAYLOR_GREEN, speed=1.0, period=1e-300
            ),
        ),
        "request.velocity.named.period",
    ),
    Extreme(
        "Textures.AdvectTexture",
        "lagrangian_d_1e150",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_LAGRANGIAN_GRIDS), put("lagrangian.d", 1e150)
        ),
        "request.lagrangian.d",
    ),
    Extreme(
        "Textures.BakeVelocity",
        "bank_x_1e300",
        also(
            put("river.channels[0].left_bank.points[1].x", 1e300),
            put("river.channels[0].right_bank.points[1].x", 1e300),
        ),
        "request.river.channels[0]",
    ),
    Extreme(
        "Textures.DeformTexture",
        "brush_radius_1e6",
        also(
            put("control", textures_pb2.DEFORM_CONTROL_BRUSH),
            put(
                "strokes", [textures_pb2.BrushStroke(center=vec2(8, 8), radius=1e6, strength=100)]
            ),
        ),
        "request.strokes[0]",
    ),
    # once runaway handlers, last: should one run away again, it keeps only the throwaway squalld busy
    Extreme(
        "Textures.AdvectTexture",
        "lagrangian_d_1e155",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_LAGRANGIAN_GRIDS), put("lagrangian.d", 1e155)
        ),
        "request.lagrangian.d",
    ),
    Extreme(
        "Textures.AdvectTexture",
        "eulerian_latency_1e-12",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_EULERIAN_MULTILAYER),
            put("eulerian.latencies", [1e-12]),
        ),
        "request.eulerian.latencies[0]",
    ),
    Extreme(
        "Textures.AdvectTexture",
        "eulerian_t0_1e19",
        also(
            put("method", textures_pb2.TEXTURE_METHOD_EULERIAN_MULTILAYER),
            put("t0", 1e19),
            put("dt", 1e4),
        ),
        "request.t0",
    ),
]


# The valid requests of the other RPCs of the table: those of the sweep, without its ids.
EXTREME_BASES: Dict[str, Callable[[], Any]] = {
    "Ocean.GetTile": get_tile_request,
    "Ocean.SampleSurface": sample_surface_request,
    "Clouds.BuildVolume": lambda: clouds_pb2.BuildVolumeRequest(model=cloud_model()),
    "Clouds.Render": lambda: clouds_pb2.RenderRequest(
        model=cloud_model(), settings=render_settings()
    ),
    "Textures.AdvectTexture": advect_request,
    "Textures.BakeVelocity": bake_request,
    "Textures.DeformTexture": deform_request,
}


def numbers(message: Message) -> Iterator[Tuple[str, np.ndarray]]:
    """Every number a reply carries: Field and image values decoded, doubles as they are."""
    for descriptor, value in message.ListFields():
        items = list(value) if is_repeated(descriptor) else [value]
        if descriptor.message_type is None:
            if descriptor.type in (descriptor.TYPE_DOUBLE, descriptor.TYPE_FLOAT):
                yield descriptor.name, np.asarray(items, dtype=np.float64)
            continue
        for item in items:
            if isinstance(item, common_pb2.Field):
                half = item.dtype == common_pb2.DTYPE_FLOAT16
                yield item.name, np.frombuffer(item.data, np.float16 if half else np.float32)
            elif isinstance(item, clouds_pb2.CloudImage):
                yield "image", np.frombuffer(item.data, np.float32)
            else:
                yield from numbers(item)


def extreme_replies(channel: grpc.Channel, case: Extreme) -> List[Message]:
    """The replies to the case's request (an eWave case also steps its session once)."""
    ewave = ewave_pb2_grpc.EWaveStub(channel)
    if case.rpc.startswith("EWave."):
        create = create_session_request()
        if case.rpc == "EWave.CreateSession":
            case.change(create, None)
        session = ewave.CreateSession(create, timeout=EXTREME_TIMEOUT).session_id
        try:
            step = step_request(session)
            step.inputs.outputs.append(ewave_pb2.EWAVE_OUTPUT_NORMAL_Z)
            if case.rpc == "EWave.Step":
                case.change(step, None)
            return [ewave.Step(step, timeout=EXTREME_TIMEOUT)]
        finally:
            request = ewave_pb2.EWaveSessionRequest(session_id=session)
            ewave.CloseSession(request, timeout=EXTREME_TIMEOUT)
    request = EXTREME_BASES[case.rpc]()
    case.change(request, None)
    stub, method, kind = RPCS[case.rpc]
    reply = getattr(stub(channel), method)(request, timeout=EXTREME_TIMEOUT)
    return [reply] if kind == UNARY else list(reply)


@pytest.fixture(scope="module")
def extremes_daemon() -> Iterator[Daemon]:
    flags = ["--max-grid-cells", str(MAX_GRID_CELLS), "--grace-period", "1", "--drain-wait", "0"]
    yield from _start(flags, "bad-input-extremes")


@pytest.mark.parametrize("case", [c.param() for c in EXTREMES])
def test_in_range_extreme_is_answered_or_refused_by_name(
    extremes_daemon: Daemon, case: Extreme
) -> None:
    with grpc.insecure_channel(extremes_daemon.address, options=list(CHANNEL_OPTIONS)) as channel:
        try:
            replies = extreme_replies(channel, case)
        except grpc.RpcError as error:
            code, details = error.code(), error.details() or ""
            assert code in (INVALID, EXHAUSTED), f"{code.name}: {details[:600]}"
            assert case.field in details, f"the message does not name {case.field!r}: {details}"
            return
        finally:
            assert extremes_daemon.running(), extremes_daemon.log()[-3000:]
    nonfinite = [
        f"{name}: {int(np.sum(~np.isfinite(values)))} of {values.size}"
        for reply in replies
        for name, values in numbers(reply)
        if not np.all(np.isfinite(values))
    ]
    assert not nonfinite, f"non-finite values in the reply: {nonfinite}"
