"""The ocean surface of one Blender object, computed by squalld: no bpy here, only numpy and squall.

The mesh is a grid of (n + 1) x (n + 1) vertices over one periodic tile of side L (the last row and
column repeat the first, so copies of the object tile seamlessly). Vertex (i, j) rests at
((i / n - 1/2) L, (j / n - 1/2) L, 0) in the object's frame and moves by the tile's sample
(i mod n, j mod n): (displacement_x, displacement_y, height) (J. Tessendorf, "Simulating Ocean
Water", eqs 4 and 29, as squall's Ocean.GetTile returns them).

A wake adds an eWave session (J. Tessendorf, "eWave: Using an Exponential Solver on the iWave
Problem") on a periodic grid of the same extent, its cell (i, j) centred at ((i + 1/2) h, (j + 1/2) h)
from the mesh's corner; the boat is an elliptic obstruction that is also a height source (eq 75), and
the session's height and displacement, interpolated bilinearly at the vertices, are added to the
ocean's (linear superposition).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Dict, Optional

import numpy as np

SPECTRA = ("jonswap", "pierson_moskowitz", "phillips", "tma")
DISPLACEMENT_OUTPUTS = ("displacement_x", "displacement_y", "height")


@dataclass(frozen=True)
class OceanParameters:
    """The tile: one squall ocean layer and its choppiness (units SI)."""

    extent: float = 200.0  # L, m
    resolution: int = 128  # n, FFT samples per side (even)
    spectrum: str = "jonswap"
    wind_speed: float = 10.0  # U10, m/s
    wind_direction: float = 0.0  # rad, counter-clockwise from +x, where the wind blows to
    choppiness: float = 1.0  # lambda of the horizontal displacement
    seed: int = 1

    def tile_spec(self) -> Any:
        import squall

        layer = squall.ocean.layer(
            extent=self.extent,
            n=self.resolution,
            spectrum=self.spectrum,
            wind_speed=self.wind_speed,
            wind_direction=self.wind_direction,
            seed=self.seed,
        )
        return squall.ocean.tile_spec([layer], choppiness=self.choppiness)


@dataclass(frozen=True)
class WakeParameters:
    """The eWave session that carries a boat's wake."""

    resolution: int = 128  # cells per side of the session's grid over the tile
    source_scale: float = 1.0  # S0 of the hull's height source (eq 75), m/s
    substeps: int = 2  # eWave steps per animation frame


@dataclass(frozen=True)
class Hull:
    """The boat at one instant, in the ocean object's frame: centre (m), heading (rad), size (m)."""

    x: float
    y: float
    heading: float
    length: float
    beam: float


def rest_positions(extent: float, n: int) -> np.ndarray:
    """Vertex rest positions, shape ((n + 1)^2, 3), x fastest."""
    s = (np.arange(n + 1) / n - 0.5) * extent
    x, y = np.meshgrid(s, s)
    return np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)


def periodic_vertices(field: np.ndarray) -> np.ndarray:
    """An (n, n) tile as (n + 1)^2 vertex values: the last row and column repeat the first."""
    return np.pad(field, ((0, 1), (0, 1)), mode="wrap").ravel()


def bilinear_periodic(field: np.ndarray, cell: float, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """A periodic cell-centred grid (ny, nx) of spacing `cell`, sampled at (x, y) from its corner."""
    ny, nx = field.shape
    u, v = x / cell - 0.5, y / cell - 0.5
    i0, j0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    fu, fv = u - i0, v - j0
    i0, j0 = i0 % nx, j0 % ny
    i1, j1 = (i0 + 1) % nx, (j0 + 1) % ny
    f = field.astype(np.float64)
    return (1 - fv) * ((1 - fu) * f[j0, i0] + fu * f[j0, i1]) + fv * (
        (1 - fu) * f[j1, i0] + fu * f[j1, i1]
    )


class Wake:
    """An eWave session stepped along the animation: advance(t) brings it to time t."""

    def __init__(self, client: Any, params: WakeParameters, extent: float, start_time: float):
        self.client, self.params, self.extent = client, params, extent
        self.cell = extent / params.resolution
        self.start_time = start_time
        self.session: Any = None
        self.time = start_time
        self.fields: Dict[str, np.ndarray] = {}

    def _open(self) -> None:
        import squall

        self.close()
        n = self.params.resolution
        config = squall.ewave.config(
            n, n, self.cell, source_scale=self.params.source_scale, start_time=self.start_time
        )
        self.session = self.client.ewave.session(config)
        self.time = self.start_time
        self.fields = {}

    def _hull_shape(self, hull: Hull) -> Any:
        import squall

        half = 0.5 * self.extent  # the grid frame starts at the mesh's corner
        return squall.ewave.ellipse(
            hull.x + half, hull.y + half, 0.5 * hull.length, 0.5 * hull.beam, hull.heading
        )

    def advance(self, t: float, frame_time: float, hull_at: Callable[[float], Hull]) -> None:
        """Steps from the session's time to t (substeps per frame_time); before it, restarts at the
        start time. hull_at(time) is the boat at that time."""
        if self.session is None or t < self.time - 1e-9:
            self._open()
        steps = int(np.ceil((t - self.time) / frame_time * self.params.substeps - 1e-6))
        if steps <= 0:  # already there (or at the start: still water)
            if not self.fields:
                n = self.params.resolution
                self.fields = {k: np.zeros((n, n), np.float32) for k in DISPLACEMENT_OUTPUTS}
            return
        dt = (t - self.time) / steps
        for k in range(steps):
            last = k == steps - 1
            hull = hull_at(self.time + dt)  # the obstruction where it is at the end of the step
            frame = self.session.step(
                dt,
                shapes=[self._hull_shape(hull)],
                outputs=DISPLACEMENT_OUTPUTS if last else ("height",),
                dtype="float32" if last else "float16",
            )
            self.time = frame.time
        self.fields = dict(frame)

    def displacement(self, rest: np.ndarray) -> np.ndarray:
        """The session's (displacement_x, displacement_y, height) at the vertices, ((n + 1)^2, 3)."""
        x, y = rest[:, 0] + 0.5 * self.extent, rest[:, 1] + 0.5 * self.extent
        return np.stack(
            [bilinear_periodic(self.fields[k], self.cell, x, y) for k in DISPLACEMENT_OUTPUTS],
            axis=1,
        )

    def close(self) -> None:
        if self.session is not None:
            self.session.close()
            self.session = None


class OceanSurface:
    """What squalld says the mesh looks like at time t: vertex positions of the ocean (+ wake)."""

    def __init__(
        self,
        client: Any,
        ocean: OceanParameters,
        wake: Optional[WakeParameters] = None,
        start_time: float = 0.0,
    ) -> None:
        self.client, self.ocean = client, ocean
        self.spec = ocean.tile_spec()
        self.rest = rest_positions(ocean.extent, ocean.resolution)
        self.wake = None if wake is None else Wake(client, wake, ocean.extent, start_time)

    def ocean_displacement(self, t: float) -> np.ndarray:
        """(displacement_x, displacement_y, height) of the tile at time t per vertex, m."""
        tile = self.client.ocean.tile(self.spec, time=t, outputs=DISPLACEMENT_OUTPUTS)
        return np.stack([periodic_vertices(tile[k]) for k in DISPLACEMENT_OUTPUTS], axis=1)

    def positions(
        self, t: float, frame_time: float, hull_at: Optional[Callable[[float], Hull]] = None
    ) -> np.ndarray:
        """Vertex positions at time t, ((n + 1)^2, 3), m. With a wake, hull_at(time) places the
        boat; frame_time (s) is the animation's frame duration (the wake's substep unit)."""
        moved = self.rest + self.ocean_displacement(t)
        if self.wake is not None and hull_at is not None:
            self.wake.advance(t, frame_time, hull_at)
            moved += self.wake.displacement(self.rest)
        return moved

    def close(self) -> None:
        if self.wake is not None:
            self.wake.close()
