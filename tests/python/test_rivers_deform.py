"""client.textures against a real squalld: rivers (BakeVelocity, a river driving an advection) and
content-aware deformation (DeformTexture, DeformInteractive), sync and asyncio.
"""

from __future__ import annotations

import asyncio
import math
from typing import Any, Dict, List, Tuple

import grpc
import numpy as np
import pytest

import squall
import squall.aio
from squall.textures import BakedVelocity, DeformFrame

# A Y junction (du): channel 0 along x in [0, 2] between y = 0 and y = 2 carrying Q = 3 du^2/s,
# splitting at x = 2 into two 1 du wide branches (left: up, right: down). The branches' flow rates
# come from the junction: 1.5 each (equal cross-sections).
REGION = (0.0, -2.0, 5.0, 4.0)  # x0, y0, x1, y1
SIZE = (51, 241)  # nodes (nx, ny): spacing 0.1 x 0.025 du, node columns at x = 0, 0.1, ...


# The trapezoidal rule: numpy >= 2 names it trapezoid and has no trapz, older numpy only trapz.
trapezoid = getattr(np, "trapezoid", None) or getattr(np, "trapz")


def y_junction(**extra: Any) -> Dict[str, Any]:
    return dict(
        channels=[
            {"left": [(0, 2), (2, 2)], "right": [(0, 0), (2, 0)], "flow_rate": 3.0},
            {"left": [(2, 2), (5, 3.5)], "right": [(2, 1), (5, 2.5)]},
            {"left": [(2, 1), (5, -0.5)], "right": [(2, 0), (5, -1.5)]},
        ],
        junctions=[{"upstream": [0], "downstream": [1, 2]}],
        search_radius=2.0,
        **extra,
    )


def node_x(i: int) -> float:
    return REGION[0] + i * (REGION[2] - REGION[0]) / (SIZE[0] - 1)


def flux_through_column(baked: BakedVelocity, i: int) -> float:
    """The trapezoid integral of u dy over the fluid nodes of node column i (du^2/s)."""
    ys = np.linspace(REGION[1], REGION[3], SIZE[1])
    fluid = baked.fluid[:, i] > 0
    u = baked.u[:, i].astype(np.float64)
    return float(trapezoid(u[fluid], ys[fluid]))


def test_bake_velocity_y_junction(client: squall.Client) -> None:
    river = squall.textures.river(**y_junction())
    baked = client.textures.bake_velocity(river, size=SIZE, region=REGION)
    assert baked.flow_rates == pytest.approx([3.0, 1.5, 1.5])
    assert [a - b for a, b in zip(baked.left_psi, baked.right_psi)] == pytest.approx(
        baked.flow_rates
    )
    assert baked.psi is None and "psi" not in baked  # only when asked
    assert list(baked) == ["u", "v", "fluid"]
    for name in ("u", "v", "fluid"):
        assert baked[name].shape == (SIZE[1], SIZE[0]) and baked[name].dtype == np.float32
    assert baked.spacing["u"][:2] == pytest.approx((0.1, 0.025))
    assert baked.origin["u"][:2] == pytest.approx(REGION[:2])
    assert baked.undefined_nodes == 0

    # the flux through a cross-section of the main channel, from u on the grid: Q
    i = 10
    assert node_x(i) == pytest.approx(1.0)
    assert flux_through_column(baked, i) == pytest.approx(3.0, rel=0.03)
    # the water moves downstream in the main channel, and not on land
    assert baked.u[(baked.fluid > 0)[:, i], i].mean() > 0
    assert np.all(baked.u[baked.fluid == 0] == 0) and np.all(baked.v[baked.fluid == 0] == 0)

    # psi when asked, the same velocity; the river given as a mapping and as the RiverVelocity
    with_psi = client.textures.bake_velocity(
        y_junction(), size=SIZE, region=REGION, psi=True, dtype="float16"
    )
    assert with_psi.psi is not None and with_psi.psi.shape == (SIZE[1], SIZE[0])
    assert with_psi.psi.dtype == np.float16 and with_psi.u.dtype == np.float16
    np.testing.assert_allclose(with_psi.u, baked.u, atol=5e-3, rtol=1e-2)
    same = client.textures.bake_velocity(river.river, size=SIZE, region=REGION)
    assert same.u.tobytes() == baked.u.tobytes()


def test_bake_velocity_errors_name_the_field(client: squall.Client) -> None:
    spec = y_junction()
    spec["channels"][0]["left"] = [(0, 2), (math.nan, 2)]
    with pytest.raises(squall.SquallError) as error:
        client.textures.bake_velocity(squall.textures.river(**spec), size=(8, 8), region=REGION)
    assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "river.channels[0].left_bank.points[1].x" in error.value.message
    assert error.value.method == "Textures.BakeVelocity"
    with pytest.raises(ValueError, match=r"river\.channels\[1\]\.right_bank"):
        squall.textures.river(channels=[spec["channels"][1], {"left": [(0, 0)], "right": [1, 2]}])


def test_river_drives_an_advection(client: squall.Client) -> None:
    frames = list(
        client.textures.advect(
            method="naive",
            velocity=squall.textures.river(**y_junction(), bake=(32, 32)),
            texture=squall.textures.noise(bands=2),
            size=(32, 32),
            region=REGION,
            frames=3,
            dt=0.1,
        )
    )
    assert [f.index for f in frames] == [0, 1, 2]
    assert frames[0]["final_0"].shape == (32, 32)
    assert not np.array_equal(frames[0]["final_0"], frames[2]["final_0"])  # the river moves it


# ---- deformation

N = 48  # texels


def texture_and_rigidity() -> Tuple[np.ndarray, np.ndarray]:
    """A (N, N, 2) texture (stripes and rings), R = 1 in a disk at the centre and -1 around it."""
    j, i = np.mgrid[0:N, 0:N]
    dx, dy = i + 0.5 - N / 2, j + 0.5 - N / 2
    image = np.stack(
        [0.5 + 0.5 * np.sin(0.7 * i), 0.5 + 0.5 * np.cos(0.4 * np.hypot(dx, dy))], axis=-1
    ).astype(np.float32)
    rigidity = np.where(dx * dx + dy * dy < 100, 1.0, -1.0).astype(np.float32)
    return image, rigidity


STROKE = (24.0, 24.0, 6.0, 1.0)  # cx, cy, radius (texels), strength (d mu per frame)


def test_deform_brush_and_constant(client: squall.Client) -> None:
    image, rigidity = texture_and_rigidity()
    frames: List[DeformFrame] = list(
        client.textures.deform(
            image,
            rigidity,
            control="brush",
            strokes=[STROKE],
            frames=4,
            dt=0.5,
            substeps=4,
            planes=("warp", "color"),
        )
    )
    assert [f.index for f in frames] == [0, 1, 2, 3]
    assert [f.time for f in frames] == pytest.approx([0.0, 0.5, 1.0, 1.5])
    assert list(frames[0]) == ["color_0", "color_1", "warp_x", "warp_y"]  # the proto's order
    for frame in frames:
        assert frame["color_0"].shape == (N, N) and frame["warp_x"].dtype == np.float32
        assert frame.solver_iterations == frames[0].solver_iterations > 0
        assert frame.solver_residual <= 1e-6 * 1.0001
    assert frames[0].max_warp == 0.0  # frame 0 is the undeformed texture
    assert 0 < frames[1].max_warp < frames[3].max_warp
    warp = np.hypot(frames[3]["warp_x"], frames[3]["warp_y"])
    assert float(warp.max()) == pytest.approx(frames[3].max_warp, rel=1e-3)
    assert frames[3].max_reference > 0 and frames[3].min_reference >= 0

    # d mu = 0: the colour is the texture, exactly
    still = list(client.textures.deform(image, rigidity, d_mu=0.0, frames=2))
    for frame in still:
        assert list(frame) == ["color_0", "color_1"]
        assert frame.max_warp == 0.0
        for c in range(2):
            assert frame[f"color_{c}"].tobytes() == image[:, :, c].tobytes()


def test_deform_errors_name_the_field(client: squall.Client) -> None:
    image, rigidity = texture_and_rigidity()
    with pytest.raises(squall.SquallError) as error:
        list(client.textures.deform(image, rigidity * 2, frames=1))
    assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "request.rigidity" in error.value.message
    with pytest.raises(TypeError, match="frames"):
        client.textures.deform(image, rigidity)


def test_deform_interactive(client: squall.Client) -> None:
    image, rigidity = texture_and_rigidity()
    with client.textures.deform_interactive(
        image, rigidity, control="brush", dt=0.5, substeps=4, planes=("color", "warp")
    ) as run:
        still = run.send(frames=2)
        assert [f.index for f in still] == [0, 1] and [f.max_warp for f in still] == [0.0, 0.0]
        pushed = run.send(frames=2, strokes=[STROKE])
        assert [f.index for f in pushed] == [2, 3]
        assert 0 < pushed[0].max_warp < pushed[1].max_warp  # the stroke acts from its first frame
        held = run.send(frames=2, clear_strokes=True)
        assert [f.max_warp for f in held] == [pushed[1].max_warp] * 2  # no brush: the warp holds
        assert held[1]["warp_x"].tobytes() == pushed[1]["warp_x"].tobytes()
        assert run.send(frames=0) == []
        assert run.frames_received == 6
    with client.textures.deform_interactive(image, rigidity, control="brush") as run:
        with pytest.raises(squall.SquallError) as error:
            run.send(strokes=[(24, 24, -1.0, 1.0)])  # radius must be > 0
    assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "control[0]" in error.value.message
    # frames, which the server refuses in a start, are refused before the stream opens
    with pytest.raises(TypeError, match="frames"):
        client.textures.deform_interactive(image, rigidity, frames=2)
    start = squall.textures.deform_request(image, rigidity, frames=2)
    with pytest.raises(TypeError, match="frames"):
        client.textures.deform_interactive(start=start)
    # and so is an end tensor, which the server refuses too: send()'s deformation steers G
    end = ((1.5, 0.0), (0.0, 1.0))
    with pytest.raises(TypeError, match="deformation_end"):
        client.textures.deform_interactive(image, rigidity, control="isotropic", deformation_end=end)


# ---- asyncio


def test_aio_bake_and_deform(client: squall.Client, daemon: Any) -> None:
    image, rigidity = texture_and_rigidity()

    async def main() -> Tuple[BakedVelocity, List[DeformFrame], List[DeformFrame]]:
        async with squall.aio.Client(daemon.address) as aclient:
            baked = await aclient.textures.bake_velocity(
                squall.textures.river(**y_junction()), size=SIZE, region=REGION, psi=True
            )
            frames = [
                f
                async for f in aclient.textures.deform(
                    image, rigidity, control="brush", strokes=[STROKE], frames=3, dt=0.5
                )
            ]
            async with aclient.textures.deform_interactive(
                image, rigidity, control="brush", dt=0.5
            ) as run:
                steered = await run.send(frames=3, strokes=[STROKE])
            return baked, frames, steered

    baked, frames, steered = asyncio.run(asyncio.wait_for(main(), 120))
    expected = client.textures.bake_velocity(y_junction(), size=SIZE, region=REGION, psi=True)
    for name in ("u", "v", "psi", "fluid"):
        assert baked[name].tobytes() == expected[name].tobytes(), name
    assert baked.flow_rates == expected.flow_rates
    oneshot = list(
        client.textures.deform(
            image, rigidity, control="brush", strokes=[STROKE], frames=3, dt=0.5
        )
    )
    assert len(frames) == len(oneshot) == 3
    for a, b in zip(frames, oneshot):
        assert a.index == b.index and a.max_warp == b.max_warp
        assert a["color_0"].tobytes() == b["color_0"].tobytes()
    # the interactive stream's first message starts with the stroke: the one-shot stream's frames
    assert [f.max_warp for f in steered] == [f.max_warp for f in oneshot]
