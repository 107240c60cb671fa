# The cases pass arguments of the wrong type on purpose.
# mypy: disable-error-code="arg-type, list-item"
"""Arguments the client checks before anything is sent: a value of the wrong kind raises TypeError,
one of the right kind out of range ValueError, each naming the argument or field and what is
wanted (``layer.nx = 2.5: want an integer``), never an internal message (a protobuf range error,
an IndexError, "'int' object is not iterable") or a SquallError for what the client did wrong.

Most cases need no daemon (a Client of an address where nothing listens: each mistake is raised
before a call is made); long deadlines and the steering of an interactive stream are also checked
against the shared daemon.
"""

from __future__ import annotations

import asyncio
import warnings
from pathlib import Path
from typing import Any, Callable, Iterator, List, Type

import grpc
import numpy as np
import pytest

import squall
import squall.aio
from squall import clouds, ewave, ocean, textures
from squall._calls import MAX_TIMEOUT, Settings
from squall._convert import array_to_field, to_message
from squall.v1 import textures_pb2

NOTHING_LISTENS = "127.0.0.1:1"
L, ts = ocean.layer, ocean.tile_spec
CUBE_OBJ = """v 0 0 0
v 1 0 0
v 0 1 0
v 0 0 1
f 1 3 2
f 1 2 4
f 1 4 3
f 2 3 4
"""
RIVER = textures.river(
    channels=[{"left": [(0, 1), (2, 1)], "right": [(0, 0), (2, 0)], "flow_rate": 1.0}]
)


@pytest.fixture(scope="module")
def offline() -> Iterator[squall.Client]:
    """A client of an address where nothing listens: nothing it is asked here gets that far."""
    with squall.Client(NOTHING_LISTENS, retries=1) as client:
        yield client


def case(
    name: str, call: Callable[[squall.Client], Any], kind: Type[Exception], match: str
) -> Any:
    """One mistake: `call` raises `kind` whose message matches `match` (the argument or field and
    what is wanted)."""
    return pytest.param(call, kind, match, id=name)


CASES = [
    # a multipeak partial that is no (peak_frequency, Hs) pair
    case(
        "partials-short",
        lambda c: L(spectrum="multipeak", partials=[(1,)]),
        ValueError,
        r"^layer\.partials\[0\] = \(1,\): want a \(peak_frequency, Hs\) pair",
    ),
    case("partials-none", lambda c: L(partials=None), TypeError, r"^layer\.partials = None"),
    # None or a number where a pair or a sequence is wanted
    case("layer-n-none", lambda c: L(n=None), TypeError, r"^layer\.n = None: want .*\(nx, ny\)"),
    case("layer-extent-none", lambda c: L(extent=None), TypeError, r"^layer\.extent = None"),
    case("layer-drift-none", lambda c: L(drift=None), TypeError, r"^layer\.drift = None"),
    case("tile-int", lambda c: c.ocean.tile(5), TypeError, r"^tile = 5: want a TileSpec"),
    case("tile-str", lambda c: c.ocean.tile("abc"), TypeError, r"^tile = 'abc'"),
    case("output-int", lambda c: ts([L()], output=5), TypeError, r"^tile\.output = 5: want"),
    case(
        "advect-size-int",
        lambda c: c.textures.advect(size=4, frames=1),
        TypeError,
        r"^size = 4: want \(width, height\)",
    ),
    case("river-bake-int", lambda c: textures.river(bake=5), TypeError, r"^river\.bake = 5"),
    case(
        "bake-size-int",
        lambda c: c.textures.bake_velocity(RIVER, size=5),
        TypeError,
        r"^request\.size = 5: want \(nx, ny\)",
    ),
    case(
        "spheres-int",
        lambda c: clouds.model(spheres=[5]),
        TypeError,
        r"^model\.spheres\[0\] = 5: want \(x, y, z, radius\)",
    ),
    case(
        "shadow-map-size-int",
        lambda c: clouds.render_settings(shadow_map_size=5),
        TypeError,
        r"^settings\.shadow_map_size = 5: want \(nx, ny, nz\)",
    ),
    case(
        "inputs-drift-none",
        lambda c: ewave.inputs(0.1, drift=None),
        TypeError,
        r"^inputs\.drift = None: want a pair",
    ),
    case(
        "request-id-int",
        lambda c: squall.Client(NOTHING_LISTENS, request_id=5),
        TypeError,
        r"^request_id must be a str or None, not int",
    ),
    case(
        "token-int",
        lambda c: squall.Client(NOTHING_LISTENS, token=5),
        TypeError,
        r"^the token must be a str or None, not int",
    ),
    # out of the field's wire range
    case("layer-seed-negative", lambda c: L(seed=-1), ValueError, r"^layer\.seed = -1: want an"),
    case("layer-n-2**32", lambda c: L(n=2**32), ValueError, r"^layer\.nx = 4294967296: want an"),
    case(
        "stream-frames-negative",
        lambda c: c.ocean.stream(ts([L(n=8)]), dt=1.0, frames=-1),
        ValueError,
        r"^frames = -1: want an integer in \[0, 4294967295\]",
    ),
    case(
        "send-frames-negative",
        lambda c: c.textures.interactive(size=(8, 8)).send(frames=-1),
        ValueError,
        r"^frames = -1: want an integer in \[0, 4294967295\]",
    ),
    case(
        "camera-width-negative",
        lambda c: clouds.camera(width=-1),
        ValueError,
        r"^camera\.width = -1: want an integer in \[0, 4294967295\]",
    ),
    case(
        "noise-bands-negative",
        lambda c: textures.noise(bands=-1),
        ValueError,
        r"^texture\.noise\.bands = -1: want an integer in",
    ),
    case(
        "config-nx-negative",
        lambda c: ewave.config(-1, 2, 0.1),
        ValueError,
        r"^config\.nx = -1: want an integer in",
    ),
    case(
        "after-step-negative",
        lambda c: ewave.unary_step_request("s", ewave.inputs(0.1), after_step=-1),
        ValueError,
        r"^after_step = -1: want an integer in",
    ),
    # no number where a number is wanted
    case(
        "tile-time-none",
        lambda c: c.ocean.tile(ts([L(n=8)]), time=None),
        TypeError,
        r"^time = None: want a number",
    ),
    case(
        "choppiness-str",
        lambda c: ts(choppiness="a"),
        TypeError,
        r"^tile\.choppiness = 'a': want a number",
    ),
    case(
        "sun-irradiance-str",
        lambda c: clouds.sun((0, 0, 1), "x"),
        TypeError,
        r"^sun\.irradiance = 'x': want a number or one per wavelength",
    ),
    case(
        "sun-direction-str",
        lambda c: clouds.sun(("a", 0, 1), 1.0),
        TypeError,
        r"^sun\.direction\[0\] = 'a': want a number",
    ),
    case(
        "circle-str",
        lambda c: ewave.circle("a", 0, 1),
        TypeError,
        r"^circle\.center_x = 'a': want a number",
    ),
    case(
        "box-none",
        lambda c: ewave.box(0, 0, None, 1),
        TypeError,
        r"^box\.half_length = None: want a number",
    ),
    case(
        "extinction-str",
        lambda c: clouds.render_settings(extinction="a"),
        TypeError,
        r"^settings\.extinction",
    ),
    # a sequence of the wrong length
    case(
        "inputs-drift-short",
        lambda c: ewave.inputs(0.1, drift=(1,)),
        ValueError,
        r"^inputs\.drift = \(1,\): want a pair",
    ),
    case(
        "output-region-short",
        lambda c: textures.output(4, 4, region=(0, 0, 1)),
        ValueError,
        r"^output\.region = \(0, 0, 1\): want \(x0, y0, x1, y1\)",
    ),
    case(
        "interactive-size-short",
        lambda c: c.textures.interactive(size=(16,)),
        ValueError,
        r"^size = \(16,\): want \(width, height\)",
    ),
    case(
        "meshes-int",
        lambda c: clouds.model(meshes=[5]),
        TypeError,
        r"^model\.meshes\[0\] = 5: want OBJ text",
    ),
    case(
        "ellipsoid-short",
        lambda c: clouds.model(ellipsoids=[(0, 0, 0, 1)]),
        ValueError,
        r"^model\.ellipsoids\[0\] = \(0, 0, 0, 1\): want \(x, y, z, rx, ry, rz\)",
    ),
    case(
        "drift-field-single",
        lambda c: ewave.inputs(0.1, drift_field=[np.zeros((2, 2))]),
        ValueError,
        r"^inputs\.drift_field = .*: want a pair \(u, v\)",
    ),
    # a number where a sequence is wanted
    case(
        "wavelengths-int",
        lambda c: clouds.render_settings(wavelengths=5),
        TypeError,
        r"^settings\.wavelengths = 5: want a sequence of wavelengths",
    ),
    case(
        "velocity-grid-times-int",
        lambda c: textures.velocity_grid(np.zeros((2, 2)), np.zeros((2, 2)), times=5),
        TypeError,
        r"^velocity_grid\.times = 5: want a sequence of frame times",
    ),
    case(
        "junctions-int",
        lambda c: textures.river(junctions=[5]),
        TypeError,
        r"^river\.junctions\[0\] = 5: want \{'upstream'",
    ),
    case(
        "channels-int",
        lambda c: textures.river(channels=5),
        TypeError,
        r"^river\.channels = 5: want a sequence of channels",
    ),
    # a str (a volume or session id, an address) that is not one
    case(
        "release-int",
        lambda c: c.clouds.release(5),
        TypeError,
        r"^volume = 5: want a stored Volume or its volume id",
    ),
    case(
        "attach-int",
        lambda c: c.ewave.attach(5),
        TypeError,
        r"^session_id = 5: want a session id",
    ),
    case(
        "address-none",
        lambda c: squall.Client(None),
        TypeError,
        r'^address = None: want "host:port"',
    ),
    case(
        "retry-key-str",
        lambda c: ewave.unary_step_request("s", ewave.inputs(0.1), retry_key="k"),
        TypeError,
        r"^retry_key = 'k': want bytes",
    ),
    # a bool is no time step (not dt = 1.0)
    case(
        "run-dt-bool",
        lambda c: ewave.step_request("s", True),
        TypeError,
        r"^inputs\.dt = True: want a number",
    ),
    case(
        "step-inputs-numpy-bool",
        lambda c: ewave.as_inputs(np.bool_(True)),
        TypeError,
        r"^inputs\.dt = (np\.)?True_?: want a number",
    ),
    # a client-side mistake, refused before gRPC would answer it INTERNAL
    case("health-int", lambda c: c.health(5), TypeError, r"^service = 5: want a service name"),
    case(
        "retries-float",
        lambda c: squall.Client(NOTHING_LISTENS, retries=1.5),
        ValueError,
        r"^retries = 1\.5: want an integer",
    ),
    case(
        "retries-negative",
        lambda c: squall.Client(NOTHING_LISTENS, retries=-1),
        ValueError,
        r"^retries = -1: want an integer >= 0",
    ),
    case(
        "retries-str",
        lambda c: squall.Client(NOTHING_LISTENS, retries="3"),
        TypeError,
        r"^retries = '3': want an integer",
    ),
    # a float where an integer is wanted is refused, not truncated
    case(
        "stream-frames-float",
        lambda c: c.ocean.stream(ts([L(n=8)]), dt=1.0, frames=2.5),
        ValueError,
        r"^frames = 2\.5: want an integer",
    ),
    case(
        "output-nx-float",
        lambda c: ts([L()], output=(2.5, 2)),
        ValueError,
        r"^tile\.output\.nx = 2\.5: want an integer",
    ),
    case(
        "send-frames-float",
        lambda c: c.textures.interactive(size=(8, 8)).send(frames=2.7),
        ValueError,
        r"^frames = 2\.7: want an integer",
    ),
    case(
        "deform-send-frames-float",
        lambda c: c.textures.deform_interactive(
            np.zeros((8, 8)), np.zeros((8, 8)), control="brush"
        ).send(frames=2.7),
        ValueError,
        r"^frames = 2\.7: want an integer",
    ),
    case(
        "interactive-size-float",
        lambda c: c.textures.interactive(size=(16.7, 16)),
        ValueError,
        r"^size\[0\] = 16\.7: want an integer",
    ),
    case(
        "river-bake-float",
        lambda c: textures.river(bake=(32.5, 32)),
        ValueError,
        r"^river\.bake\[0\] = 32\.5: want an integer",
    ),
    # a bool field given anything but True or False
    case(
        "b-correction-str",
        lambda c: ts(b_correction="off"),
        TypeError,
        r"^tile\.b_correction = 'off': want True or False",
    ),
    case(
        "invert-displacement-str",
        lambda c: c.ocean.sample(ts([L(n=8)]), [(0.0, 0.0)], invert_displacement="false"),
        TypeError,
        r"^invert_displacement = 'false': want True or False",
    ),
    case(
        "time-varying-str",
        lambda c: textures.noise(time_varying="no"),
        TypeError,
        r"^texture\.noise\.time_varying = 'no': want True or False",
    ),
    case(
        "time-varying-int",
        lambda c: textures.noise(time_varying=1),
        TypeError,
        r"^texture\.noise\.time_varying = 1: want True or False",
    ),
    case(
        "keep-str",
        lambda c: c.clouds.build(clouds.model(spheres=[(0, 0, 0, 5)]), keep="no"),
        TypeError,
        r"^keep = 'no': want True or False",
    ),
    case(
        "clear-strokes-str",
        lambda c: c.textures.deform_interactive(
            np.zeros((8, 8)), np.zeros((8, 8)), control="brush"
        ).send(clear_strokes="no"),
        TypeError,
        r"^clear_strokes = 'no': want True or False",
    ),
    # None for a size or a count, which the message would carry as 0
    case(
        "config-nx-none",
        lambda c: ewave.config(nx=None, ny=16, dx=0.01),
        TypeError,
        r"^config\.nx = None: want an integer",
    ),
    case(
        "config-ny-none",
        lambda c: ewave.config(16, None, 0.01),
        TypeError,
        r"^config\.ny = None: want an integer",
    ),
    case(
        "config-dx-none",
        lambda c: ewave.config(16, 16, None),
        TypeError,
        r"^config\.dx = None: want a number",
    ),
    case(
        "voxel-size-none",
        lambda c: clouds.model(voxel_size=None),
        TypeError,
        r"^model\.voxel_size = None: want a number",
    ),
    case(
        "camera-width-none",
        lambda c: clouds.camera(width=None),
        TypeError,
        r"^camera\.width = None: want an integer",
    ),
    case(
        "camera-height-none",
        lambda c: clouds.camera(height=None),
        TypeError,
        r"^camera\.height = None: want an integer",
    ),
    case(
        "render-step-none",
        lambda c: clouds.render_settings(step=None),
        TypeError,
        r"^settings\.step = None: want a number",
    ),
    case(
        "output-width-none",
        lambda c: textures.output(None, 4),
        TypeError,
        r"^output\.width = None: want an integer",
    ),
    case(
        "output-height-none",
        lambda c: textures.output(4, None),
        TypeError,
        r"^output\.height = None: want an integer",
    ),
    case(
        "advect-request-frames-none",
        lambda c: textures.advect_request(frames=None),
        TypeError,
        r"^request\.frames = None: want an integer",
    ),
    case(
        "checkpoint-every-none",
        lambda c: textures.advect_request(frames=2, checkpoint_every=None),
        TypeError,
        r"^request\.checkpoint_every = None: want an integer",
    ),
    case(
        "deform-request-frames-none",
        lambda c: textures.deform_request(np.zeros((4, 4)), np.zeros((4, 4)), frames=None),
        TypeError,
        r"^request\.frames = None: want an integer",
    ),
    case(
        "stack-levels-none",
        lambda c: textures.deform_request(
            np.zeros((4, 4)), np.zeros((4, 4)), frames=2, stack_levels=None
        ),
        TypeError,
        r"^request\.stack_levels = None: want an integer",
    ),
    case(
        "output-nx-none",
        lambda c: ts([L()], output=(None, 8)),
        TypeError,
        r"^tile\.output\.nx = None: want an integer",
    ),
    case(
        "output-extent-none",
        lambda c: ts([L()], output=(8, 8, 100.0, None)),
        TypeError,
        r"^tile\.output\.extent_y = None: want a number",
    ),
    # an array of numbers that are not real (complex, objects, strings): none is sent in part
    case(
        "sample-points-complex",
        lambda c: c.ocean.sample(ts([L(n=8)]), np.array([[1, 2]], dtype=complex)),
        TypeError,
        r"^points: want numbers, got an array of complex128",
    ),
    case(
        "sample-points-none",
        lambda c: c.ocean.sample(ts([L(n=8)]), [(1.0, None)]),
        TypeError,
        r"^points: want numbers, got an array of object",
    ),
    case(
        "sample-points-str",
        lambda c: c.ocean.sample(ts([L(n=8)]), [("1", "2")]),
        TypeError,
        r"^points: want numbers, got an array of <U1",
    ),
    case(
        "polygon-complex",
        lambda c: ewave.polygon(np.ones((3, 2), dtype=complex)),
        TypeError,
        r"^polygon\.vertices: want numbers, got an array of complex128",
    ),
    case(
        "polyline-complex",
        lambda c: textures.polyline(np.ones((3, 2), dtype=np.complex64), "bank"),
        TypeError,
        r"^bank: want numbers, got an array of complex64",
    ),
    case(
        "tensor-complex",
        lambda c: textures.tensor2(np.eye(2) * 1j, "control.deformation"),
        TypeError,
        r"^control\.deformation: want numbers, got an array of complex128",
    ),
    case(
        "mesh-vertices-complex",
        lambda c: clouds.model(meshes=[(np.zeros((4, 3), dtype=complex), [(0, 1, 2)])]),
        TypeError,
        r"^model\.meshes\[0\]\.vertices: want numbers, got an array of complex128",
    ),
    case(
        "spacing-complex",
        lambda c: array_to_field(np.zeros((2, 2)), spacing=(1, 1j), path="map"),
        TypeError,
        r"^map\.spacing: want numbers, got an array of complex128",
    ),
    # a value beyond the dtype it is sent as
    case(
        "source-height-overflow",
        lambda c: ewave.inputs(0.01, source_height=np.full((4, 4), 1e300)),
        ValueError,
        r"^inputs\.source_height\[0, 0\] = 1e\+300: beyond float32",
    ),
    case(
        "float16-overflow",
        lambda c: array_to_field(np.array([[1.0, 7e4]]), dtype="float16", path="map"),
        ValueError,
        r"^map\[0, 1\] = 70000\.0: beyond float16",
    ),
    case(
        "float-field-overflow",
        lambda c: to_message(textures_pb2.FinalLookup, {"table": [1.0, -1e300]}, "lut"),
        ValueError,
        r"^lut\.table\[1\] = -1e\+300: beyond float32",
    ),
]


@pytest.mark.parametrize("call, kind, match", CASES)
def test_a_mistake_is_refused_before_sending_naming_the_argument(
    offline: squall.Client, call: Callable[[squall.Client], Any], kind: Type[Exception], match: str
) -> None:
    with pytest.raises(kind, match=match):
        call(offline)


def test_what_is_right_is_still_taken() -> None:
    """The checks take every right kind of value: numpy scalars and bools, floats holding an
    integer, arrays, inf and NaN (which the server refuses by name)."""
    layer = L(n=np.int64(8), extent=(np.float32(100), 50), seed=np.uint64(7), drift=np.zeros(2))
    assert (layer.nx, layer.ny, layer.extent_y, layer.seed) == (8, 8, 50.0, 7)
    assert L(n=8.0).nx == 8 and L(n=np.array(16)).ny == 16
    partial = L(spectrum="multipeak", partials=[(1.0, 2.0), np.array([0.5, 1.0])]).partials
    assert [(p.peak_frequency, p.significant_wave_height) for p in partial] == [(1, 2), (0.5, 1)]
    assert ts(b_correction=np.bool_(True), output=(16.0, 8)).b_correction
    assert ocean.stream_request(ts(), 0.1, 2.0).frame_count == 2
    assert textures.noise(time_varying=True).noise.time_varying
    assert clouds.sun(np.array([0.0, 0.0, 1.0]), np.float64(2)).intensity == [2.0]
    assert clouds.render_settings(extinction=0.5, wavelengths=(5e-7, 6e-7)).extinction == [0.5] * 2
    assert ewave.circle(np.float32(1), 2, 3).circle.radius == 3.0
    inputs = ewave.inputs(0.1, source_height=np.full((2, 2), np.inf), drift=np.array([1, 2]))
    assert np.isinf(np.frombuffer(inputs.source_height.data, "<f4")).all()
    assert (inputs.drift_x, inputs.drift_y) == (1.0, 2.0)
    with squall.Client(NOTHING_LISTENS, retries=0, own_connection=np.bool_(True)):
        pass


def test_a_mesh_str_without_a_newline_is_a_path(tmp_path: Path) -> None:
    """OBJ text has a line per vertex and face: a str without a newline names an .obj file."""
    missing = str(tmp_path / "no" / "cube")  # no .obj suffix, no newline: a path
    with pytest.raises(FileNotFoundError, match=r"^model\.meshes\[0\] = '.*/no/cube': no such"):
        clouds.model(meshes=[missing])
    with pytest.raises(FileNotFoundError, match=r"^model\.meshes\[1\] = .*: no such file"):
        clouds.model(meshes=[CUBE_OBJ, tmp_path / "cube.obj"])  # an os.PathLike
    with pytest.raises(ValueError, match=r"^model\.meshes\[0\] = '.*': a directory"):
        clouds.model(meshes=[str(tmp_path)])
    assert clouds.model(meshes=[CUBE_OBJ]).meshes[0].obj == CUBE_OBJ.encode()  # OBJ text
    (tmp_path / "cube").write_text(CUBE_OBJ)
    from_file = clouds.model(meshes=[str(tmp_path / "cube"), tmp_path / "cube"])
    assert [m.obj for m in from_file.meshes] == [CUBE_OBJ.encode()] * 2
    arrays = clouds.model(meshes=[(np.eye(3).tolist() + [[0, 0, 0]], [(0, 1, 2), (0, 2, 3)])])
    assert list(arrays.meshes[0].triangles) == [0, 1, 2, 0, 2, 3]
    with pytest.raises(ValueError, match=r"^model\.meshes\[0\]\.triangles\[1\] = 1\.5"):
        clouds.model(meshes=[(np.zeros((4, 3)), [(0, 1.5, 2)])])
    assert "newline" in (clouds.model.__doc__ or "")


def test_a_timeout_past_the_bound_sends_no_deadline() -> None:
    """gRPC fails a call at once whose deadline it cannot represent (about 1e10 s ahead): a
    timeout past MAX_TIMEOUT (1e8 s) is sent as none, as inf is."""
    assert MAX_TIMEOUT == 1e8
    settings = Settings(1e20, 1e10, None, None)
    assert settings.deadline(None, stream=False) is None
    assert settings.deadline(None, stream=True) is None
    assert settings.deadline(1e10, stream=False) is None
    assert settings.deadline(MAX_TIMEOUT, stream=False) == MAX_TIMEOUT
    assert settings.deadline(30, stream=True) == 30.0
    assert "1e8" in (squall.Client.__doc__ or "")


def test_a_long_timeout_reaches_the_transport() -> None:
    """Nothing listens: the call is refused UNAVAILABLE by the transport, not DEADLINE_EXCEEDED
    before it is made."""
    with squall.Client(NOTHING_LISTENS, timeout=1e20, retries=1) as client:
        for timeout in (None, 1e10, 1e300):
            with pytest.raises(squall.SquallError) as error:
                client.info(timeout=timeout)
            assert error.value.code == grpc.StatusCode.UNAVAILABLE, error.value

    async def call() -> None:
        async with squall.aio.Client(NOTHING_LISTENS, timeout=1e10, retries=1) as client:
            with pytest.raises(squall.SquallError) as error:
                await client.info()
            assert error.value.code == grpc.StatusCode.UNAVAILABLE, error.value

    asyncio.run(call())


def test_the_asyncio_client_checks_its_arguments() -> None:
    async def make(**kwargs: Any) -> None:
        async with squall.aio.Client(**kwargs):
            pass

    async def health(service: Any) -> None:
        async with squall.aio.Client(NOTHING_LISTENS, retries=1) as client:
            await client.health(service)

    with pytest.raises(TypeError, match=r'^address = None: want "host:port"'):
        asyncio.run(make(address=None))
    with pytest.raises(ValueError, match=r"^retries = 1\.5: want an integer"):
        asyncio.run(make(address=NOTHING_LISTENS, retries=1.5))
    with pytest.raises(TypeError, match=r"^service = 5: want a service name"):
        asyncio.run(health(5))


def test_a_tls_file_without_a_pem_block_is_refused(tmp_path: Path) -> None:
    """gRPC takes any bytes as a CA, certificate or key and fails every call later ("empty address
    list"): a file holding no PEM block is a ValueError naming the argument and the file, for the
    sync and the asyncio client alike (both take squall.tls_credentials)."""
    pem = tmp_path / "ca.pem"
    pem.write_text("-----BEGIN CERTIFICATE-----\nAAAA\n-----END CERTIFICATE-----\n")
    text = tmp_path / "passwd"
    text.write_text("root:x:0:0:root:/root:/bin/bash\n")
    empty = tmp_path / "empty.key"
    empty.write_bytes(b"")
    assert isinstance(squall.tls_credentials(ca=str(pem)), grpc.ChannelCredentials)
    assert squall.tls_credentials(ca=str(pem), cert=str(pem), key=str(pem)) is not None
    with pytest.raises(ValueError, match=r"^ca = '.*/passwd': no PEM block \(-----BEGIN "):
        squall.tls_credentials(ca=str(text))
    with pytest.raises(ValueError, match=r"^cert = '.*/passwd': no PEM block"):
        squall.tls_credentials(ca=str(pem), cert=str(text), key=str(pem))
    with pytest.raises(ValueError, match=r"^key = '.*/empty\.key': no PEM block"):
        squall.tls_credentials(cert=str(pem), key=str(empty))
    with pytest.raises(FileNotFoundError):
        squall.tls_credentials(ca=str(tmp_path / "missing.pem"))


# ---- against the shared daemon


def test_long_timeouts_against_a_daemon(client: squall.Client, daemon: Any) -> None:
    spec = ts([L(n=8)])
    assert client.ocean.tile(spec, timeout=1e10)["height"].shape == (8, 8)
    with squall.Client(daemon.address, timeout=1e20, stream_timeout=1e20) as patient:
        assert patient.ocean.tile(spec)["height"].shape == (8, 8)
        assert len(list(patient.ocean.stream(spec, dt=0.1, frames=2))) == 2

    async def call() -> List[Any]:
        async with squall.aio.Client(daemon.address, timeout=1e20, stream_timeout=1e20) as c:
            tile = await c.ocean.tile(spec)
            frames = [f async for f in c.ocean.stream(spec, dt=0.1, frames=2)]
            return [tile, *frames]

    assert len(asyncio.run(call())) == 3


def test_send_of_no_frames_reports_its_error_later(client: squall.Client) -> None:
    """As the send() docstrings say: the server answers nothing to a message of 0 frames, so its
    error comes with the next send() that asks for frames, or with close()."""
    for send in (
        textures.Interactive.send,
        textures.DeformInteractive.send,
        squall.aio.Interactive.send,
        squall.aio.DeformInteractive.send,
    ):
        doc = " ".join((send.__doc__ or "").split())
        assert "frames=0``: send() returns [] " in doc, send.__qualname__
        assert "only by the next send() that asks for frames, or by close()" in doc
    drift = textures.analytic("uniform", velocity_x=0.1)
    run = client.textures.interactive(velocity=drift, size=(8, 8))
    assert run.send(frames=0, dt=-1.0) == [] and run.send(frames=0) == []
    with pytest.raises(squall.SquallError, match=r"control\[0\]\.dt = -1"):
        run.send(frames=1)
    run.close()
    run = client.textures.interactive(velocity=drift, size=(8, 8))
    assert run.send(frames=0, dt=-1.0) == []
    with pytest.raises(squall.SquallError, match=r"control\[0\]\.dt = -1"):
        run.close()


def test_a_whole_build_request_takes_keep_and_return_vdb_too() -> None:
    """build(request=..., keep=True) stores the volume as build(model, keep=True) does: the
    arguments add to what the request asks, never silently dropped."""
    model = squall.clouds.model(0.5, spheres=[(0, 0, 0, 4)])
    whole = squall.clouds.build_request(None, False, False, {"model": model})
    assert not whole.keep and not whole.return_vdb
    both = squall.clouds.build_request(None, True, True, {"model": model})
    assert both.keep and both.return_vdb
    kept = squall.clouds.build_request(None, False, False, {"model": model, "keep": True})
    assert kept.keep, "the request's own keep stays"


@pytest.mark.parametrize(
    "address, warned",
    [
        ("192.0.2.1:50051", True),
        ("squalld.example:50051", True),
        ("dns:///squalld.example:50051", True),
        ("[2001:db8::1]:50051", True),
        ("127.0.0.1:50051", False),
        ("localhost:50051", False),
        ("[::1]:50051", False),
        ("ipv4:127.0.0.2:50051", False),
        ("unix:/run/squalld.sock", False),
        ("ipv6:[::1]:50051,[2001:db8::1]:50051", True),
        ("ipv4:127.0.0.1:50051,127.0.0.2:50051", False),
    ],
)
def test_a_token_sent_in_plaintext_off_this_machine_is_warned_of(address: str, warned: bool) -> None:
    """A bearer token without TLS to another host can be read on the way: the client says so when
    it is made (it connects later), and keeps quiet on loopback, with TLS or without a token."""

    def made(make: Callable[[], Any]) -> List[warnings.WarningMessage]:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            make()
        return [w for w in caught if issubclass(w.category, squall.PlaintextTokenWarning)]

    async def made_async(**kwargs: Any) -> List[warnings.WarningMessage]:
        async def make() -> None:
            await squall.aio.Client(address, **kwargs).close()

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            await make()
        return [w for w in caught if issubclass(w.category, squall.PlaintextTokenWarning)]

    tls = grpc.ssl_channel_credentials()
    for seen in (
        made(lambda: squall.Client(address, token="secret").close()),
        asyncio.run(made_async(token="secret")),
    ):
        assert len(seen) == int(warned), (address, [str(w.message) for w in seen])
        if warned:
            assert address in str(seen[0].message) and "secret" not in str(seen[0].message)
    assert not made(lambda: squall.Client(address).close()), "no token, no warning"
    assert not made(lambda: squall.Client(address, token="t", credentials=tls).close()), "TLS"
    assert not asyncio.run(made_async()), "no token, no warning (asyncio)"
