"""client.textures against a real squalld: AdvectTexture frames, numpy inputs, AdvectInteractive,
errors.
"""

from __future__ import annotations

import gc
import math
import sys
from types import FrameType
from typing import Optional

import grpc
import numpy as np
import pytest

import squall

from processes import wait_for

SIZE = (32, 24)  # width, height


def test_advect_frames(client: squall.Client) -> None:
    frames = list(
        client.textures.advect(
            method="lagrangian",
            velocity=squall.textures.analytic("rotation", angular_velocity=0.5),
            texture=squall.textures.noise(bands=2, final="sum_bands"),
            size=SIZE,
            planes=("coverage", "final"),
            frames=3,
            t0=1.0,
            dt=0.1,
        )
    )
    assert [f.index for f in frames] == [0, 1, 2]
    assert [f.time for f in frames] == pytest.approx([1.0, 1.1, 1.2])
    for frame in frames:
        assert list(frame) == ["final", "coverage"]  # the proto's order whatever the order asked
        assert frame["final"].shape == (24, 32) and frame["final"].dtype == np.float32
        assert len(frame.mean) == 1 and frame.mean[0] == pytest.approx(
            float(frame["final"].mean()), abs=1e-3
        )
        assert frame.stats.particles.alive > 0  # Lagrangian grids carry the texture
    assert not np.array_equal(frames[0]["final"], frames[2]["final"])  # it moves


def test_numpy_inputs(client: squall.Client) -> None:
    """A uint8 image (sent as Pixels8) and the same image as float planes (Fields) give the same
    frames;
    a velocity grid of numpy arrays equals the analytic uniform field it samples."""
    rng = np.random.default_rng(5)
    pixels = rng.integers(0, 256, size=(16, 16, 3), dtype=np.uint8)
    planes = pixels.astype(np.float32) / 255.0
    common = dict(method="naive", size=SIZE, frames=2, dt=0.1, planes=("final", "raw"))
    a = list(client.textures.advect(texture=squall.textures.image(pixels, scale=1.0), **common))
    b = list(client.textures.advect(texture=squall.textures.image(planes, scale=1.0), **common))
    assert list(a[0]) == ["final_0", "final_1", "final_2", "raw_0", "raw_1", "raw_2"]
    assert len(a) == len(b) == 2
    for fa, fb in zip(a, b):
        for name in fa:
            np.testing.assert_allclose(fa[name], fb[name], atol=1e-6, err_msg=name)

    # uint16 pixels are value / 65535 (not sent as their integers); other integers are refused
    wide = pixels.astype(np.uint16) * np.uint16(257)  # v / 255 == 257 v / 65535
    c = list(client.textures.advect(texture=squall.textures.image(wide, scale=1.0), **common))
    for fc, fb in zip(c, b):
        for name in fc:
            np.testing.assert_allclose(fc[name], fb[name], atol=1e-6, err_msg=name)
    with pytest.raises(TypeError, match="int32"):
        squall.textures.image(pixels.astype(np.int32))

    u = np.full((5, 5), 0.2, dtype=np.float32)
    v = np.full((5, 5), -0.1, dtype=np.float32)
    common = dict(
        method="naive", texture=squall.textures.noise(bands=2), size=SIZE, frames=3, dt=0.1
    )
    gridded = list(client.textures.advect(velocity=squall.textures.velocity_grid(u, v), **common))
    uniform = list(
        client.textures.advect(
            velocity=squall.textures.analytic("uniform", velocity_x=0.2, velocity_y=-0.1), **common
        )
    )
    assert len(gridded) == len(uniform) == 3
    for fg, fu in zip(gridded, uniform):
        np.testing.assert_allclose(fg["final_0"], fu["final_0"], atol=1e-5)


def test_interactive(client: squall.Client) -> None:
    start = dict(
        method="eulerian",
        velocity=squall.textures.analytic("uniform", velocity_x=0.1),
        texture=squall.textures.noise(bands=2),
        size=SIZE,
        dt=0.05,
    )
    with client.textures.interactive(**start) as run:
        first = run.send(frames=2)
        assert [f.index for f in first] == [0, 1]
        steered = run.send(
            velocity=squall.textures.analytic("rotation", angular_velocity=1.0), dt=0.1
        )
        assert [f.index for f in steered] == [2] and steered[0].time == pytest.approx(0.05 + 0.1)
        assert run.send(frames=0) == []
    # the same first frames as the one-shot stream of that request
    oneshot = list(client.textures.advect(frames=2, **start))
    assert len(oneshot) == 2
    for a, b in zip(first, oneshot):
        assert a["final_0"].tobytes() == b["final_0"].tobytes()
    with client.textures.interactive(**start) as run:
        with pytest.raises(squall.SquallError) as error:
            run.send(dt=-1.0)
    assert (
        error.value.code == grpc.StatusCode.INVALID_ARGUMENT
        and "control[0]" in error.value.message
    )
    # what the server refuses in a start is refused before the stream opens
    for refused in (dict(frames=2), dict(checkpoint_every=1), dict(resume_state=b"\x01")):
        with pytest.raises(TypeError, match=next(iter(refused))):
            client.textures.interactive(**start, **refused)


def small_interactive() -> dict:
    return dict(texture=squall.textures.noise(bands=2), size=(16, 16), dt=0.1)


def test_a_cancelled_interactive_stream_refuses_to_send(client: squall.Client) -> None:
    """As in squall.aio: a send after cancel() raises SquallError, not the request queue's
    RuntimeError."""
    with client.textures.interactive(**small_interactive()) as run:
        assert len(run.send(frames=1)) == 1
        run.cancel()
        with pytest.raises(squall.SquallError) as error:
            run.send(frames=1)
        assert error.value.code == grpc.StatusCode.FAILED_PRECONDITION


def request_threads() -> int:
    """gRPC's threads feeding a stream's requests (one per open bidirectional call), told by the
    function they run."""

    def feeds_requests(frame: Optional[FrameType]) -> bool:
        while frame is not None:
            if frame.f_code.co_name == "consume_request_iterator":
                return True
            frame = frame.f_back
        return False

    return sum(feeds_requests(frame) for frame in sys._current_frames().values())


def test_an_interactive_stream_dropped_unclosed_ends_its_request_thread(
    client: squall.Client,
) -> None:
    gc.collect()  # the earlier tests' streams, ended, and their request threads with them
    wait_for(lambda: request_threads() == 0, 10, "the earlier streams' request threads to end")
    run = client.textures.interactive(**small_interactive())
    assert len(run.send(frames=1)) == 1 and request_threads() == 1
    del run  # neither closed nor left in a with block
    gc.collect()
    wait_for(lambda: request_threads() == 0, 10, "the request thread to end")


def test_errors_name_the_field(client: squall.Client) -> None:
    with pytest.raises(squall.SquallError) as error:
        list(client.textures.advect(size=SIZE, frames=2, dt=math.nan))
    assert (
        error.value.code == grpc.StatusCode.INVALID_ARGUMENT
        and "request.dt" in error.value.message
    )
    with pytest.raises(squall.SquallError) as error:
        next(
            client.textures.advect(
                size=SIZE, frames=2, velocity="0123456789abcdef0123456789abcdef"
            )
        )
    assert error.value.code == grpc.StatusCode.NOT_FOUND and "ewave_session" in error.value.message
