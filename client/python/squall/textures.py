"""Advected textures (squall.v1.Textures): a tileable texture carried by a velocity field, as
frames.

Methods: "lagrangian" (Lagrangian grids, Yu et al. 2011), "eulerian" (multi-layer, Neyret 2003),
"two_phase_flow_map", "naive". Domain units (du) for lengths, s for times; texture coordinates in
texture periods. Output planes are arrays of shape (height, width): ``frame["final"][j, i]`` is
pixel (i, j) at (x0 + (i + 0.5) px, y0 + (j + 0.5) py).

Example::

    frames = client.textures.advect(
        method="lagrangian", velocity=squall.textures.analytic("rotation", angular_velocity=0.5),
        texture=squall.textures.noise(bands=4), size=(128, 128), frames=30, dt=1 / 30)
    for frame in frames:
        frame["final"]    # (128, 128) float32, dimensionless
"""

from __future__ import annotations

from typing import Any, List, Mapping, Optional, Sequence, Union

import grpc
import numpy as np

from squall._calls import Connection, RequestQueue, Stream
from squall._convert import (
    ArrayLike,
    array_to_field,
    dtype_value,
    enum_value,
    message_from,
    to_message,
)
from squall._errors import SquallError
from squall._pb import ocean_pb2, textures_pb2, textures_pb2_grpc
from squall._results import TextureFrame

# VelocitySpec, AnalyticVelocity, VelocityGrid, TileSpec, an eWave session (id or EWaveSession),
# or a mapping of VelocitySpec's fields
VelocityLike = Any
TextureLike = Any  # TextureSource, a mapping of its fields, an image array, PNG bytes

__all__ = [
    "analytic",
    "velocity_grid",
    "noise",
    "image",
    "output",
    "advect_request",
    "Textures",
    "Interactive",
    "TextureFrame",
]


def analytic(kind: Union[str, int] = "uniform", **params: Any) -> textures_pb2.VelocitySpec:
    """An analytic, steady velocity field (du/s).

    Args:
        kind: "uniform", "rotation", "shear", "sink", "rankine_vortex", "taylor_green",
            "poiseuille_channel", "cylinder".
        params: AnalyticVelocity's fields: velocity_x, velocity_y (du/s; uniform), angular_velocity
            (rad/s; rotation), center ((x, y) du; default (0.5, 0.5)), shear_rate (1/s), y0 (du),
            speed (du/s), epsilon (du), circulation (du^2/s), core_radius (du), period (du),
            half_width (du), radius (du). Unset optionals take the proto's defaults.
    """
    fields = dict(params)
    fields["kind"] = kind
    return textures_pb2.VelocitySpec(
        named=to_message(textures_pb2.AnalyticVelocity, fields, "velocity.named")
    )


def velocity_grid(
    u: ArrayLike,
    v: ArrayLike,
    *,
    times: Optional[Sequence[float]] = None,
    origin: Sequence[float] = (0.0, 0.0),
    spacing: Optional[Sequence[float]] = None,
    extrapolation: Union[str, int, None] = None,
    mask: Optional[ArrayLike] = None,
) -> textures_pb2.VelocitySpec:
    """A velocity field sampled on nodes: bilinear in space, linear in time between frames.

    Args:
        u, v: velocity components, du/s: arrays of shape (ny, nx) (one frame), or (frames, ny, nx)
            with `times`. nx, ny >= 2.
        times: frame times, s, increasing (default: 0 for a single frame, else 0, 1, 2, ...).
        origin: position of node (0, 0), du.
        spacing: node spacing (sx, sy), du, > 0; default: the nodes span [0, 1]^2
            (1 / (nx - 1), 1 / (ny - 1)).
        extrapolation: "clamp" (default), "zero", "push_pull" (solid nodes filled from the fluid).
        mask: (ny, nx): nonzero fluid, 0 solid; unset: all fluid.
    """
    uu, vv = np.asarray(u), np.asarray(v)
    if uu.shape != vv.shape or uu.ndim not in (2, 3):
        raise ValueError(
            "velocity_grid: u and v want the same shape (ny, nx) or (frames, ny, nx), "
            f"got {uu.shape} and {vv.shape}"
        )
    if uu.ndim == 2:
        uu, vv = uu[None], vv[None]
    count, ny, nx = uu.shape
    if times is None:
        times = [float(i) for i in range(count)]
    if len(times) != count:
        raise ValueError(f"velocity_grid: {len(times)} times for {count} frames")
    if spacing is None:
        spacing = (1.0 / max(nx - 1, 1), 1.0 / max(ny - 1, 1))
    frames = [
        textures_pb2.VelocityGridFrame(
            time=float(t),
            u=array_to_field(uu[i], path=f"grid.frames[{i}].u"),
            v=array_to_field(vv[i], path=f"grid.frames[{i}].v"),
        )
        for i, t in enumerate(times)
    ]
    grid = message_from(
        textures_pb2.VelocityGrid,
        None,
        "velocity.grid",
        nx=nx,
        ny=ny,
        origin=origin,
        spacing=spacing,
        frames=frames,
        extrapolation=extrapolation,
        mask=None if mask is None else array_to_field(mask, path="velocity.grid.mask"),
    )
    return textures_pb2.VelocitySpec(grid=grid)


def as_velocity(
    value: VelocityLike, path: str = "velocity"
) -> Optional[textures_pb2.VelocitySpec]:
    """A VelocitySpec from a VelocitySpec, an AnalyticVelocity or VelocityGrid, an ocean TileSpec,
    an eWave session id (str) or EWaveSession (the session's surface current), or a mapping of
    VelocitySpec's fields; None stays None (the proto default: zero velocity)."""
    if value is None:
        return None
    if isinstance(value, textures_pb2.VelocitySpec):
        return value
    if isinstance(value, textures_pb2.AnalyticVelocity):
        return textures_pb2.VelocitySpec(named=value)
    if isinstance(value, textures_pb2.VelocityGrid):
        return textures_pb2.VelocitySpec(grid=value)
    if isinstance(value, ocean_pb2.TileSpec):
        return textures_pb2.VelocitySpec(ocean=value)
    if isinstance(value, str):
        return textures_pb2.VelocitySpec(ewave_session=value)
    session_id = getattr(value, "id", None)
    if isinstance(session_id, str) and hasattr(value, "config"):
        return textures_pb2.VelocitySpec(ewave_session=session_id)
    return to_message(textures_pb2.VelocitySpec, value, path)


def _finish_source(
    source: textures_pb2.TextureSource,
    scale: Optional[float],
    final: Union[str, int, None],
    final_scale: Optional[float],
    lut: Any,
) -> textures_pb2.TextureSource:
    if scale is not None:
        source.scale = float(scale)
    if final is not None:
        source.final_function = enum_value(
            textures_pb2.FinalFunction.DESCRIPTOR, final, "texture.final_function"
        )
    if final_scale is not None:
        source.final_scale = float(final_scale)
    if lut is not None:
        source.lut.CopyFrom(to_message(textures_pb2.FinalLookup, lut, "texture.lut"))
    return source


def noise(
    bands: Optional[int] = None,
    base_cells: Optional[int] = None,
    *,
    spin: Optional[float] = None,
    seed: Optional[int] = None,
    time_varying: bool = False,
    scale: Optional[float] = None,
    final: Union[str, int, None] = None,
    final_scale: Optional[float] = None,
    lut: Any = None,
) -> textures_pb2.TextureSource:
    """A procedural gradient-noise texture, one channel per band.

    Args:
        bands: 1..8; unset: 4.
        base_cells: lattice cells per period in band 0, 1..64; unset: 4.
        spin: rad/s of band 0 (flow noise, with time_varying); unset: 1.
        seed: gradient table seed; unset: 1.
        time_varying: flow noise (gradients turn in time); False: a still texture.
        scale: texture periods per du, (0, 1e6]; unset: 4.
        final: the final function: "identity" (default), "sum_bands", "turbulence", "ridged",
            "lut".
        final_scale: dimensionless; unset: 1.
        lut: FinalLookup (or mapping) for final="lut".
    """
    texture = message_from(
        textures_pb2.NoiseTexture,
        None,
        "texture.noise",
        bands=bands,
        base_cells=base_cells,
        spin=spin,
        seed=seed,
        time_varying=time_varying,
    )
    return _finish_source(
        textures_pb2.TextureSource(noise=texture), scale, final, final_scale, lut
    )


def image(
    pixels: Union[ArrayLike, bytes],
    *,
    tileable: bool = True,
    scale: Optional[float] = None,
    final: Union[str, int, None] = None,
    final_scale: Optional[float] = None,
    lut: Any = None,
) -> textures_pb2.TextureSource:
    """A reference texture given as pixels: one period of a tileable texture, row 0 at y = 0.

    Args:
        pixels: an array of shape (height, width) or (height, width, channels) with 1..8 channels:
            float values (dimensionless) are sent as one float32 (float16 stays float16) Field per
            channel; uint8 values as 8-bit pixels (value / 255). Or the bytes of a PNG file.
        tileable: whether the edges match (the image is sampled with wrap either way).
        scale, final, final_scale, lut: as for ``noise``.
    """
    if isinstance(pixels, (bytes, bytearray)):
        texture = textures_pb2.ImageTexture(png=bytes(pixels), tileable=tileable)
    else:
        array = np.asarray(pixels)
        if array.ndim == 2:
            array = array[:, :, None]
        if array.ndim != 3:
            raise ValueError(
                "texture image: want (height, width) or (height, width, channels), "
                f"got {array.shape}"
            )
        height, width, channels = array.shape
        if array.dtype == np.uint8:
            texture = textures_pb2.ImageTexture(
                pixels8=textures_pb2.Pixels8(
                    width=width,
                    height=height,
                    channels=channels,
                    data=np.ascontiguousarray(array).tobytes(),
                ),
                tileable=tileable,
            )
        else:
            texture = textures_pb2.ImageTexture(
                channels=[
                    array_to_field(array[:, :, c], path=f"texture.image.channels[{c}]")
                    for c in range(channels)
                ],
                tileable=tileable,
            )
    return _finish_source(
        textures_pb2.TextureSource(image=texture), scale, final, final_scale, lut
    )


def as_texture(value: TextureLike, path: str = "texture") -> Optional[textures_pb2.TextureSource]:
    """A TextureSource from a TextureSource, a mapping of its fields, an image array or PNG bytes;
    None stays None (the proto default: noise with its defaults)."""
    if value is None or isinstance(value, textures_pb2.TextureSource):
        return value
    if isinstance(value, (bytes, bytearray, np.ndarray)):
        return image(value)
    return to_message(textures_pb2.TextureSource, value, path)


def output(
    width: int,
    height: int,
    *,
    region: Optional[Sequence[float]] = None,
    planes: Union[str, Sequence[Union[str, int]]] = ("final",),
    dtype: Any = "float32",
) -> textures_pb2.TextureOutput:
    """The output pixels of each frame.

    Args:
        width, height: pixels, >= 1.
        region: (x0, y0, x1, y1), du; unset: the unit square.
        planes: "final", "raw", "weight_sum", "weight_sq_sum", "coverage", "layer", ...; sent in
            the proto's order whatever the order asked.
        dtype: "float32" or "float16".
    """
    if isinstance(planes, (str, int)):
        planes = [planes]
    region_message = None
    if region is not None:
        x0, y0, x1, y1 = (float(v) for v in region)
        region_message = textures_pb2.TextureRegion(x0=x0, y0=y0, x1=x1, y1=y1)
    return message_from(
        textures_pb2.TextureOutput,
        None,
        "output",
        width=width,
        height=height,
        region=region_message,
        planes=[
            enum_value(textures_pb2.TexturePlane.DESCRIPTOR, p, f"output.planes[{i}]")
            for i, p in enumerate(planes)
        ],
        dtype=dtype_value(dtype, "output.dtype"),
    )


def advect_request(
    *,
    method: Union[str, int] = "lagrangian",
    velocity: VelocityLike = None,
    texture: TextureLike = None,
    size: Sequence[int] = (256, 256),
    region: Optional[Sequence[float]] = None,
    planes: Union[str, Sequence[Union[str, int]]] = ("final",),
    dtype: Any = "float32",
    output_spec: Optional[Union[textures_pb2.TextureOutput, Mapping[str, Any]]] = None,
    frames: int = 0,
    t0: float = 0.0,
    dt: Optional[float] = None,
    substeps: Optional[int] = None,
    seed: Optional[int] = None,
    lagrangian: Optional[Union[textures_pb2.LagrangianParams, Mapping[str, Any]]] = None,
    eulerian: Optional[Union[textures_pb2.EulerianParams, Mapping[str, Any]]] = None,
    checkpoint_every: int = 0,
    resume_state: bytes = b"",
    request: Optional[textures_pb2.AdvectTextureRequest] = None,
) -> textures_pb2.AdvectTextureRequest:
    """The AdvectTextureRequest of ``Textures.advect``'s arguments (or `request` when given)."""
    if request is not None:
        return to_message(textures_pb2.AdvectTextureRequest, request)
    if output_spec is None:
        width, height = (int(v) for v in size)
        out = output(width, height, region=region, planes=planes, dtype=dtype)
    else:
        out = to_message(textures_pb2.TextureOutput, output_spec, "request.output")
    return message_from(
        textures_pb2.AdvectTextureRequest,
        None,
        "request",
        method=enum_value(textures_pb2.TextureMethod.DESCRIPTOR, method, "request.method"),
        velocity=as_velocity(velocity, "request.velocity"),
        texture=as_texture(texture, "request.texture"),
        output=out,
        t0=t0,
        dt=dt,
        frames=frames,
        substeps=substeps,
        seed=seed,
        lagrangian=lagrangian,
        eulerian=eulerian,
        checkpoint_every=checkpoint_every,
        resume_state=resume_state,
    )


def control_message(
    start: Optional[textures_pb2.AdvectTextureRequest],
    frames: int,
    velocity: VelocityLike,
    dt: Optional[float],
    substeps: Optional[int],
    spin: Optional[float],
    final_scale: Optional[float],
) -> textures_pb2.TextureControl:
    return message_from(
        textures_pb2.TextureControl,
        None,
        "control",
        start=start,
        frames=int(frames),
        velocity=as_velocity(velocity, "control.velocity"),
        dt=dt,
        substeps=substeps,
        spin=spin,
        final_scale=final_scale,
    )


class Interactive:
    """A running AdvectInteractive stream (sync): ``send`` steers it and returns the frames it asks
    for.

    Use it in a ``with`` block (or call ``close()``): the stream then ends and frees its
    --max-streams slot. A message that fails validation raises SquallError naming
    "control[n].<field>".
    """

    METHOD = "Textures.AdvectInteractive"

    def __init__(
        self,
        connection: Connection,
        service: Any,
        start: textures_pb2.AdvectTextureRequest,
        timeout: Optional[float],
    ) -> None:
        self._requests = RequestQueue()
        self._start: Optional[textures_pb2.AdvectTextureRequest] = start
        try:
            self._call = service.AdvectInteractive(
                self._requests,
                timeout=connection.settings.deadline(timeout, stream=True),
                metadata=connection.settings.metadata(),
            )
        except grpc.RpcError as error:
            raise SquallError.from_rpc(error, self.METHOD) from None
        self.frames_received = 0
        self._ended = False  # the call has ended (its error, if any, was raised)

    def _next(self) -> textures_pb2.TextureFrame:
        try:
            return next(self._call)
        except StopIteration:
            self._ended = True
            raise SquallError(
                grpc.StatusCode.INTERNAL,
                "client: the stream ended before the frames asked for",
                self.METHOD,
            ) from None
        except grpc.RpcError as error:
            self._ended = True
            raise SquallError.from_rpc(error, self.METHOD) from None

    def send(
        self,
        frames: int = 1,
        *,
        velocity: VelocityLike = None,
        dt: Optional[float] = None,
        substeps: Optional[int] = None,
        spin: Optional[float] = None,
        final_scale: Optional[float] = None,
    ) -> List[TextureFrame]:
        """Applies the changes given (from the next step on) and returns `frames` more frames.

        Args:
            frames: frames to produce after applying this message, 0..1024.
            velocity: a new velocity field (as ``advect``'s), e.g. a new ``velocity_grid`` frame
                set.
            dt: s between frames from now on, (0, 1e4].
            substeps: integration steps per frame from now on, 1..64.
            spin: rad/s, flow-noise rotation of band 0 (noise textures).
            final_scale: the final function's scale (dimensionless).
        """
        if self._ended:
            raise SquallError(
                grpc.StatusCode.FAILED_PRECONDITION, "client: the stream has ended", self.METHOD
            )
        message = control_message(self._start, frames, velocity, dt, substeps, spin, final_scale)
        self._start = None
        self._requests.put(message)
        out = [TextureFrame(self._next()) for _ in range(int(frames))]
        self.frames_received += len(out)
        return out

    def close(self) -> None:
        """Ends the request side and waits for the server to finish the call (raises its error,
        unless
        ``send`` raised it already)."""
        self._requests.close()
        if self._ended:
            return
        self._ended = True
        try:
            for _ in self._call:
                pass
        except grpc.RpcError as error:
            if error.code() != grpc.StatusCode.CANCELLED:  # type: ignore[attr-defined]
                raise SquallError.from_rpc(error, self.METHOD) from None

    def cancel(self) -> None:
        """Ends the call now."""
        self._requests.close()
        self._call.cancel()

    def __enter__(self) -> "Interactive":
        return self

    def __exit__(self, exc_type: Any, *exc: Any) -> None:
        if exc_type is None:
            self.close()
        else:
            self.cancel()


class Textures:
    """``client.textures``: the Textures service (AdvectTexture, AdvectInteractive)."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = textures_pb2_grpc.TexturesStub(connection.channel)

    def advect(
        self,
        *,
        method: Union[str, int] = "lagrangian",
        velocity: VelocityLike = None,
        texture: TextureLike = None,
        size: Sequence[int] = (256, 256),
        region: Optional[Sequence[float]] = None,
        planes: Union[str, Sequence[Union[str, int]]] = ("final",),
        dtype: Any = "float32",
        output_spec: Optional[Union[textures_pb2.TextureOutput, Mapping[str, Any]]] = None,
        frames: Optional[int] = None,
        t0: float = 0.0,
        dt: Optional[float] = None,
        substeps: Optional[int] = None,
        seed: Optional[int] = None,
        lagrangian: Optional[Union[textures_pb2.LagrangianParams, Mapping[str, Any]]] = None,
        eulerian: Optional[Union[textures_pb2.EulerianParams, Mapping[str, Any]]] = None,
        checkpoint_every: int = 0,
        resume_state: bytes = b"",
        timeout: Optional[float] = None,
        request: Optional[textures_pb2.AdvectTextureRequest] = None,
    ) -> Stream[TextureFrame]:
        """Advects a texture and streams its frames (AdvectTexture).

        Args:
            method: "lagrangian" (default), "eulerian" (multi-layer), "two_phase_flow_map",
                "naive".
            velocity: ``analytic(...)``, ``velocity_grid(u, v, ...)``, an eWave session (its id
                or the EWaveSession: its surface current), an ocean TileSpec (its surface
                current), or a VelocitySpec; None: zero velocity.
            texture: ``noise(...)``, ``image(array)``, an image array, PNG bytes, or a
                TextureSource; None: noise with its defaults.
            size: (width, height) of each frame, pixels.
            region: (x0, y0, x1, y1) sampled, du; None: the unit square.
            planes: "final" (default), "raw", "weight_sum", "weight_sq_sum", "coverage",
                "layer", ...: sent in the proto's order whatever the order asked.
            dtype: "float32" or "float16" of the returned planes.
            output_spec: a TextureOutput instead of size, region, planes and dtype.
            frames: total frames of the stream, counted from frame 0, 1..100000. Required.
            t0: time of frame 0, s.
            dt: s between frames, (0, 1e4]; unset: 1/30.
            substeps: integration steps per frame, 1..64; unset: 1.
            seed: Lagrangian particle placement and patch origins; unset: 1.
            lagrangian: LagrangianParams (or a mapping: d, alpha, beta, grid_res, ...).
            eulerian: EulerianParams (or a mapping: latencies, phases, grid_nx, ...).
            checkpoint_every: k >= 1: every k-th frame carries ``checkpoint`` bytes; 0: none.
            resume_state: the checkpoint of frame k of this same request: the stream continues
                bit-identically with frames k + 1 ...
            request: a ready-made AdvectTextureRequest instead of all the above.

        Returns:
            An iterator of TextureFrames (planes keyed by name, with index, time, stats); it holds
            one --max-streams slot until it ends or is cancelled.
        """
        if request is None and frames is None:
            raise TypeError("advect: frames (1..100000) is required")
        message = advect_request(
            method=method,
            velocity=velocity,
            texture=texture,
            size=size,
            region=region,
            planes=planes,
            dtype=dtype,
            output_spec=output_spec,
            frames=frames or 0,
            t0=t0,
            dt=dt,
            substeps=substeps,
            seed=seed,
            lagrangian=lagrangian,
            eulerian=eulerian,
            checkpoint_every=checkpoint_every,
            resume_state=resume_state,
            request=request,
        )
        return self._connection.stream(
            "Textures.AdvectTexture", self._rpc.AdvectTexture, message, TextureFrame, timeout
        )

    def interactive(
        self,
        start: Optional[Union[textures_pb2.AdvectTextureRequest, Mapping[str, Any]]] = None,
        *,
        timeout: Optional[float] = None,
        **kwargs: Any,
    ) -> Interactive:
        """Starts an AdvectInteractive stream: the advection (an AdvectTextureRequest, or the
        keyword arguments of ``advect`` but frames and checkpoints), steered by
        ``Interactive.send``.

        Example::

            drift = squall.textures.analytic("uniform", velocity_x=0.1)
            with client.textures.interactive(velocity=drift, size=(64, 64)) as run:
                first = run.send(frames=2)  # frames 0 and 1
                turn = squall.textures.analytic("rotation", angular_velocity=1.0)
                later = run.send(velocity=turn)  # frame 2, turning
        """
        if start is not None:
            if kwargs:
                raise TypeError(
                    "interactive: pass either start or advect's keyword arguments, not both"
                )
            request = to_message(textures_pb2.AdvectTextureRequest, start, "start")
        else:
            request = advect_request(**kwargs)
        return Interactive(self._connection, self._rpc, request, timeout)
