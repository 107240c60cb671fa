"""client.clouds against a real squalld: BuildVolume (.vdb), Render (H, W, C), StreamEvolution,
release.
"""

from __future__ import annotations

import asyncio
import math
import re
import resource
import signal
import stat
import struct
from functools import partial
from typing import Any, List

import grpc
import numpy as np
import pytest

import squall
import squall.aio
from squall.v1 import clouds_pb2, clouds_pb2_grpc

from conftest import Daemon, LostReply, in_process_server
from processes import wait_for

W, H = 24, 16


def cloud() -> clouds_pb2.CloudModel:
    return squall.clouds.model(voxel_size=1.0, spheres=[(0, 0, 0, 12)])


def settings() -> clouds_pb2.RenderSettings:
    # 60 m away with a 40 degree field of view: the 12 m sphere covers the middle, not the corners
    return squall.clouds.render_settings(
        squall.clouds.camera(eye=(0, -60, 0), width=W, height=H),
        step=0.5,
        lights=[squall.clouds.sun((1, -1, 1), 1.0)],
        shadow="none",
    )


def test_build_writes_the_vdb(client: squall.Client, tmp_path) -> None:
    path = tmp_path / "cloud.vdb"
    volume = client.clouds.build(cloud(), path=path)
    data = path.read_bytes()
    assert volume.vdb == data and len(data) > 1000
    assert struct.unpack("<q", data[:8])[0] == 0x56444220  # OpenVDB's file magic, "VDB "
    s = volume.summary
    assert volume.id is None and s.voxel_size == 1.0
    # active voxels: about the ball's volume (4/3 pi r^3 = 7238 voxels for r = 12) plus the skin
    assert 0.8 * 4 / 3 * math.pi * 12**3 < s.active_voxels < 2.0 * 4 / 3 * math.pi * 14**3
    assert s.bounds_min.x == pytest.approx(-s.bounds_max.x, abs=2.0)
    assert client.clouds.build(cloud()).vdb is None  # not asked for


def test_render_stored_and_inline_are_equal(client: squall.Client) -> None:
    volume = client.clouds.build(cloud(), keep=True)
    assert volume.id
    try:
        stored = client.clouds.render(volume, settings())
        inline = client.clouds.render(cloud(), settings())
        assert stored.channels == ("radiance_0", "transmittance_0", "depth")
        assert stored.pixels.shape == (H, W, 3) and stored.pixels.dtype == np.float32
        assert stored.pixels.tobytes() == inline.pixels.tobytes()
        # channel-major planes in the reply, decoded with struct: pixels[j, i, c]
        request = clouds_pb2.RenderRequest(volume_id=volume.id, settings=settings())
        raw = clouds_pb2_grpc.CloudsStub(client.channel).Render(request, timeout=60).image
        planes = np.array(struct.unpack(f"<{W * H * 3}f", raw.data), dtype=np.float32).reshape(
            3, H, W
        )
        for c, name in enumerate(stored.channels):
            assert np.array_equal(stored[name], planes[c])
        t = stored["transmittance_0"]
        assert 0.0 <= t.min() and t.max() <= 1.0
        assert t[H // 2, W // 2] < 0.9 and t[0, 0] == pytest.approx(
            1.0
        )  # the cloud is in the middle
        assert (
            stored["depth"][0, 0] == -1.0 and stored["depth"][H // 2, W // 2] > 40
        )  # metres from the eye
        assert np.asarray(stored).shape == (H, W, 3)
        assert np.asarray(stored, dtype=np.float64).dtype == np.float64
        copied = np.array(stored, copy=True)
        assert not np.shares_memory(copied, stored.pixels)
        assert np.array_equal(copied, stored.pixels)
        with pytest.raises(KeyError, match="radiance_0, transmittance_0, depth"):
            stored["radiance"]
        assert stored != inline and stored == stored  # images compare by identity
    finally:
        client.clouds.release(volume)
    with pytest.raises(squall.SquallError) as error:
        client.clouds.render(volume.id, settings())
    assert error.value.code == grpc.StatusCode.NOT_FOUND


def test_evolution_stream(client: squall.Client) -> None:
    frames = list(
        client.clouds.evolve(
            cloud(), [0.0, 2.0], evolution=dict(drift=(2.0, 0.0, 0.0)), settings=settings()
        )
    )
    assert [f.time for f in frames] == [0.0, 2.0]
    assert frames[0].image.pixels.shape == (H, W, 3)
    # the cloud drifted 4 m along +x
    assert frames[1].summary.bounds_min.x == pytest.approx(
        frames[0].summary.bounds_min.x + 4.0, abs=1.0
    )


def test_a_mesh_conversion_stops_at_the_deadline(client: squall.Client, daemon: Daemon) -> None:
    """A needle of an ellipsoid (1 m voxels, 6e4 m long, its estimate within the limits) takes
    OpenVDB's mesh conversion about 18 s on 2 cores; with a 1 s deadline squalld stops it within a
    few."""
    needle = dict(voxel_size=1.0, ellipsoids=[dict(center=(0, 0, 0), radii=(0.5, 3e4, 0.5))])
    request = squall.clouds.build_request(needle, keep=False, return_vdb=False, request=None)
    ended = re.compile(
        r"method=/squall\.v1\.Clouds/BuildVolume status=CANCELLED duration_ms=([0-9.]+)"
    )
    before = len(ended.findall(daemon.log()))
    with pytest.raises(grpc.RpcError) as late:
        clouds_pb2_grpc.CloudsStub(client.channel).BuildVolume(request, timeout=1.0)
    assert late.value.code() == grpc.StatusCode.DEADLINE_EXCEEDED
    wait_for(lambda: len(ended.findall(daemon.log())) > before, 60, "the cancelled build's log")
    duration_ms = float(ended.findall(daemon.log())[before])
    assert duration_ms < 6000, duration_ms


def test_a_kept_build_the_client_gave_up_on_is_released(client: squall.Client) -> None:
    """squalld kept the volume (the build ended in time on its side), but the client's deadline
    passed before the reply came: the client releases the id it proposed, so no volume waits for
    its TTL that nobody can name. The call is the real BuildVolume; only its reply is lost."""
    clouds = client.clouds
    rpc = clouds._rpc  # the client's own stub

    proposed: List[str] = []

    def late_build(request: clouds_pb2.BuildVolumeRequest, timeout: float, metadata: Any) -> None:
        proposed.append(dict(metadata)["x-squall-session"])
        rpc.BuildVolume(request, timeout=60, metadata=metadata)
        raise LostReply()

    request = squall.clouds.build_request(cloud(), keep=True, return_vdb=False, request=None)
    undo = partial(squall.clouds.release_call, rpc)
    with pytest.raises(squall.SquallError) as lost:
        clouds._connection.create("Clouds.BuildVolume", late_build, request, 60, "cloud-", undo)
    assert lost.value.code == grpc.StatusCode.DEADLINE_EXCEEDED
    with pytest.raises(squall.SquallError) as gone:  # release() would return either way
        clouds.render(proposed[0], settings())
    assert gone.value.code == grpc.StatusCode.NOT_FOUND, "the kept volume is still stored"


class ReleasedButAnswerLost(clouds_pb2_grpc.CloudsServicer):
    """A Clouds service storing one volume, whose first ReleaseVolume releases it and then ends
    UNAVAILABLE, as a connection lost after the release and before its answer: the client's retry
    policy sends the call again, which finds the volume gone (NOT_FOUND, as squalld)."""

    VOLUME = "cloud-" + "0" * 32

    def __init__(self) -> None:
        self.stored = {self.VOLUME}
        self.calls = 0

    def ReleaseVolume(self, request, context):  # type: ignore[no-untyped-def]
        self.calls += 1
        if request.volume_id not in self.stored:
            context.abort(grpc.StatusCode.NOT_FOUND, f"volume_id: no volume {request.volume_id}")
        self.stored.remove(request.volume_id)
        if self.calls == 1:
            context.abort(grpc.StatusCode.UNAVAILABLE, "connection lost after the release")
        return clouds_pb2.ReleaseVolumeResponse()


async def release_async(address: str, volume: str) -> None:
    async with squall.aio.Client(address) as aclient:
        await aclient.clouds.release(volume)


@pytest.mark.parametrize("flavour", ["sync", "asyncio"])
def test_a_release_whose_answer_was_lost_counts_the_volume_released(flavour: str) -> None:
    """release() is idempotent, as EWaveSession.close(): the retry of a release that was made
    finds the volume gone, and release() returns rather than raising the NOT_FOUND."""
    service = ReleasedButAnswerLost()
    add = clouds_pb2_grpc.add_CloudsServicer_to_server
    with in_process_server(add, service) as address:
        if flavour == "sync":
            with squall.Client(address) as client:
                client.clouds.release(service.VOLUME)
        else:
            asyncio.run(asyncio.wait_for(release_async(address, service.VOLUME), 30))
    assert service.calls == 2, "the lost answer was not retried"
    assert not service.stored


def test_errors_name_the_field(client: squall.Client) -> None:
    bad = squall.clouds.model(voxel_size=1.0, spheres=[(0, 0, 0, math.nan)])
    with pytest.raises(squall.SquallError) as error:
        client.clouds.build(bad)
    assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "model.spheres[0].radius" in error.value.message
    with pytest.raises(squall.SquallError) as error:
        client.clouds.render(cloud(), camera=squall.clouds.camera(width=0, height=4))
    assert (
        error.value.code == grpc.StatusCode.INVALID_ARGUMENT
        and "settings.camera.width" in error.value.message
    )


def test_build_of_a_request_with_a_path_writes_the_vdb(client: squall.Client, tmp_path) -> None:
    path = tmp_path / "request.vdb"
    volume = client.clouds.build(request=clouds_pb2.BuildVolumeRequest(model=cloud()), path=path)
    assert volume.vdb and path.read_bytes() == volume.vdb  # the path asked for the bytes


def test_a_vdb_that_cannot_be_written_whole_leaves_the_file_that_was_there(tmp_path) -> None:
    """A .vdb write that fails (here past RLIMIT_FSIZE, as on a full disk) leaves the old file as
    it was and nothing beside it."""
    path = tmp_path / "cloud.vdb"
    path.write_bytes(b"the volume written before")
    response = clouds_pb2.BuildVolumeResponse(vdb=bytes(1 << 20))
    old_limit = resource.getrlimit(resource.RLIMIT_FSIZE)
    old_handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    try:
        resource.setrlimit(resource.RLIMIT_FSIZE, (1 << 16, old_limit[1]))
        with pytest.raises(OSError):
            squall.clouds.volume_of(response, False, path)
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, old_limit)
        signal.signal(signal.SIGXFSZ, old_handler)
    assert path.read_bytes() == b"the volume written before"
    assert [p.name for p in tmp_path.iterdir()] == ["cloud.vdb"]
    path.chmod(0o640)
    squall.clouds.volume_of(response, False, path)
    assert path.read_bytes() == response.vdb
    assert stat.S_IMODE(path.stat().st_mode) == 0o640  # the file replaced keeps its mode


def test_a_sun_lights_the_side_its_direction_points_to(client: squall.Client) -> None:
    """A directional light's direction points from the scene toward the light (z up): a sun
    overhead makes the sphere's upper half brighter than its lower half, and one below the
    reverse, by far more than the jitter's noise."""

    def halves(direction) -> tuple:
        image = client.clouds.render(
            cloud(),
            camera=squall.clouds.camera(eye=(0, -60, 0), width=W, height=H),
            step=0.5,
            lights=[squall.clouds.sun(direction, 1.0)],
            shadow="direct",
            shadow_step=1.0,
            shadow_trilinear=True,
        )
        radiance = image["radiance_0"]  # row 0 at the top
        return float(radiance[: H // 2].mean()), float(radiance[H // 2 :].mean())

    top, bottom = halves((0, 0, 1))
    print(f"[clouds] sun overhead: upper half {top:.4g}, lower half {bottom:.4g}")
    assert top > 1.5 * bottom
    top, bottom = halves((0, 0, -1))
    assert bottom > 1.5 * top


def test_a_point_light_lights_the_cloud_around_it(client: squall.Client) -> None:
    """A point light inside the sphere, the only light, at (6, 0, 4) m: every pixel finite, the
    brightest pixel in the image's right half and upper half (x right, z up from the camera at
    -y), and twice the intensity gives twice the radiance, bit for bit."""

    def radiance(intensity: float) -> np.ndarray:
        image = client.clouds.render(
            cloud(),
            camera=squall.clouds.camera(eye=(0, -60, 0), width=W, height=H),
            step=0.5,
            lights=[squall.clouds.point_light((6, 0, 4), intensity)],
            shadow="direct",
        )
        return image["radiance_0"]

    once, twice = radiance(1000.0), radiance(2000.0)
    assert np.isfinite(once).all() and once.max() > 0
    row, column = np.unravel_index(int(np.argmax(once)), once.shape)
    assert column >= W // 2 and row < H // 2, (row, column)
    assert np.array_equal(twice, 2 * once)


def test_render_settings_take_the_shadow_march_options() -> None:
    s = squall.clouds.render_settings(shadow_step=0.75, shadow_trilinear=True)
    assert s.shadow_step == 0.75 and s.shadow_trilinear
    assert squall.clouds.render_settings().shadow_step == 0.0


def test_a_mesh_is_obj_text_or_an_existing_file(tmp_path) -> None:
    obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
    path = tmp_path / "hull.obj"
    path.write_text(obj)
    for mesh in (obj, str(path), path):
        assert squall.clouds.model(meshes=[mesh]).meshes[0].obj == obj.encode()
    # a mistyped path, not OBJ text to send
    for missing in (str(tmp_path / "hul.obj"), "hull.OBJ", tmp_path / "hul.obj"):
        with pytest.raises(FileNotFoundError):
            squall.clouds.model(meshes=[missing])
