"""Advected textures (squall.v1.Textures): a tileable texture carried by a velocity field, as
frames.

Methods: "lagrangian" (Lagrangian grids, Yu et al. 2011), "eulerian" (multi-layer, Neyret 2003),
"two_phase_flow_map", "naive". Domain units (du) for lengths, s for times; texture coordinates in
texture periods. Output planes are arrays of shape (height, width): ``frame["final_0"][j, i]`` is
pixel (i, j) at (x0 + (i + 0.5) px, y0 + (j + 0.5) py).

Example::

    frames = client.textures.advect(
        method="lagrangian", velocity=squall.textures.analytic("rotation", angular_velocity=0.5),
        texture=squall.textures.noise(bands=4), size=(128, 128), frames=30, dt=1 / 30)
    for frame in frames:
        frame["final_0"]  # (128, 128) float32, dimensionless: the first of the 4 bands' planes

Rivers (Yu et al. 2009): ``river(channels=[{"left": [...], "right": [...], "flow_rate": q}],
...)`` is a velocity for ``advect``; ``client.textures.bake_velocity(river, size, region)`` returns
its u, v, fluid (and psi) on a grid. Content-aware deformation (Guingo et al. 2020):
``client.textures.deform(image, rigidity, control=..., frames=...)`` streams DeformFrames
(planes "color_<c>", "warp_x", ...), ``deform_interactive`` steers it.
"""

from __future__ import annotations

from typing import Any, Callable, Generic, List, Mapping, Optional, Sequence, Tuple, TypeVar, Union

import grpc
import numpy as np

from squall._calls import Connection, RequestQueue, Stream
from squall._convert import (
    UINT32_MAX,
    ArrayLike,
    FieldLike,
    array_to_field,
    dtype_value,
    enum_value,
    flag,
    float_array,
    floats,
    integer,
    integers,
    items_of,
    message_from,
    number,
    sequence,
    to_field,
    to_message,
)
from squall._errors import SquallError
from squall._pb import common_pb2, ocean_pb2, rpc_client, textures_pb2, textures_pb2_grpc
from squall._results import BakedVelocity, DeformFrame, TextureFrame

# VelocitySpec, AnalyticVelocity, VelocityGrid, RiverVelocity, TileSpec, an eWave session (id or
# EWaveSession), or a mapping of VelocitySpec's fields
VelocityLike = Any
TextureLike = Any  # TextureSource, a mapping of its fields, an image array, PNG bytes

__all__ = [
    "analytic",
    "velocity_grid",
    "noise",
    "image",
    "output",
    "advect_request",
    "river",
    "river_message",
    "polyline",
    "texture_region",
    "bake_request",
    "tensor2",
    "brush_stroke",
    "deform_request",
    "Textures",
    "Steering",
    "Interactive",
    "DeformInteractive",
    "TextureFrame",
    "BakedVelocity",
    "DeformFrame",
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
    times = floats(times, "velocity_grid.times", "a sequence of frame times, s")
    if len(times) != count:
        raise ValueError(f"velocity_grid: {len(times)} times for {count} frames")
    if spacing is None:
        spacing = (1.0 / max(nx - 1, 1), 1.0 / max(ny - 1, 1))
    frames = [
        textures_pb2.VelocityGridFrame(
            time=t,
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
    """A VelocitySpec from a VelocitySpec, an AnalyticVelocity, VelocityGrid or RiverVelocity, an
    ocean TileSpec, an eWave session id (str) or EWaveSession (the session's surface current), or
    a mapping of VelocitySpec's fields; None stays None (the proto default: zero velocity)."""
    if value is None:
        return None
    if isinstance(value, textures_pb2.VelocitySpec):
        return value
    if isinstance(value, textures_pb2.AnalyticVelocity):
        return textures_pb2.VelocitySpec(named=value)
    if isinstance(value, textures_pb2.VelocityGrid):
        return textures_pb2.VelocitySpec(grid=value)
    if isinstance(value, textures_pb2.RiverVelocity):
        return textures_pb2.VelocitySpec(river=value)
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
        source.scale = number(scale, "texture.scale")
    if final is not None:
        source.final_function = enum_value(
            textures_pb2.FinalFunction.DESCRIPTOR, final, "texture.final_function"
        )
    if final_scale is not None:
        source.final_scale = number(final_scale, "texture.final_scale")
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


def image_texture(
    pixels: Union[ArrayLike, bytes], *, tileable: bool = True, path: str = "texture.image"
) -> textures_pb2.ImageTexture:
    """The ImageTexture of ``image``'s `pixels` (an (H, W) or (H, W, C) array, or PNG bytes)."""
    tileable = flag(tileable, f"{path}.tileable")
    if isinstance(pixels, (bytes, bytearray)):
        texture = textures_pb2.ImageTexture(png=bytes(pixels), tileable=tileable)
    else:
        array = np.asarray(pixels)
        if array.ndim == 2:
            array = array[:, :, None]
        if array.ndim != 3:
            raise ValueError(
                f"{path}: want (height, width) or (height, width, channels), " f"got {array.shape}"
            )
        height, width, channels = array.shape
        if array.dtype.kind in "iu" and array.dtype not in (np.uint8, np.uint16):
            raise TypeError(
                f"{path}: integer pixels of {array.dtype}: want uint8 (value / 255), uint16 "
                "(value / 65535) or floats"
            )
        if array.dtype == np.uint16:
            array = array.astype(np.float32) / np.float32(65535)
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
                    array_to_field(array[:, :, c], path=f"{path}.channels[{c}]")
                    for c in range(channels)
                ],
                tileable=tileable,
            )
    return texture


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
            channel; uint8 values as 8-bit pixels (value / 255), uint16 values as float32 Fields
            (value / 65535); other integer types raise TypeError. Or the bytes of a PNG file.
        tileable: whether the edges match (the image is sampled with wrap either way).
        scale, final, final_scale, lut: as for ``noise``.
    """
    texture = image_texture(pixels, tileable=tileable)
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
    if isinstance(planes, (str, int, np.integer)):
        planes = [planes]
    plane_items = sequence(planes, "output.planes", "a plane name or a sequence of them")
    region_message = None if region is None else texture_region(region, "output.region")
    return message_from(
        textures_pb2.TextureOutput,
        None,
        "output",
        width=integer(width, "output.width", 0, UINT32_MAX),
        height=integer(height, "output.height", 0, UINT32_MAX),
        region=region_message,
        planes=[
            enum_value(textures_pb2.TexturePlane.DESCRIPTOR, p, f"output.planes[{i}]")
            for i, p in enumerate(plane_items)
        ],
        dtype=dtype_value(dtype, "output.dtype"),
    )


def followed_session(request: textures_pb2.AdvectTextureRequest) -> Optional[str]:
    """The eWave session whose surface current the advection follows, if any: sent as
    x-squall-session, so that a session-affine proxy routes the stream to the replica holding it.
    """
    return request.velocity.ewave_session or None


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
        want = "(width, height) in pixels"
        width, height = integers(size, "size", want, (2,), 0, UINT32_MAX)
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
        frames=integer(frames, "request.frames", 0, UINT32_MAX),
        substeps=substeps,
        seed=seed,
        lagrangian=lagrangian,
        eulerian=eulerian,
        checkpoint_every=integer(checkpoint_every, "request.checkpoint_every", 0, UINT32_MAX),
        resume_state=resume_state,
    )


# -------------------------------------------------------------------------------------------------
# Procedural rivers (Yu et al. 2009, "Scalable Real-Time Animation of Rivers", RiverVelocity)

# A polyline: a sequence of (x, y) points in du, an array of shape (n, 2), or a Polyline.
PointsLike = Union[ArrayLike, textures_pb2.Polyline]
# RiverVelocity, a VelocitySpec with its river set, or a mapping of ``river_message``'s arguments
RiverLike = Any
RegionLike = Union[textures_pb2.TextureRegion, Sequence[float], Mapping[str, float]]

_CHANNEL_KEYS = {
    "left": "left_bank",
    "left_bank": "left_bank",
    "right": "right_bank",
    "right_bank": "right_bank",
    "flow_rate": "flow_rate",
    "cross_section": "cross_section",
}


def polyline(points: PointsLike, path: str = "polyline") -> textures_pb2.Polyline:
    """A Polyline from (x, y) points (du): a sequence of pairs, an (n, 2) array, or a Polyline.
    The points are sent as given (the server checks them: 2..4096 finite points, consecutive
    points distinct)."""
    if isinstance(points, textures_pb2.Polyline):
        return points
    if isinstance(points, Mapping):
        return to_message(textures_pb2.Polyline, points, path)
    array = float_array(points, path, "(x, y) points, a sequence of pairs or an array (n, 2)")
    if array.size == 0:
        return textures_pb2.Polyline()
    if array.ndim != 2 or array.shape[1] != 2:
        raise ValueError(
            f"{path}: want (x, y) points, a sequence of pairs or an array of shape (n, 2), "
            f"got shape {array.shape}"
        )
    return textures_pb2.Polyline(points=[textures_pb2.Vec2(x=x, y=y) for x, y in array.tolist()])


def texture_region(value: RegionLike, path: str = "region") -> textures_pb2.TextureRegion:
    """A TextureRegion from (x0, y0, x1, y1) in du, a mapping of its fields, or the message."""
    if isinstance(value, (textures_pb2.TextureRegion, Mapping)):
        return to_message(textures_pb2.TextureRegion, value, path)
    x0, y0, x1, y1 = floats(value, path, "(x0, y0, x1, y1), du", (4,))
    return textures_pb2.TextureRegion(x0=x0, y0=y0, x1=x1, y1=y1)


def river_channel(value: Any, path: str = "river.channels[0]") -> textures_pb2.RiverChannel:
    """A RiverChannel from a mapping {"left": points, "right": points, "flow_rate": Q or None,
    "cross_section": w or None} ("left_bank" / "right_bank" also accepted) or the message."""
    if isinstance(value, textures_pb2.RiverChannel):
        return value
    if not isinstance(value, Mapping):
        raise TypeError(
            f"{path}: want a RiverChannel or a mapping with left, right (bank points), "
            f"flow_rate, cross_section; got {value!r}"
        )
    channel = textures_pb2.RiverChannel()
    for key, item in value.items():
        name = _CHANNEL_KEYS.get(key)
        if name is None:
            raise TypeError(
                f"{path}: unknown key {key!r} (want left, right, flow_rate, cross_section)"
            )
        if item is None:
            continue
        if name in ("left_bank", "right_bank"):
            getattr(channel, name).CopyFrom(polyline(item, f"{path}.{name}"))
        else:
            setattr(channel, name, number(item, f"{path}.{name}"))
    return channel


def river_junction(value: Any, path: str = "river.junctions[0]") -> textures_pb2.RiverJunction:
    """A RiverJunction from {"upstream": [channel indices], "downstream": [...]}, a pair
    (upstream, downstream), or the message. Indices left to right looking downstream."""
    if isinstance(value, (textures_pb2.RiverJunction, Mapping)):
        return to_message(textures_pb2.RiverJunction, value, path)
    want = "{'upstream': [...], 'downstream': [...]} or an (upstream, downstream) pair"
    upstream, downstream = items_of(value, path, (2,), want)
    return to_message(
        textures_pb2.RiverJunction, {"upstream": upstream, "downstream": downstream}, path
    )


def river_obstacle(value: Any, path: str = "river.obstacles[0]") -> textures_pb2.RiverObstacle:
    """A RiverObstacle from its outline (closed polygon points, du), a mapping {"outline": points,
    "search_radius": r or None}, or the message."""
    if isinstance(value, textures_pb2.RiverObstacle):
        return value
    if isinstance(value, Mapping):
        unknown = set(value) - {"outline", "search_radius"}
        if unknown:
            raise TypeError(
                f"{path}: unknown key {sorted(unknown)[0]!r} (want outline, search_radius)"
            )
        obstacle = textures_pb2.RiverObstacle()
        if value.get("outline") is not None:
            obstacle.outline.CopyFrom(polyline(value["outline"], f"{path}.outline"))
        if value.get("search_radius") is not None:
            obstacle.search_radius = number(value["search_radius"], f"{path}.search_radius")
        return obstacle
    return textures_pb2.RiverObstacle(outline=polyline(value, f"{path}.outline"))


def _each(items: Sequence[Any], name: str) -> List[Tuple[int, Any]]:
    """(index, item) of a river's channels, junctions or obstacles (TypeError naming
    "river.<name>" for no sequence)."""
    return list(enumerate(sequence(items, f"river.{name}", f"a sequence of {name}")))


def river_message(
    channels: Sequence[Any] = (),
    junctions: Sequence[Any] = (),
    obstacles: Sequence[Any] = (),
    *,
    p: Optional[float] = None,
    search_radius: Optional[float] = None,
    bake: Optional[Sequence[int]] = None,
    bake_region: Optional[RegionLike] = None,
) -> textures_pb2.RiverVelocity:
    """The RiverVelocity of ``river``'s arguments (see there)."""
    message = textures_pb2.RiverVelocity(
        channels=[
            river_channel(c, f"river.channels[{i}]") for i, c in _each(channels, "channels")
        ],
        junctions=[
            river_junction(j, f"river.junctions[{i}]") for i, j in _each(junctions, "junctions")
        ],
        obstacles=[
            river_obstacle(o, f"river.obstacles[{i}]") for i, o in _each(obstacles, "obstacles")
        ],
    )
    if p is not None:
        message.p = number(p, "river.p")
    if search_radius is not None:
        message.search_radius = number(search_radius, "river.search_radius")
    if bake is not None:
        nx, ny = _pair(bake, "river.bake")
        message.bake_nx, message.bake_ny = nx, ny
    if bake_region is not None:
        message.bake_region.CopyFrom(texture_region(bake_region, "river.bake_region"))
    return message


def river(
    channels: Sequence[Any] = (),
    junctions: Sequence[Any] = (),
    obstacles: Sequence[Any] = (),
    *,
    p: Optional[float] = None,
    search_radius: Optional[float] = None,
    bake: Optional[Sequence[int]] = None,
    bake_region: Optional[RegionLike] = None,
) -> textures_pb2.VelocitySpec:
    """A procedural river (Yu et al. 2009): a steady, divergence-free 2D flow v = curl psi along a
    network of channels, as a velocity for ``advect`` (baked on a grid first) or for
    ``Textures.bake_velocity``.

    Args:
        channels: 1..256 channels, each a mapping {"left": [(x, y), ...], "right": [(x, y), ...],
            "flow_rate": Q, "cross_section": w} (or a RiverChannel): the left and right banks
            looking downstream, both drawn from upstream to downstream (du); Q in du^2/s, > 0
            (None: from the junctions); w in du, > 0 (None: the distance between the banks'
            first points).
        junctions: 0..256 junctions, each {"upstream": [channel indices], "downstream": [...]}
            (or an (upstream, downstream) pair, or a RiverJunction), indices left to right
            looking downstream.
        obstacles: 0..256 islands, each its closed outline [(x, y), ...] (du, 3..4096 points), or
            {"outline": [...], "search_radius": r} (r in du; None: the river's), or a
            RiverObstacle.
        p: the boundary exponent, (0, 8]; None: 1. p > 1: no-slip walls, p <= 1: slip.
        search_radius: s, du, > 0; None: twice the largest cross-section. It must reach both
            banks of a channel everywhere.
        bake: (nx, ny) nodes of the grid the river is baked on when it drives an advection,
            2..4096 each; None: 128 x 128.
        bake_region: (x0, y0, x1, y1) of that grid, du; None: the advection's output region.

    Returns:
        A VelocitySpec with its river set (``.river`` is the RiverVelocity).
    """
    return textures_pb2.VelocitySpec(
        river=river_message(
            channels,
            junctions,
            obstacles,
            p=p,
            search_radius=search_radius,
            bake=bake,
            bake_region=bake_region,
        )
    )


def _pair(value: Sequence[int], path: str) -> Tuple[int, int]:
    nx, ny = integers(value, path, "(nx, ny) nodes", (2,), 0, UINT32_MAX)
    return nx, ny


def as_river(value: RiverLike, path: str = "river") -> textures_pb2.RiverVelocity:
    """A RiverVelocity from a RiverVelocity, a VelocitySpec with its river set (``river(...)``), or a
    mapping of ``river_message``'s arguments (bake_nx, bake_ny also accepted)."""
    if isinstance(value, textures_pb2.RiverVelocity):
        return value
    if isinstance(value, textures_pb2.VelocitySpec):
        if value.WhichOneof("field") != "river":
            raise ValueError(f"{path}: the VelocitySpec holds no river")
        return value.river
    if not isinstance(value, Mapping):
        raise TypeError(
            f"{path}: want squall.textures.river(...), a RiverVelocity or a mapping, "
            f"got {value!r}"
        )
    arguments = dict(value)
    bake_nx, bake_ny = arguments.pop("bake_nx", None), arguments.pop("bake_ny", None)
    try:
        message = river_message(**arguments)
    except TypeError as error:
        raise TypeError(f"{path}: {error}") from None
    if bake_nx is not None:
        message.bake_nx = integer(bake_nx, f"{path}.bake_nx", 0, UINT32_MAX)
    if bake_ny is not None:
        message.bake_ny = integer(bake_ny, f"{path}.bake_ny", 0, UINT32_MAX)
    return message


def _river_bounds(river: textures_pb2.RiverVelocity) -> Optional[textures_pb2.TextureRegion]:
    """The bounding box of the river's banks and obstacles (None without points)."""
    lines = [c.left_bank for c in river.channels] + [c.right_bank for c in river.channels]
    lines += [o.outline for o in river.obstacles]
    xs = [q.x for line in lines for q in line.points]
    ys = [q.y for line in lines for q in line.points]
    if not xs:
        return None
    return textures_pb2.TextureRegion(x0=min(xs), y0=min(ys), x1=max(xs), y1=max(ys))


def bake_request(
    river: RiverLike = None,
    *,
    size: Optional[Sequence[int]] = None,
    region: Optional[RegionLike] = None,
    psi: bool = False,
    dtype: Any = "float32",
    request: Optional[textures_pb2.BakeVelocityRequest] = None,
) -> textures_pb2.BakeVelocityRequest:
    """The BakeVelocityRequest of ``Textures.bake_velocity``'s arguments (or `request`)."""
    if request is not None:
        return to_message(textures_pb2.BakeVelocityRequest, request)
    if river is None:
        raise TypeError("bake_velocity: river is required")
    message = as_river(river, "request.river")
    if size is None:
        nx, ny = message.bake_nx or 128, message.bake_ny or 128
    else:
        nx, ny = _pair(size, "request.size")
    if region is not None:
        area: Optional[textures_pb2.TextureRegion] = texture_region(region, "request.region")
    elif message.HasField("bake_region"):
        area = message.bake_region
    else:
        area = _river_bounds(message)
    out = textures_pb2.BakeVelocityRequest(
        river=message,
        nx=nx,
        ny=ny,
        psi=flag(psi, "psi"),
        dtype=dtype_value(dtype, "request.dtype"),
    )
    if area is not None:
        out.region.CopyFrom(area)
    return out


# -------------------------------------------------------------------------------------------------
# Content-aware texture deformation (Guingo et al. 2020)

# An (H, W) or (H, W, C) array, PNG bytes, an ImageTexture, or a TextureSource holding an image
DeformImageLike = Any
# A 2x2 array-like [[xx, xy], [yx, yy]], a Tensor2, or a mapping of its fields
TensorLike = Any
# (cx, cy, radius, strength), a mapping {"center": (x, y), "radius": r, "strength": s}, or a
# BrushStroke
StrokeLike = Any
PlanesLike = Union[str, int, Sequence[Union[str, int]]]


def tensor2(value: TensorLike, path: str = "tensor") -> textures_pb2.Tensor2:
    """A Tensor2 from a 2x2 array-like [[xx, xy], [yx, yy]], a mapping of its fields, or the
    message."""
    if isinstance(value, (textures_pb2.Tensor2, Mapping)):
        return to_message(textures_pb2.Tensor2, value, path)
    array = float_array(value, path, "a 2x2 matrix [[xx, xy], [yx, yy]]")
    if array.shape not in ((2, 2), (4,)):
        raise ValueError(
            f"{path}: want a 2x2 matrix [[xx, xy], [yx, yy]], got shape {array.shape}"
        )
    xx, xy, yx, yy = array.ravel().tolist()
    return textures_pb2.Tensor2(xx=xx, xy=xy, yx=yx, yy=yy)


def brush_stroke(value: StrokeLike, path: str = "strokes[0]") -> textures_pb2.BrushStroke:
    """A BrushStroke from (cx, cy, radius, strength) (texels, texels, d mu per frame), a mapping
    {"center": (cx, cy), "radius": r, "strength": s}, or the message."""
    if isinstance(value, (textures_pb2.BrushStroke, Mapping)):
        return to_message(textures_pb2.BrushStroke, value, path)
    want = "(cx, cy, radius, strength), a mapping or a BrushStroke"
    cx, cy, radius, strength = floats(value, path, want, (4,))
    return textures_pb2.BrushStroke(
        center=textures_pb2.Vec2(x=cx, y=cy), radius=radius, strength=strength
    )


def _strokes(
    values: Optional[Sequence[StrokeLike]], path: str
) -> Optional[List[textures_pb2.BrushStroke]]:
    if values is None:
        return None
    items = sequence(values, path, "a sequence of strokes")
    return [brush_stroke(s, f"{path}[{i}]") for i, s in enumerate(items)]


def _field_or_none(value: Optional[FieldLike], path: str) -> Optional[common_pb2.Field]:
    return None if value is None else to_field(value, path)


def deform_texture(
    value: DeformImageLike, path: str = "request.texture"
) -> textures_pb2.ImageTexture:
    """The ImageTexture deformed: from an (H, W) or (H, W, C) array (float: one Field per channel;
    uint8: 8-bit pixels; uint16: Fields of value / 65535), PNG bytes, an ImageTexture, or a
    TextureSource holding an image."""
    if isinstance(value, textures_pb2.ImageTexture):
        return value
    if isinstance(value, textures_pb2.TextureSource):
        if value.WhichOneof("source") != "image":
            raise ValueError(f"{path}: the TextureSource holds no image")
        return value.image
    if isinstance(value, Mapping):
        return to_message(textures_pb2.ImageTexture, value, path)
    return image_texture(value, tileable=False, path=path)


def _deform_planes(planes: PlanesLike, path: str) -> List[int]:
    if isinstance(planes, (str, int, np.integer)):
        planes = [planes]
    items = sequence(planes, path, "a plane name or a sequence of them")
    return [
        enum_value(textures_pb2.DeformPlane.DESCRIPTOR, p, f"{path}[{i}]")
        for i, p in enumerate(items)
    ]


def deform_request(
    image: DeformImageLike = None,
    rigidity: Optional[FieldLike] = None,
    *,
    control: Union[str, int] = "constant",
    d_mu: Optional[float] = None,
    d_mu_map: Optional[FieldLike] = None,
    kappa: Optional[float] = None,
    deformation_start: Optional[TensorLike] = None,
    deformation_end: Optional[TensorLike] = None,
    strokes: Optional[Sequence[StrokeLike]] = None,
    paper_dt_factor: bool = False,
    frames: int = 0,
    dt: Optional[float] = None,
    substeps: Optional[int] = None,
    stack_levels: int = 0,
    chart: Optional[FieldLike] = None,
    planes: PlanesLike = ("color",),
    dtype: Any = "float32",
    tolerance: Optional[float] = None,
    max_iterations: Optional[int] = None,
    request: Optional[Union[textures_pb2.DeformTextureRequest, Mapping[str, Any]]] = None,
) -> textures_pb2.DeformTextureRequest:
    """The DeformTextureRequest of ``Textures.deform``'s arguments (or `request` when given)."""
    if request is not None:
        return to_message(textures_pb2.DeformTextureRequest, request, "request")
    if image is None or rigidity is None:
        raise TypeError("deform: image and rigidity are required")
    return message_from(
        textures_pb2.DeformTextureRequest,
        None,
        "request",
        texture=deform_texture(image, "request.texture"),
        rigidity=to_field(rigidity, "request.rigidity"),
        chart=_field_or_none(chart, "request.chart"),
        control=enum_value(textures_pb2.DeformControlKind.DESCRIPTOR, control, "request.control"),
        kappa=kappa,
        d_mu=d_mu,
        d_mu_map=_field_or_none(d_mu_map, "request.d_mu_map"),
        deformation_start=(
            None
            if deformation_start is None
            else tensor2(deformation_start, "request.deformation_start")
        ),
        deformation_end=(
            None
            if deformation_end is None
            else tensor2(deformation_end, "request.deformation_end")
        ),
        strokes=_strokes(strokes, "request.strokes"),
        paper_dt_factor=paper_dt_factor,
        frames=integer(frames, "request.frames", 0, UINT32_MAX),
        dt=dt,
        substeps=substeps,
        stack_levels=integer(stack_levels, "request.stack_levels", 0, UINT32_MAX),
        planes=_deform_planes(planes, "request.planes"),
        dtype=dtype_value(dtype, "request.dtype"),
        tolerance=tolerance,
        max_iterations=max_iterations,
    )


def deform_control_message(
    start: Optional[textures_pb2.DeformTextureRequest],
    frames: int,
    d_mu: Optional[float],
    d_mu_map: Optional[FieldLike],
    deformation: Optional[TensorLike],
    strokes: Optional[Sequence[StrokeLike]],
    clear_strokes: bool,
) -> textures_pb2.DeformControl:
    return message_from(
        textures_pb2.DeformControl,
        None,
        "control",
        start=start,
        frames=integer(frames, "frames", 0, UINT32_MAX),
        d_mu=d_mu,
        d_mu_map=_field_or_none(d_mu_map, "control.d_mu_map"),
        deformation=None if deformation is None else tensor2(deformation, "control.deformation"),
        strokes=_strokes(strokes, "control.strokes"),
        clear_strokes=flag(clear_strokes, "clear_strokes"),
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
        frames=integer(frames, "frames", 0, UINT32_MAX),
        velocity=as_velocity(velocity, "control.velocity"),
        dt=dt,
        substeps=substeps,
        spin=spin,
        final_scale=final_scale,
    )


F = TypeVar("F")
S = TypeVar("S", bound="Steering[Any]")


class Steering(Generic[F]):
    """A running bidirectional stream steered message by message (sync): each message asks for
    some frames, which come back before the next one is sent. The base of ``Interactive``
    (AdvectInteractive) and ``DeformInteractive``.

    Use it in a ``with`` block (or call ``close()``): the stream then ends and frees its
    --max-streams slot. A message that fails validation raises SquallError naming
    "control[n].<field>".
    """

    METHOD = ""

    def __init__(
        self,
        connection: Connection,
        open_call: Callable[..., Any],
        convert: Callable[[Any], F],
        start: Any,
        timeout: Optional[float],
        session: Optional[str] = None,
    ) -> None:
        self._requests = RequestQueue()
        self._convert = convert
        self._start: Any = start  # sent with the first message only
        try:
            self._call = open_call(
                self._requests,
                timeout=connection.settings.deadline(timeout, stream=True),
                metadata=connection.settings.metadata(session),
            )
        except grpc.RpcError as error:
            raise SquallError.from_rpc(error, self.METHOD) from None
        self.frames_received = 0
        self._ended = False  # the call has ended (its error, if any, was raised)

    def _next(self) -> Any:
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

    def _check_open(self) -> None:
        if self._ended:
            raise SquallError(
                grpc.StatusCode.FAILED_PRECONDITION, "client: the stream has ended", self.METHOD
            )

    def _take_start(self) -> Any:
        start, self._start = self._start, None
        return start

    def _exchange(self, message: Any, frames: int) -> List[F]:
        """Sends one message and reads the `frames` frames it asks for. Anything raised while
        reading them (a frame that fails conversion, an interrupt) cancels the stream: the
        frames left unread would otherwise be returned by the next ``send``."""
        self._requests.put(message)
        try:
            out = [self._convert(self._next()) for _ in range(int(frames))]
        except BaseException:
            self.cancel()
            raise
        self.frames_received += len(out)
        return out

    def close(self) -> None:
        """Ends the request side and waits for the server to finish the call (raises its error,
        unless ``send`` raised it already)."""
        self._requests.close()
        if self._ended:
            return
        self._ended = True
        try:
            for _ in self._call:
                pass
        except grpc.RpcError as error:
            if error.code() != grpc.StatusCode.CANCELLED:
                raise SquallError.from_rpc(error, self.METHOD) from None

    def cancel(self) -> None:
        """Ends the call now; ``send`` then raises SquallError (FAILED_PRECONDITION) and ``close``
        nothing."""
        self._ended = True
        self._requests.close()
        self._call.cancel()

    def __enter__(self: S) -> S:
        return self

    def __exit__(self, exc_type: Any, *exc: Any) -> None:
        if exc_type is None:
            self.close()
        else:
            self.cancel()

    def __del__(self) -> None:
        # Neither closed nor left in a with block: gRPC's request thread would wait in the queue
        # forever.
        try:
            self._requests.close()
            self._call.cancel()
        except Exception:  # __init__ failed before the call was opened
            pass


class Interactive(Steering[TextureFrame]):
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
        super().__init__(
            connection,
            service.AdvectInteractive,
            TextureFrame,
            start,
            timeout,
            session=followed_session(start),
        )

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
                set. The stream stays routed by the velocity it was opened with: behind a
                session-affine proxy, open it on an eWave session to follow that session later.
            dt: s between frames from now on, (0, 1e4].
            substeps: integration steps per frame from now on, 1..64.
            spin: rad/s, flow-noise rotation of band 0 (noise textures).
            final_scale: the final function's scale (dimensionless).

        A message that fails validation raises SquallError naming "control[n].<field>", but
        the server sends no reply to one with ``frames=0``: send() returns [] at once, and
        that message's error is raised only by the next send() that asks for frames, or by
        close() (the end of the ``with`` block); a send(frames=0) in between returns [] too,
        and cancel() drops the error.
        """
        self._check_open()
        message = control_message(self._start, frames, velocity, dt, substeps, spin, final_scale)
        self._take_start()
        return self._exchange(message, message.frames)


class DeformInteractive(Steering[DeformFrame]):
    """A running DeformInteractive stream (sync): ``send`` steers the deformation and returns the
    frames it asks for. Use it in a ``with`` block (or call ``close()``); a message that fails
    validation raises SquallError naming "control[n].<field>".
    """

    METHOD = "Textures.DeformInteractive"

    def __init__(
        self,
        connection: Connection,
        service: Any,
        start: textures_pb2.DeformTextureRequest,
        timeout: Optional[float],
    ) -> None:
        super().__init__(connection, service.DeformInteractive, DeformFrame, start, timeout)

    def send(
        self,
        frames: int = 1,
        *,
        d_mu: Optional[float] = None,
        d_mu_map: Optional[FieldLike] = None,
        deformation: Optional[TensorLike] = None,
        strokes: Optional[Sequence[StrokeLike]] = None,
        clear_strokes: bool = False,
    ) -> List[DeformFrame]:
        """Applies the changes given (from this message's first frame on) and returns `frames`
        more frames.

        Args:
            frames: frames to produce after applying this message, 0..1024.
            d_mu: control "constant": the new d mu per frame (|d_mu| <= 100).
            d_mu_map: control "map": the new (H, W) map of d mu.
            deformation: tensor controls: G now (a 2x2 array-like, det >= 1e-12), reached at this
                message's first frame and held after it.
            strokes: control "brush": the strokes of the next frames, each (cx, cy, radius,
                strength), replacing the previous ones.
            clear_strokes: with no strokes: no brush from now on.

        A message that fails validation raises SquallError naming "control[n].<field>", but
        the server sends no reply to one with ``frames=0``: send() returns [] at once, and
        that message's error is raised only by the next send() that asks for frames, or by
        close() (the end of the ``with`` block); a send(frames=0) in between returns [] too,
        and cancel() drops the error.
        """
        self._check_open()
        message = deform_control_message(
            self._start, frames, d_mu, d_mu_map, deformation, strokes, clear_strokes
        )
        self._take_start()
        return self._exchange(message, message.frames)


def interactive_start(
    start: Optional[Union[textures_pb2.AdvectTextureRequest, Mapping[str, Any]]],
    kwargs: Mapping[str, Any],
) -> textures_pb2.AdvectTextureRequest:
    """The advection an ``interactive`` stream starts (sync and asyncio): ``start``, or
    ``advect``'s keyword arguments. TypeError for both, and for frames, checkpoint_every or
    resume_state, which the server refuses in a start (each send() asks for its frames; the
    stream neither checkpoints nor resumes)."""
    if start is not None and kwargs:
        raise TypeError("interactive: pass either start or advect's keyword arguments, not both")
    request = (
        advect_request(**kwargs)
        if start is None
        else to_message(textures_pb2.AdvectTextureRequest, start, "start")
    )
    refused = [f for f in ("frames", "checkpoint_every", "resume_state") if getattr(request, f)]
    if refused:
        raise TypeError(
            f"interactive: {', '.join(refused)} set: each send() asks for its frames, and an "
            "interactive stream neither checkpoints nor resumes"
        )
    return request


def deform_interactive_start(
    start: Optional[Union[textures_pb2.DeformTextureRequest, Mapping[str, Any]]],
    image: Any,
    rigidity: Any,
    kwargs: Mapping[str, Any],
) -> textures_pb2.DeformTextureRequest:
    """The deformation a ``deform_interactive`` stream starts (sync and asyncio): ``start``, or
    ``deform``'s arguments. TypeError for both, for frames (each send() asks for its frames) and
    for deformation_end (send()'s deformation steers G)."""
    if start is not None and (kwargs or image is not None or rigidity is not None):
        raise TypeError("deform_interactive: pass either start or deform's arguments, not both")
    request = (
        deform_request(image, rigidity, **kwargs)
        if start is None
        else to_message(textures_pb2.DeformTextureRequest, start, "start")
    )
    if request.frames:
        raise TypeError("deform_interactive: frames set: each send() asks for its frames")
    if request.HasField("deformation_end"):
        raise TypeError("deform_interactive: deformation_end set: send(deformation=...) steers G")
    return request


class Textures:
    """``client.textures``: the Textures service (AdvectTexture, AdvectInteractive, BakeVelocity,
    DeformTexture, DeformInteractive)."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = rpc_client(textures_pb2_grpc.TexturesStub, connection.channel)

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
            resume_state: the checkpoint of frame k of this same request (but for frames and
                checkpoint_every): the stream continues bit-identically with frames k + 1 ...
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
            "Textures.AdvectTexture",
            self._rpc.AdvectTexture,
            message,
            TextureFrame,
            timeout,
            session=followed_session(message),
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
        return Interactive(self._connection, self._rpc, interactive_start(start, kwargs), timeout)

    def bake_velocity(
        self,
        river: RiverLike = None,
        *,
        size: Optional[Sequence[int]] = None,
        region: Optional[RegionLike] = None,
        psi: bool = False,
        dtype: Any = "float32",
        timeout: Optional[float] = None,
        request: Optional[textures_pb2.BakeVelocityRequest] = None,
    ) -> BakedVelocity:
        """A river's velocity evaluated on the nodes of a grid (BakeVelocity).

        Args:
            river: ``squall.textures.river(...)``, a RiverVelocity, or a mapping of
                ``river_message``'s arguments. Its bake grid is not used here, except as defaults.
            size: (nx, ny) nodes, 2..4096 each; None: the river's bake size, else 128 x 128.
            region: (x0, y0, x1, y1), du: node (i, j) at (x0 + i (x1 - x0) / (nx - 1),
                y0 + j (y1 - y0) / (ny - 1)); None: the river's bake_region, else the bounding box
                of its banks and obstacles.
            psi: also return the stream function.
            dtype: "float32" or "float16" of the returned arrays.
            request: a ready-made BakeVelocityRequest instead of all the above.

        Returns:
            A BakedVelocity: arrays u, v, fluid (and psi when asked) of shape (ny, nx), with
            flow_rates, left_psi, right_psi, obstacle_psi and undefined_nodes.
        """
        message = bake_request(
            river, size=size, region=region, psi=psi, dtype=dtype, request=request
        )
        return BakedVelocity(
            self._connection.unary(
                "Textures.BakeVelocity", self._rpc.BakeVelocity, message, timeout
            )
        )

    def deform(
        self,
        image: DeformImageLike = None,
        rigidity: Optional[FieldLike] = None,
        *,
        control: Union[str, int] = "constant",
        d_mu: Optional[float] = None,
        d_mu_map: Optional[FieldLike] = None,
        kappa: Optional[float] = None,
        deformation_start: Optional[TensorLike] = None,
        deformation_end: Optional[TensorLike] = None,
        strokes: Optional[Sequence[StrokeLike]] = None,
        paper_dt_factor: bool = False,
        frames: Optional[int] = None,
        dt: Optional[float] = None,
        substeps: Optional[int] = None,
        stack_levels: int = 0,
        chart: Optional[FieldLike] = None,
        planes: PlanesLike = ("color",),
        dtype: Any = "float32",
        tolerance: Optional[float] = None,
        max_iterations: Optional[int] = None,
        timeout: Optional[float] = None,
        request: Optional[textures_pb2.DeformTextureRequest] = None,
    ) -> Stream[DeformFrame]:
        """Content-aware deformation of a texture (DeformTexture; Guingo et al. 2020): the flow
        field v is solved once from the rigidity map, then each frame moves every texel's warp
        along v by its d mu. Texture space in texels; d mu dimensionless.

        Args:
            image: the texture, W x H texels (W, H >= 4): an (H, W) or (H, W, C) array (float:
                one Field per channel, 1..8 channels; uint8: 8-bit pixels / 255; uint16: value /
                65535), PNG bytes, an ImageTexture, or ``squall.textures.image(...)``.
            rigidity: R, an (H, W) array in [-1, 1]: 1 rigid (kept), -1 stretchable.
            control: "constant" (d mu = d_mu), "map" (kappa d_mu_map), "isotropic",
                "anisotropic" (the deformation gradient, from deformation_start to
                deformation_end), "brush" (the strokes' Gaussians).
            d_mu: "constant": d mu per frame, |d_mu| <= 100; None: 0.
            d_mu_map: "map": an (H, W) array, |value| <= 100.
            kappa: the scale of d mu ("map", tensor controls), |kappa| <= 1e6; None: 1.
            deformation_start, deformation_end: G at frame 0 and at the last frame (2x2
                array-likes [[xx, xy], [yx, yy]], det >= 1e-12); None: identity.
            strokes: "brush": 0..256 strokes (cx, cy, radius, strength) in texels, texels and d mu
                at the centre per frame (> 0 shrinks the pattern there, < 0 widens it).
            paper_dt_factor: tensor controls multiply d mu by dt (as the paper's eqs. 7-8).
            frames: frames of the stream, frame 0 first (the undeformed texture), 1..100000.
                Required.
            dt: s between frames, (0, 1e4]; None: 1/30.
            substeps: Euler sub-steps of each frame's warp update, 1..100; None: 10.
            stack_levels: resampling stack levels L, 0..16 (0: no stack).
            chart: an (H, W) array, nonzero inside the chart; texels outside stay fixed.
            planes: "color" (default; "color_<c>"), "warp" ("warp_x", "warp_y", texels),
                "reference" ("reference_time"), "level", "flow" ("flow_x", "flow_y"); sent in
                that order whatever the order asked.
            dtype: "float32" or "float16" of the returned planes.
            tolerance: flow solve's relative residual, [1e-12, 1e-1]; None: 1e-6.
            max_iterations: flow solve iterations, 1..100000; None: 4000.
            request: a ready-made DeformTextureRequest instead of all the above.

        Returns:
            An iterator of DeformFrames (planes keyed by name, arrays of shape (H, W), with index,
            time, solver_iterations, solver_residual, max_warp, ...); it holds one
            --max-streams slot until it ends or is cancelled.
        """
        if request is None and frames is None:
            raise TypeError("deform: frames (1..100000) is required")
        message = deform_request(
            image,
            rigidity,
            control=control,
            d_mu=d_mu,
            d_mu_map=d_mu_map,
            kappa=kappa,
            deformation_start=deformation_start,
            deformation_end=deformation_end,
            strokes=strokes,
            paper_dt_factor=paper_dt_factor,
            frames=frames or 0,
            dt=dt,
            substeps=substeps,
            stack_levels=stack_levels,
            chart=chart,
            planes=planes,
            dtype=dtype,
            tolerance=tolerance,
            max_iterations=max_iterations,
            request=request,
        )
        return self._connection.stream(
            "Textures.DeformTexture", self._rpc.DeformTexture, message, DeformFrame, timeout
        )

    def deform_interactive(
        self,
        image: DeformImageLike = None,
        rigidity: Optional[FieldLike] = None,
        *,
        start: Optional[Union[textures_pb2.DeformTextureRequest, Mapping[str, Any]]] = None,
        timeout: Optional[float] = None,
        **kwargs: Any,
    ) -> DeformInteractive:
        """Starts a DeformInteractive stream: the deformation (``deform``'s arguments but frames,
        or a DeformTextureRequest as `start`, frames 0), steered by ``DeformInteractive.send``.

        Example::

            with client.textures.deform_interactive(image, rigidity, control="brush") as run:
                still = run.send(frames=2)                       # frames 0 and 1: no stroke yet
                pushed = run.send(frames=3, strokes=[(24, 24, 6, 1.0)])
                held = run.send(frames=2, clear_strokes=True)    # the warp stays where it is
        """
        request = deform_interactive_start(start, image, rigidity, kwargs)
        return DeformInteractive(self._connection, self._rpc, request, timeout)
