"""The Blender add-on (client/blender/squall_ocean), run headless by Debian's Blender against a real
squalld: blender_scene.py enables it, builds a plain ocean and one with a boat's wake, plays the
animation and saves the evaluated meshes; these tests compare them with what the Python client gets
from the same daemon for the same tile and eWave steps, computed here independently.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Dict

import numpy as np
import pytest

import squall
from conftest import BINARY_DIR, SOURCE_DIR

BLENDER = os.environ.get("SQUALL_BLENDER") or shutil.which("blender") or "blender"
SCENE = {
    "fps": 24,
    "frame_start": 1,
    "frame_end": 97,  # 4 s
    "extent": 100.0,  # m
    "resolution": 64,
    "spectrum": "jonswap",
    "wind_speed": 9.0,
    "wind_direction": 0.5,
    "choppiness": 1.2,
    "seed": 7,
    "hull_length": 12.0,
    "hull_beam": 3.0,
    "boat_x0": -30.0,
    "boat_x1": -30.0 + 4.3 * 4.0,  # 4.3 m/s: Froude number V / sqrt(g L) = 0.4
    "boat_y": 0.0,
    "wake_resolution": 64,
    "substeps": 2,
    "recorded_frames": [1, 24, 49, 97],
    "revisited_frame": 49,
}
OUTPUTS = ("displacement_x", "displacement_y", "height")


@pytest.fixture(scope="module")
def played(daemon, tmp_path_factory) -> Dict[str, np.ndarray]:
    """blender_scene.py's .npz, from a Blender whose user scripts hold only this add-on."""
    work = tmp_path_factory.mktemp("blender")
    addons = work / "scripts" / "addons"
    addons.mkdir(parents=True)
    (addons / "squall_ocean").symlink_to(SOURCE_DIR / "client" / "blender" / "squall_ocean")
    out = work / "scene.npz"
    argv = [
        BLENDER, "-b", "--factory-startup", "--python-exit-code", "1",
        "--python", str(Path(__file__).with_name("blender_scene.py")), "--",
        "--address", daemon.address,
        "--python-path", str(Path(squall.__file__).resolve().parents[1]),
        "--out", str(out), "--scene", json.dumps(SCENE),
    ]  # fmt: skip
    env = dict(os.environ, BLENDER_USER_SCRIPTS=str(work / "scripts"))
    env.setdefault("POCL_CACHE_DIR", str(BINARY_DIR / "pocl-cache"))
    run = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0 and out.exists(), f"blender failed:\n{run.stdout}\n{run.stderr}"
    with np.load(out) as data:
        return {k: data[k] for k in data.files}


def tile_spec():
    layer = squall.ocean.layer(
        extent=SCENE["extent"],
        n=SCENE["resolution"],
        spectrum=SCENE["spectrum"],
        wind_speed=SCENE["wind_speed"],
        wind_direction=SCENE["wind_direction"],
        seed=SCENE["seed"],
    )
    return squall.ocean.tile_spec([layer], choppiness=SCENE["choppiness"])


def seconds(frame: float) -> float:
    return frame / SCENE["fps"]


def rest() -> np.ndarray:
    """Vertex (i, j) of the (n + 1)^2 grid at ((i / n - 1/2) L, (j / n - 1/2) L, 0)."""
    n, extent = SCENE["resolution"], SCENE["extent"]
    s = (np.arange(n + 1) / n - 0.5) * extent
    x, y = np.meshgrid(s, s)
    return np.stack([x, y, np.zeros_like(x)], axis=-1)  # (n + 1, n + 1, 3)


def vertex_grid(flat: np.ndarray) -> np.ndarray:
    n = SCENE["resolution"]
    return flat.reshape(n + 1, n + 1, 3).astype(np.float64)


def test_the_add_on_registers(played):
    assert played["enabled"].tolist() == [True, True]  # (enabled by default, loaded)


@pytest.mark.parametrize("frame", SCENE["recorded_frames"])
def test_vertices_are_the_tiles_displacement_at_the_frames_time(played, client, frame):
    tile = client.ocean.tile(tile_spec(), time=seconds(frame), outputs=OUTPUTS)
    moved = vertex_grid(played[f"plain_{frame}"]) - rest()
    n = SCENE["resolution"]
    for axis, name in enumerate(OUTPUTS):
        want = tile[name].astype(np.float64)
        got = moved[:n, :n, axis]
        assert np.abs(got - want).max() < 2e-5, name  # float32 coordinates of up to 50 m
        assert np.array_equal(moved[n, :, axis], moved[0, :, axis]), f"{name}: seam in y"
        assert np.array_equal(moved[:, n, axis], moved[:, 0, axis]), f"{name}: seam in x"
    z = moved[:n, :n, 2]
    height = tile["height"].astype(np.float64)
    assert z.var() == pytest.approx(height.var(), rel=1e-5)
    assert z.var() > 0.05  # a 9 m/s JONSWAP sea: Hs = 4 sqrt(var) is about 1.3 m


def wake_reference(client) -> Dict[str, np.ndarray]:
    """The same eWave steps made directly: 2 per frame, the hull where it is at each step's end."""
    n, extent = SCENE["wake_resolution"], SCENE["extent"]
    cell, fps, substeps = extent / n, SCENE["fps"], SCENE["substeps"]
    speed = (SCENE["boat_x1"] - SCENE["boat_x0"]) / seconds(
        SCENE["frame_end"] - SCENE["frame_start"]
    )
    dt = 1.0 / (fps * substeps)
    with client.ewave.session(nx=n, ny=n, dx=cell, source_scale=1.0) as session:
        for k in range(1, (SCENE["frame_end"] - SCENE["frame_start"]) * substeps + 1):
            x = SCENE["boat_x0"] + speed * k * dt + extent / 2  # the grid frame's origin: a corner
            y = SCENE["boat_y"] + extent / 2
            hull = squall.ewave.ellipse(
                x, y, SCENE["hull_length"] / 2, SCENE["hull_beam"] / 2, 0.0
            )
            frame = session.step(dt, shapes=[hull], outputs=OUTPUTS)
    return dict(frame)


def at_cell_corners(field: np.ndarray) -> np.ndarray:
    """A periodic cell-centred field at the cell corners (the vertices): the mean of 4 cells."""
    f = field.astype(np.float64)
    corners = (f + np.roll(f, 1, 0) + np.roll(f, 1, 1) + np.roll(np.roll(f, 1, 0), 1, 1)) / 4
    return np.pad(corners, ((0, 1), (0, 1)), mode="wrap")


def test_the_wake_is_the_boats_ewave_session_added_to_the_ocean(played, client):
    last = SCENE["frame_end"]
    wake = vertex_grid(played[f"waked_{last}"]) - vertex_grid(played[f"plain_{last}"])
    reference = wake_reference(client)
    for axis, name in enumerate(OUTPUTS):
        want = at_cell_corners(reference[name])
        assert np.abs(wake[..., axis] - want).max() < 5e-5, name


def test_the_wake_trails_the_boat(played):
    """Energy of the wake behind the hull against ahead of it, in a band around the track."""
    last = SCENE["frame_end"]
    h = (vertex_grid(played[f"waked_{last}"]) - vertex_grid(played[f"plain_{last}"]))[..., 2]
    x, y = rest()[..., 0], rest()[..., 1]
    bow = SCENE["boat_x1"] + SCENE["hull_length"] / 2
    band = np.abs(y - SCENE["boat_y"]) < 20.0
    behind = band & (x < bow - SCENE["hull_length"]) & (x > SCENE["boat_x0"] - 10.0)
    ahead = band & (x > bow + 10.0) & (x < bow + 30.0)
    assert np.abs(h[behind]).max() > 0.01  # m
    assert (h[behind] ** 2).mean() > 20 * (h[ahead] ** 2).mean()


def test_going_back_replays_the_wake_to_the_same_surface(played):
    frame = SCENE["revisited_frame"]
    again, first = played[f"revisited_{frame}"], played[f"waked_{frame}"]
    assert np.abs(again.astype(np.float64) - first).max() < 2e-5


def test_an_unreachable_daemon_is_reported_not_raised(played):
    message = str(played["refresh"])
    assert "squall:" in message and "UNAVAILABLE" in message, message
