"""Cloud volumes (squall.v1.Clouds): sparse volumes modeled with OpenVDB, ray-marched images.

Builders: ``model`` (the CloudModel), ``camera``, ``sun`` / ``point_light`` and
    ``render_settings``.
Units: m, s, K; z is up (altitude). Level sets are > 0 inside a shape; density is dimensionless.

Example::

    cloud = squall.clouds.model(voxel_size=1.0, spheres=[(0, 0, 0, 20)], pyroclastic=dict(
        layers=2, amplitude=4.0, noise=dict(frequency=0.05)))
    volume = client.clouds.build(cloud, path="cloud.vdb")          # .vdb written, summary returned
    image = client.clouds.render(cloud, camera=squall.clouds.camera(width=64, height=64),
                                 lights=[squall.clouds.sun((1, -1, 1), 1.0)])
    image.pixels.shape, image.channels   # (64, 64, 3), ('radiance_0', 'transmittance_0', 'depth')
"""

from __future__ import annotations

import contextlib
import os
import stat
import uuid
from functools import partial
from typing import Any, List, Mapping, Optional, Sequence, Union

import grpc

from squall._calls import Connection, Stream, Undo
from squall._convert import (
    UINT32_MAX,
    enum_value,
    flag,
    float_array,
    floats,
    integer,
    items_of,
    message_from,
    number,
    number_or_floats,
    repeated_per,
    sequence,
    shown,
    to_message,
    vec3,
)
from squall._errors import SquallError
from squall._pb import clouds_pb2, clouds_pb2_grpc, rpc_client
from squall._results import EvolutionFrame, Image, Volume

CloudModel = clouds_pb2.CloudModel
RenderSettings = clouds_pb2.RenderSettings
ModelLike = Union[clouds_pb2.CloudModel, Mapping[str, Any]]
SettingsLike = Union[clouds_pb2.RenderSettings, Mapping[str, Any]]
SourceLike = Union[str, Volume, clouds_pb2.CloudModel, Mapping[str, Any]]
PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "model",
    "camera",
    "sun",
    "point_light",
    "render_settings",
    "Clouds",
    "Image",
    "Volume",
    "EvolutionFrame",
]


_MESH_WANT = (
    "OBJ text (a str of several lines) or bytes, the path of an .obj file, (vertices (n, 3), "
    "triangles (m, 3)), a MeshSpec or a mapping of its fields"
)


def _read_mesh(file: Union[str, bytes], path: str) -> clouds_pb2.MeshSpec:
    """The MeshSpec of the OBJ file `file`: FileNotFoundError for a missing one, ValueError for a
    directory, each naming `path`."""
    if os.path.isdir(file):
        raise ValueError(f"{path} = {file!r}: a directory, want an .obj file or OBJ text")
    if not os.path.exists(file):
        raise FileNotFoundError(
            f"{path} = {file!r}: no such file (a str without a newline is the path of an .obj "
            "file; OBJ text has a line per vertex and face)"
        )
    with open(file, "rb") as f:
        return clouds_pb2.MeshSpec(obj=f.read())


def _mesh(value: Any, path: str) -> clouds_pb2.MeshSpec:
    """A MeshSpec (see ``model``'s meshes)."""
    if isinstance(value, (clouds_pb2.MeshSpec, Mapping)):
        return to_message(clouds_pb2.MeshSpec, value, path)
    if isinstance(value, bytes):
        return clouds_pb2.MeshSpec(obj=value)
    if isinstance(value, str) and "\n" in value:
        return clouds_pb2.MeshSpec(obj=value.encode())
    if isinstance(value, (str, os.PathLike)):
        return _read_mesh(os.fspath(value), path)
    vertices, triangles = items_of(value, path, (2,), _MESH_WANT)
    fields = {
        "vertices": float_array(vertices, f"{path}.vertices", "an array (n, 3), m"),
        "triangles": float_array(triangles, f"{path}.triangles", "an array (m, 3) of indices"),
    }
    return to_message(clouds_pb2.MeshSpec, fields, path)  # each value checked as its field


def _shape(item: Any, cls: Any, path: str) -> Any:
    """A `cls` (SphereSpec, EllipsoidSpec, ParticleSpec) from (x, y, z, radius) (an ellipsoid:
    (x, y, z, rx, ry, rz)), a message or a mapping of its fields."""
    if isinstance(item, (Mapping, cls)):
        return to_message(cls, item, path)
    kind = cls.DESCRIPTOR.name
    if cls is clouds_pb2.EllipsoidSpec:
        v = floats(item, path, f"(x, y, z, rx, ry, rz) in m, an {kind} or a mapping", (6,))
        return cls(center=vec3(v[:3]), radii=vec3(v[3:]))
    v = floats(item, path, f"(x, y, z, radius) in m, a {kind} or a mapping", (4,))
    return cls(center=vec3(v[:3]), radius=v[3])


def _shapes(items: Any, cls: Any, name: str) -> List[Any]:
    """The `cls` messages of ``model``'s spheres, ellipsoids or particles."""
    path = f"model.{name}"
    values = sequence(items, path, f"a sequence of {name}")
    return [_shape(item, cls, f"{path}[{i}]") for i, item in enumerate(values)]


def model(
    voxel_size: float = 1.0,
    *,
    spheres: Sequence[Union[Sequence[float], Mapping[str, Any], clouds_pb2.SphereSpec]] = (),
    ellipsoids: Sequence[Union[Sequence[float], Mapping[str, Any], clouds_pb2.EllipsoidSpec]] = (),
    meshes: Sequence[Any] = (),
    particles: Sequence[Union[Sequence[float], Mapping[str, Any], clouds_pb2.ParticleSpec]] = (),
    pyroclastic: Optional[Union[Mapping[str, Any], clouds_pb2.PyroclasticSpec]] = None,
    advection: Optional[Union[Mapping[str, Any], clouds_pb2.AdvectionSpec]] = None,
    temperature: Optional[Union[Mapping[str, Any], clouds_pb2.TemperatureSpec]] = None,
    skin: Optional[float] = None,
    max_active_voxels: Optional[int] = None,
) -> clouds_pb2.CloudModel:
    """A cloud model (Gilligan sec. 6). None leaves an optional field at the server's default.

    Args:
        voxel_size: m, in [1e-4, 1e6] (default 1, as ``squall cloud``).
        spheres: base spheres, unioned: (x, y, z, radius) in m, or SphereSpec / mappings.
        ellipsoids: base ellipsoids: (x, y, z, rx, ry, rz) in m, or EllipsoidSpec / mappings.
        meshes: closed triangle meshes: OBJ text or bytes, a path to an .obj file, or
            (vertices (n, 3) m, triangles (m, 3) indices). A str holding a newline is OBJ text;
            one without (or an os.PathLike) is the path of an .obj file, read here:
            FileNotFoundError when there is none, ValueError for a directory.
        particles: noise-stamped particles (eqs 113-114): (x, y, z, radius) in m, or ParticleSpec /
            mappings (amplitude, bias, fade, noise).
        pyroclastic: PyroclasticSpec or mapping: layers 0..8, amplitude m, gamma, noise (a
            NoiseSpec mapping: frequency 1/m, octaves, roughness, frequency_jump, offset).
        advection: AdvectionSpec or mapping: speed m/s, time s, substeps, scheme, noise.
        temperature: TemperatureSpec or mapping: enabled, surface K, base_altitude m, lapse_rate
            K/m, fluctuation K, noise.
        skin: skin thickness of the density ramp (eq 103), m; unset: 2 voxel sizes.
        max_active_voxels: active-voxel budget; unset: the server's.
    """
    mesh_items = sequence(meshes, "model.meshes", "a sequence of meshes")
    return message_from(
        clouds_pb2.CloudModel,
        None,
        "model",
        voxel_size=number(voxel_size, "model.voxel_size"),
        skin=skin,
        spheres=_shapes(spheres, clouds_pb2.SphereSpec, "spheres"),
        ellipsoids=_shapes(ellipsoids, clouds_pb2.EllipsoidSpec, "ellipsoids"),
        meshes=[_mesh(m, f"model.meshes[{i}]") for i, m in enumerate(mesh_items)],
        pyroclastic=pyroclastic,
        particles=_shapes(particles, clouds_pb2.ParticleSpec, "particles"),
        advection=advection,
        temperature=temperature,
        max_active_voxels=max_active_voxels,
    )


def camera(
    eye: Sequence[float] = (0.0, -100.0, 0.0),
    look_at: Sequence[float] = (0.0, 0.0, 0.0),
    up: Sequence[float] = (0.0, 0.0, 1.0),
    *,
    width: int = 256,
    height: int = 256,
    vertical_fov_deg: Optional[float] = None,
) -> clouds_pb2.CameraSpec:
    """A pinhole camera. Defaults as ``squall cloud render``.

    Args:
        eye, look_at: positions, m (look_at != eye).
        up: up direction, not parallel to look_at - eye.
        width, height: pixels, 1..8192.
        vertical_fov_deg: degrees, (0, 170); unset: 40.
    """
    return message_from(
        clouds_pb2.CameraSpec,
        None,
        "camera",
        eye=vec3(eye, "camera.eye"),
        look_at=vec3(look_at, "camera.look_at"),
        up=vec3(up, "camera.up"),
        width=integer(width, "camera.width", 0, UINT32_MAX),
        height=integer(height, "camera.height", 0, UINT32_MAX),
        vertical_fov_deg=vertical_fov_deg,
    )


_default_camera = camera


def sun(
    direction: Sequence[float], irradiance: Union[float, Sequence[float]]
) -> clouds_pb2.LightSpec:
    """A directional light: `direction` (non-zero) points from the scene toward the light (z up:
    a sun above the horizon has direction z > 0), irradiance W m^-2 m^-1: one number (repeated
    for every wavelength by ``render_settings``) or one per wavelength."""
    want = "a number or one per wavelength, W m^-2 m^-1"
    values = number_or_floats(irradiance, "sun.irradiance", want)
    return clouds_pb2.LightSpec(
        kind=clouds_pb2.LIGHT_KIND_DIRECTIONAL,
        direction=vec3(direction, "sun.direction"),
        intensity=values,
    )


def point_light(
    position: Sequence[float], intensity: Union[float, Sequence[float]]
) -> clouds_pb2.LightSpec:
    """A point light at `position` (m) with intensity W sr^-1 m^-1 (one number, or one per
    wavelength). Its irradiance at distance d is intensity / max(d, r)^2, r half the volume's
    voxel.
    """
    want = "a number or one per wavelength, W sr^-1 m^-1"
    values = number_or_floats(intensity, "point_light.intensity", want)
    return clouds_pb2.LightSpec(
        kind=clouds_pb2.LIGHT_KIND_POINT,
        position=vec3(position, "point_light.position"),
        intensity=values,
    )


def render_settings(
    camera: Optional[Union[clouds_pb2.CameraSpec, Mapping[str, Any]]] = None,
    *,
    step: float = 1.0,
    wavelengths: Sequence[float] = (550e-9,),
    extinction: Union[float, Sequence[float]] = 0.1,
    albedo: Union[float, Sequence[float]] = 0.9,
    lights: Sequence[Union[clouds_pb2.LightSpec, Mapping[str, Any]]] = (),
    phase: Optional[Union[clouds_pb2.PhaseSpec, Mapping[str, Any]]] = None,
    shadow: Union[str, int, None] = None,
    shadow_map_size: Optional[Sequence[int]] = None,
    shadow_step: float = 0.0,
    shadow_trilinear: bool = False,
    substeps: Optional[int] = None,
    trilinear: bool = False,
    seed: int = 0,
    min_transmittance: Optional[float] = None,
) -> clouds_pb2.RenderSettings:
    """Ray-march settings (Gilligan sec. 7). Defaults as ``squall cloud render``.

    Args:
        camera: ``camera(...)``; None: its defaults (256 x 256 from (0, -100, 0)).
        step: ray-march step, m, > 0.
        wavelengths: m, [1e-8, 1e-3], 1 to 8.
        extinction: 1/m per unit density, [0, 1e6], one number for every wavelength or one per
            wavelength.
        albedo: [0, 1], one number for every wavelength or one per wavelength.
        lights: 0..4 ``sun`` / ``point_light``; a single intensity is repeated for every
            wavelength.
        phase: PhaseSpec or mapping (kind "uniform", "henyey_greenstein",
            "double_henyey_greenstein", "fournier_forand"; g1, g2, weight, ff_n, ff_mu); unset:
            Henyey-Greenstein g = 0.8.
        shadow: "none", "direct", "deep_shadow_map" (default).
        shadow_map_size: nodes along x, y, z, 2..512 each; unset: 64 each.
        shadow_step: step of the marches toward the lights, m, >= 0; 0: 3 primary steps.
        shadow_trilinear: trilinear density on the marches toward the lights (default: the
            nearest voxel).
        substeps: random sub-steps per step, 1..8; unset: 1.
        trilinear: trilinear density (default: nearest voxel).
        seed: jitter seed.
        min_transmittance: early termination, [0, 1); unset: 1e-4.
    """
    waves = floats(wavelengths, "settings.wavelengths", "a sequence of wavelengths, m")
    count = len(waves)
    light_messages = []
    for i, light in enumerate(sequence(lights, "settings.lights", "a sequence of lights")):
        message = clouds_pb2.LightSpec()
        message.CopyFrom(to_message(clouds_pb2.LightSpec, light, f"settings.lights[{i}]"))
        if len(message.intensity) == 1 and count > 1:
            message.intensity[:] = [message.intensity[0]] * count
        light_messages.append(message)
    return message_from(
        clouds_pb2.RenderSettings,
        None,
        "settings",
        camera=_default_camera() if camera is None else camera,
        step=number(step, "settings.step"),
        substeps=substeps,
        trilinear=trilinear,
        seed=seed,
        min_transmittance=min_transmittance,
        phase=phase,
        wavelengths=waves,
        extinction=repeated_per(extinction, count, "settings.extinction"),
        albedo=repeated_per(albedo, count, "settings.albedo"),
        lights=light_messages,
        shadow=(
            None
            if shadow is None
            else enum_value(clouds_pb2.ShadowMode.DESCRIPTOR, shadow, "settings.shadow")
        ),
        shadow_map_size=(
            None
            if shadow_map_size is None
            else items_of(shadow_map_size, "settings.shadow_map_size", (3,), "(nx, ny, nz) nodes")
        ),
        shadow_step=shadow_step,
        shadow_trilinear=shadow_trilinear,
    )


def as_settings(
    settings: Optional[SettingsLike], kwargs: Mapping[str, Any]
) -> clouds_pb2.RenderSettings:
    if settings is not None:
        if kwargs:
            raise TypeError(
                "render: pass either settings or render_settings' keyword arguments, not both"
            )
        return to_message(clouds_pb2.RenderSettings, settings, "settings")
    return render_settings(**kwargs)


def stored_session(message: clouds_pb2.RenderRequest) -> Optional[str]:
    """The stored volume a render names, sent as its session (x-squall-session) so that a
    session-affine proxy routes the call to the replica that holds it; None for a model."""
    return message.volume_id if message.WhichOneof("source") == "volume_id" else None


def release_call(rpc: Any, volume_id: str) -> Undo:
    """Connection.create's `undo` for a kept build: what releases `volume_id`.

    The undo is a triple: the method's name ("Clouds.ReleaseVolume"), the connection's
    ReleaseVolume callable (`rpc.ReleaseVolume`) and a ReleaseVolumeRequest for `volume_id`.
    """
    request = clouds_pb2.ReleaseVolumeRequest(volume_id=volume_id)
    return ("Clouds.ReleaseVolume", rpc.ReleaseVolume, request)


def build_request(
    cloud: Optional[ModelLike],
    keep: bool,
    return_vdb: bool,
    request: Optional[clouds_pb2.BuildVolumeRequest],
) -> clouds_pb2.BuildVolumeRequest:
    if request is not None:
        message = clouds_pb2.BuildVolumeRequest()
        message.CopyFrom(to_message(clouds_pb2.BuildVolumeRequest, request))
        # The arguments add to what the request asks (a path asks for the bytes).
        message.keep = message.keep or flag(keep, "keep")
        message.return_vdb = message.return_vdb or flag(return_vdb, "return_vdb")
        return message
    if cloud is None:
        raise TypeError("build: a model is needed (squall.clouds.model(...), or request=...)")
    return clouds_pb2.BuildVolumeRequest(
        model=to_message(clouds_pb2.CloudModel, cloud, "model"),
        keep=flag(keep, "keep"),
        return_vdb=flag(return_vdb, "return_vdb"),
    )


def render_request(
    source: Optional[SourceLike],
    settings: Optional[SettingsLike],
    kwargs: Mapping[str, Any],
    request: Optional[clouds_pb2.RenderRequest],
) -> clouds_pb2.RenderRequest:
    if request is not None:
        return to_message(clouds_pb2.RenderRequest, request)
    message = clouds_pb2.RenderRequest(settings=as_settings(settings, kwargs))
    if isinstance(source, Volume):
        if not source.id:
            raise ValueError(
                "render: the volume was not stored (build it with keep=True) or pass the model"
            )
        message.volume_id = source.id
    elif isinstance(source, str):
        message.volume_id = source
    elif source is not None:
        message.model.CopyFrom(to_message(clouds_pb2.CloudModel, source, "model"))
    else:
        raise TypeError("render: a source is needed: a model, a stored Volume or its volume id")
    return message


def evolution_request(
    cloud: Optional[ModelLike],
    times: Optional[Sequence[float]],
    evolution: Optional[Union[clouds_pb2.EvolutionSpec, Mapping[str, Any]]],
    settings: Optional[SettingsLike],
    include_vdb: bool,
    kwargs: Mapping[str, Any],
    request: Optional[clouds_pb2.StreamEvolutionRequest],
) -> clouds_pb2.StreamEvolutionRequest:
    if request is not None:
        return to_message(clouds_pb2.StreamEvolutionRequest, request)
    if cloud is None or times is None:
        raise TypeError("evolve: a model and times (s) are needed")
    return clouds_pb2.StreamEvolutionRequest(
        model=to_message(clouds_pb2.CloudModel, cloud, "model"),
        evolution=to_message(clouds_pb2.EvolutionSpec, evolution, "evolution"),
        times=floats(times, "times", "a sequence of frame times, s"),
        settings=as_settings(settings, kwargs),
        include_vdb=flag(include_vdb, "include_vdb"),
    )


def write_whole(path: PathLike, data: bytes) -> None:
    """Writes `data` at `path` whole or not at all: into a temporary file beside it, renamed over it
    once written with the mode of the file it replaces, so that a full disk leaves the file that was
    there as it was. Only a regular file this user may write (or none) is replaced so: a device, a
    pipe, a symbolic link, or a file in a folder where no other can be made, is written in place."""
    target = os.fspath(path)
    try:
        st: Optional[os.stat_result] = os.lstat(target)
    except FileNotFoundError:
        st = None
    replaceable = st is None or (stat.S_ISREG(st.st_mode) and os.access(target, os.W_OK))
    temp = f"{target}.partial-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    try:
        fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666) if replaceable else -1
    except OSError:
        fd = -1
    if fd < 0:
        with open(target, "wb") as f:
            f.write(data)
        return
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        if st is not None:
            os.chmod(temp, stat.S_IMODE(st.st_mode))
        os.replace(temp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(temp)
        raise


def volume_of(
    response: clouds_pb2.BuildVolumeResponse, return_vdb: bool, path: Optional[PathLike]
) -> Volume:
    if path is not None:
        write_whole(path, response.vdb)
    return Volume(response.summary, response.vdb if return_vdb else None)


def evolution_frame(frame: clouds_pb2.EvolutionFrame) -> EvolutionFrame:
    return EvolutionFrame(
        frame.time, Image.from_proto(frame.image, frame.summary), frame.summary, frame.vdb or None
    )


def volume_id_of(volume: Union[str, Volume]) -> str:
    """The id of a stored volume: a Volume built with keep=True, or its id (a str)."""
    if isinstance(volume, Volume):
        if not volume.id:
            raise ValueError("release: the volume was not stored (keep=True)")
        return volume.id
    if not isinstance(volume, str):
        raise TypeError(f"volume = {shown(volume)}: want a stored Volume or its volume id (str)")
    return volume


class Clouds:
    """``client.clouds``: the Clouds service (build, render, evolve, release)."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = rpc_client(clouds_pb2_grpc.CloudsStub, connection.channel)

    def build(
        self,
        cloud: Optional[ModelLike] = None,
        *,
        keep: bool = False,
        return_vdb: bool = False,
        path: Optional[PathLike] = None,
        timeout: Optional[float] = None,
        request: Optional[clouds_pb2.BuildVolumeRequest] = None,
    ) -> Volume:
        """Builds a volume from a model (BuildVolume).

        Args:
            cloud: the model (``model(...)``, a CloudModel or a mapping of its fields).
            keep: store it on the server: ``Volume.id`` then names it for ``render`` (dropped after
                --session-ttl idle, or by ``release``). A stored volume keeps the deep shadow map of
                its last render, which the next renders that differ only in the camera reuse.
            return_vdb: return the grids ("density", "temperature") as .vdb bytes (``Volume.vdb``).
            path: write the .vdb file there (implies return_vdb).
            timeout: seconds (None: the client's).
            request: a whole BuildVolumeRequest (or a mapping of its fields) instead of `cloud`;
                keep, return_vdb and path add to what it asks.

        Returns:
            A Volume: ``summary`` (bounds m, active voxels, bytes, ...), ``vdb`` bytes if asked,
                ``id``.
        """
        want_vdb = return_vdb or path is not None
        message = build_request(cloud, keep, want_vdb, request)
        if message.keep:
            undo = partial(release_call, self._rpc)
            response = self._connection.create(
                "Clouds.BuildVolume", self._rpc.BuildVolume, message, timeout, "cloud-", undo
            )
        else:
            response = self._connection.unary(
                "Clouds.BuildVolume", self._rpc.BuildVolume, message, timeout
            )
        return volume_of(response, message.return_vdb, path)

    def render(
        self,
        source: Optional[SourceLike] = None,
        settings: Optional[SettingsLike] = None,
        *,
        timeout: Optional[float] = None,
        request: Optional[clouds_pb2.RenderRequest] = None,
        **kwargs: Any,
    ) -> Image:
        """Ray-marches a stored volume or a model built for this call (Render).

        Args:
            source: a model (built for this call), a stored Volume (keep=True) or its volume id.
            settings: RenderSettings (or a mapping); or instead ``render_settings``' keyword
                arguments (camera=, step=, wavelengths=, extinction=, albedo=, lights=, shadow=,
                ...).

        Returns:
            An Image: ``pixels`` (height, width, channels) float32, row 0 at the top, and
            ``channels`` ("radiance_<i>" W m^-2 sr^-1 m^-1 and "transmittance_<i>" per
            wavelength, then "depth" m); ``image["depth"]`` is one channel.
        """
        message = render_request(source, settings, kwargs, request)
        response = self._connection.unary(
            "Clouds.Render", self._rpc.Render, message, timeout, session=stored_session(message)
        )
        return Image.from_proto(response.image, response.summary)

    def evolve(
        self,
        cloud: Optional[ModelLike] = None,
        times: Optional[Sequence[float]] = None,
        *,
        evolution: Optional[Union[clouds_pb2.EvolutionSpec, Mapping[str, Any]]] = None,
        settings: Optional[SettingsLike] = None,
        include_vdb: bool = False,
        timeout: Optional[float] = None,
        request: Optional[clouds_pb2.StreamEvolutionRequest] = None,
        **kwargs: Any,
    ) -> Stream[EvolutionFrame]:
        """One frame per time of a model whose parameters evolve linearly (StreamEvolution, sec.
        6.4).

        Args:
            cloud: the model at t = 0.
            times: frame times, s, 1..1000.
            evolution: EvolutionSpec or mapping: drift, noise_drift, velocity_drift (m/s, (x, y,
                z)), amplitude_rate (m/s), advection_rate (s/s).
            settings / keyword arguments: as for ``render``.
            include_vdb: each frame carries its grids as .vdb bytes.
        """
        message = evolution_request(
            cloud, times, evolution, settings, include_vdb, kwargs, request
        )
        return self._connection.stream(
            "Clouds.StreamEvolution", self._rpc.StreamEvolution, message, evolution_frame, timeout
        )

    def release(self, volume: Union[str, Volume], *, timeout: Optional[float] = None) -> None:
        """Drops a stored volume (ReleaseVolume).

        Idempotent, the rule of ``EWaveSession.close``: a volume no longer stored (NOT_FOUND)
        counts as released. It returns once the volume is gone, however it went: a first attempt
        may have released it and had its answer lost (the connection broke after squalld acted),
        the client's retry policy sending it again to find it gone; or it was released elsewhere,
        or evicted after --session-ttl idle. An id that was never stored (a typo) is not told apart
        from these; ``render`` of it raises NOT_FOUND. Any other error raises SquallError, the
        volume perhaps still stored.
        """
        message = clouds_pb2.ReleaseVolumeRequest(volume_id=volume_id_of(volume))
        try:
            self._connection.unary(
                "Clouds.ReleaseVolume",
                self._rpc.ReleaseVolume,
                message,
                timeout,
                session=message.volume_id,
            )
        except SquallError as error:
            if error.code != grpc.StatusCode.NOT_FOUND:
                raise
