"""client.ocean against a real squalld: GetTile, StreamTiles (chunked), SampleSurface, errors,
slots.
"""

from __future__ import annotations

import csv
import io
import math
import struct
import subprocess
import time
from typing import List

import grpc
import numpy as np
import pytest

import squall
from squall.v1 import common_pb2, ocean_pb2, ocean_pb2_grpc

from conftest import SQUALL_CLI, _start

OUTPUTS = ("height", "displacement_x", "normal_z")


def small_tile(choppiness: float = 1.0, seed: int = 7) -> ocean_pb2.TileSpec:
    """Two layers, 64 x 64 output: every path of the tile at test size."""
    return squall.ocean.tile_spec(
        [
            squall.ocean.layer(
                extent=200, n=64, wind_speed=12, wind_direction=0.3, fetch=50000, seed=seed
            ),
            squall.ocean.layer(
                extent=50, n=32, wind_speed=12, wind_direction=0.3, fetch=50000, seed=seed + 1
            ),
        ],
        choppiness=choppiness,
        output=(64, 64),
    )


def raw_values(field: common_pb2.Field) -> np.ndarray:
    """A Field's values decoded with struct, independently of squall's codec: (ny, nx) float64."""
    count = field.nx * field.ny
    code = {common_pb2.DTYPE_FLOAT32: "f", common_pb2.DTYPE_FLOAT16: "e"}[field.dtype]
    return np.array(struct.unpack(f"<{count}{code}", field.data), dtype=np.float64).reshape(
        field.ny, field.nx
    )


def test_tile_matches_the_raw_reply(client: squall.Client) -> None:
    spec = small_tile()
    tile = client.ocean.tile(spec, time=2.5, outputs=OUTPUTS)
    assert list(tile) == list(OUTPUTS)
    assert tile.time == 2.5 and tile.unresolved_slope_variance > 0
    assert tile.units == {"height": "m", "displacement_x": "m", "normal_z": "1"}
    for name in OUTPUTS:
        assert tile[name].shape == (64, 64) and tile[name].dtype == np.float32
    assert tile.spacing["height"][:2] == pytest.approx((200 / 64, 200 / 64))
    # the same request through the raw generated client class, decoded with struct
    request = ocean_pb2.GetTileRequest(
        tile=spec,
        time=common_pb2.SimTime(seconds=2.5),
        outputs=[
            ocean_pb2.TILE_OUTPUT_HEIGHT,
            ocean_pb2.TILE_OUTPUT_DISPLACEMENT_X,
            ocean_pb2.TILE_OUTPUT_NORMAL_Z,
        ],
    )
    raw = ocean_pb2_grpc.OceanStub(client.channel).GetTile(request, timeout=60)
    for field in raw.fields:
        assert np.array_equal(tile[field.name].astype(np.float64), raw_values(field))
    # physics sanity: a wind sea of about 12 m/s has decimetre-to-metre waves; normals point up
    assert 0.05 < float(tile["height"].std()) < 5.0
    assert float(tile["normal_z"].min()) > 0.0


def test_float16_tile_is_the_float32_tile_rounded(client: squall.Client) -> None:
    spec = small_tile()
    full = client.ocean.tile(spec, time=1.0, outputs=OUTPUTS)
    half = client.ocean.tile(spec, time=1.0, outputs=OUTPUTS, dtype="float16")
    for name in OUTPUTS:
        assert half[name].dtype == np.float16
        assert np.array_equal(half[name], full[name].astype(np.float16)), name


def test_stream_equals_get_tile_bit_for_bit(tight_client: squall.Client) -> None:
    spec, t0, dt = small_tile(), 0.5, 0.25
    # 3 fields of 64 x 64 float32 (48 KiB) exceed a chunk under --max-message-bytes 65536: frames
    # split
    request = squall.ocean.stream_request(spec, dt, 3, t0, OUTPUTS)
    chunks = list(ocean_pb2_grpc.OceanStub(tight_client.channel).StreamTiles(request, timeout=60))
    assert {c.chunk_count for c in chunks} == {2} and len(chunks) == 6
    assert any(p.row_offset > 0 for c in chunks for p in c.pieces)  # a field split across chunks

    frames = list(tight_client.ocean.stream(spec, dt=dt, frames=3, t0=t0, outputs=OUTPUTS))
    assert [f.frame_index for f in frames] == [0, 1, 2]
    for k, frame in enumerate(frames):
        assert frame.time == t0 + k * dt
        tile = tight_client.ocean.tile(spec, time=t0 + k * dt, outputs=OUTPUTS)
        assert frame.unresolved_slope_variance == tile.unresolved_slope_variance
        for name in OUTPUTS:
            assert frame[name].tobytes() == tile[name].tobytes(), (k, name)
            assert frame.origin[name] == tile.origin[name]


def run_cli(address: str, *args: str) -> str:
    result = subprocess.run(
        [str(SQUALL_CLI), "--address", address, *args], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_sample_matches_the_cli(client: squall.Client, daemon) -> None:
    points = np.array([[10.0, 20.0], [33.5, -4.0], [150.25, 199.0]])
    args = [
        "ocean",
        "sample",
        "--extent",
        "200",
        "--grid",
        "64",
        "--wind-speed",
        "12",
        "--time",
        "1.5",
    ]
    for x, y in points:
        args += ["--point", f"{x},{y}"]
    rows = list(csv.DictReader(io.StringIO(run_cli(daemon.address, *args))))
    # the same request from the builders' defaults, which are the command line's
    spec = squall.ocean.tile_spec([squall.ocean.layer(extent=200, n=64, wind_speed=12)])
    samples = client.ocean.sample(spec, points, time=1.5)
    assert len(rows) == 3
    for key in squall.Samples.KEYS:
        assert samples[key].shape == (3,)
        expected = np.array([float(r[key]) for r in rows])  # printed with 9 significant digits
        np.testing.assert_allclose(samples[key], expected, rtol=1e-8, atol=1e-12, err_msg=key)


def test_inverted_samples_land_on_the_query_points(client: squall.Client) -> None:
    points = np.random.default_rng(3).uniform(0, 200, size=(50, 2))
    samples = client.ocean.sample(small_tile(), points, time=4.0, invert_displacement=True)
    # x0 + lambda D(x0) = x where the surface does not fold: the surface point found, x0, sampled
    # again without the inversion, is displaced onto the query point
    sources = np.stack([samples["source_x"], samples["source_y"]], axis=1)
    assert np.abs(sources - points).max() > 0.1  # the tile's displacement is not negligible
    again = client.ocean.sample(small_tile(), sources, time=4.0)
    np.testing.assert_allclose(again.position[:, :2], points, atol=1e-3)
    np.testing.assert_allclose(again["height"], samples["height"], atol=1e-4)
    assert np.allclose(
        np.linalg.norm(
            np.stack([samples["normal_x"], samples["normal_y"], samples["normal_z"]]), axis=0
        ),
        1,
        atol=1e-5,
    )


def test_nan_wind_speed_names_the_field(client: squall.Client) -> None:
    spec = squall.ocean.tile_spec([squall.ocean.layer(extent=200, n=64, wind_speed=math.nan)])
    with pytest.raises(squall.SquallError) as error:
        client.ocean.tile(spec)
    assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "tile.layers[0].wind_speed" in error.value.message
    assert error.value.method == "Ocean.GetTile"
    with pytest.raises(squall.SquallError) as error:  # a stream is refused before its first frame
        next(client.ocean.stream(spec, dt=0.1, frames=2))
    assert (
        error.value.code == grpc.StatusCode.INVALID_ARGUMENT
        and "wind_speed" in error.value.message
    )
    with pytest.raises(ValueError, match="outputs"):  # caught before sending
        client.ocean.tile(spec, outputs=("heigth",))


def wait_for_the_slot(client: squall.Client, spec: ocean_pb2.TileSpec) -> List[int]:
    """The frame indices of a 2-frame stream, once the only --max-streams slot is free (within
    10 s: the server notices a cancellation at its next frame)."""
    deadline = time.monotonic() + 10
    while True:
        try:
            frames = list(client.ocean.stream(spec, dt=0.1, frames=2, outputs="height"))
            return [f.frame_index for f in frames]
        except squall.SquallError as e:
            assert e.code == grpc.StatusCode.RESOURCE_EXHAUSTED and time.monotonic() < deadline, e
            time.sleep(0.05)


def test_a_cancelled_stream_releases_its_slot(tight_client: squall.Client) -> None:
    spec = small_tile()
    first = tight_client.ocean.stream(spec, dt=0.1, frames=0, outputs="height")  # endless
    assert next(first).frame_index == 0
    assert next(first).frame_index == 1
    # the only --max-streams slot is taken
    with pytest.raises(squall.SquallError) as error:
        next(tight_client.ocean.stream(spec, dt=0.1, frames=1, outputs="height"))
    assert (
        error.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
        and "--max-streams" in error.value.message
    )
    first.cancel()
    assert list(first) == []  # a cancelled stream just stops
    assert wait_for_the_slot(tight_client, spec) == [0, 1]


def test_a_message_that_fails_to_convert_ends_its_stream(tight_client: squall.Client) -> None:
    """A reply the client cannot read raises, and the call is cancelled: the server stops streaming
    and gives its --max-streams slot back."""

    def unreadable(chunk: ocean_pb2.TileChunk) -> None:
        raise ValueError("cannot read this chunk")

    spec = small_tile()
    request = squall.ocean.stream_request(spec, 0.1, 0, 0.0, "height", "float32", None)  # endless
    endless = tight_client._connection.stream(
        "Ocean.StreamTiles", tight_client.ocean._rpc.StreamTiles, request, unreadable
    )
    with pytest.raises(ValueError, match="cannot read"):
        next(endless)
    assert wait_for_the_slot(tight_client, spec) == [0, 1]
    assert list(endless) == []  # cancelled: it just stops


def test_an_expired_tile_frees_the_device_within_a_layer() -> None:
    """A tile of eight 2048^2 layers (about 14 s on 2 cores) whose deadline passes after 1.5 s ends
    DEADLINE_EXCEEDED, and the device is free within a layer: a small tile right after it is served
    within two layers' time, timed in the same run (it used to wait for every layer left, five or
    more). On a squalld of its own: the layers' spectra stay cached."""
    layers = [squall.ocean.layer(extent=1000, n=2048, wind_speed=12, seed=s) for s in range(8)]
    heavy = squall.ocean.tile_spec(layers, output=(2048, 2048))
    for daemon in _start([], "expired-tile"):
        with squall.Client(daemon.address, timeout=60) as client:
            for last in (-1, -2):  # the first also makes the transforms' plans
                start = time.monotonic()
                one = squall.ocean.tile_spec(layers[last:][:1], output=(2048, 2048))
                client.ocean.tile(one, time=1.0, outputs=("height",))
                layer = time.monotonic() - start  # a spectrum and its transforms, this run's pace
            with pytest.raises(squall.SquallError) as expired:
                client.ocean.tile(heavy, time=1.0, outputs=("height",), timeout=1.5)
            assert expired.value.code == grpc.StatusCode.DEADLINE_EXCEEDED, expired.value
            start = time.monotonic()
            client.ocean.tile(small_tile(), time=1.0)
            waited = time.monotonic() - start
            assert waited < 2 * layer + 0.5, f"the expired tile held the device {waited} s"
