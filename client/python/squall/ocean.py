"""Ocean tiles (squall.v1.Ocean): FFT spectral ocean surfaces, streamed frames and surface samples.

Builders (``layer``, ``tile_spec``) make the TileSpec; ``client.ocean`` (an ``Ocean``) calls the
service. Units: SI (m, s, rad); world axes x east, y north, z up; angles counter-clockwise from +x.
Equation numbers are those of J. Tessendorf, "Gilligan" (2017) and its App A ("Simulating Ocean
Water").

Example::

    import squall
    with squall.Client("127.0.0.1:50051") as client:
        spec = squall.ocean.tile_spec([squall.ocean.layer(extent=200, n=128, wind_speed=12)])
        tile = client.ocean.tile(spec, time=2.0, outputs=("height", "displacement_x"))
        tile["height"].shape   # (128, 128): [j, i] is sample (i, j), metres
"""

from __future__ import annotations

from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import grpc
import numpy as np

from squall._calls import Connection, Stream
from squall._convert import (
    UINT32_MAX,
    ArrayLike,
    bytes_per_value,
    dtype_value,
    enum_value,
    flag,
    integer,
    is_number,
    items_of,
    message_from,
    number,
    points_to_vec3,
    sequence,
    to_message,
)
from squall._errors import SquallError
from squall._pb import common_pb2, ocean_pb2, ocean_pb2_grpc, rpc_client
from squall._results import Samples, Tile

LayerSpec = ocean_pb2.LayerSpec
TileSpec = ocean_pb2.TileSpec
LayerLike = Union[ocean_pb2.LayerSpec, Mapping[str, Any]]
TileLike = Union[ocean_pb2.TileSpec, ocean_pb2.LayerSpec, Mapping[str, Any], Sequence[LayerLike]]
Outputs = Sequence[Union[str, int]]

__all__ = ["layer", "tile_spec", "as_tile_spec", "Ocean", "TileAssembler", "Tile", "Samples"]


def _pair(value: Union[float, Sequence[float]], path: str, want: str) -> Tuple[Any, Any]:
    """(value, value) for one number, else the items of a pair; their types are checked as the
    fields they are set to."""
    if is_number(value):
        return value, value
    x, y = items_of(value, path, (2,), want)
    return x, y


def _partial(
    value: Union[Tuple[float, float], Mapping[str, Any], ocean_pb2.PartialSpectrum], path: str
) -> ocean_pb2.PartialSpectrum:
    """A PartialSpectrum from a (peak_frequency, Hs) pair, a mapping of its fields or itself."""
    if isinstance(value, (Mapping, ocean_pb2.PartialSpectrum)):
        return to_message(ocean_pb2.PartialSpectrum, value, path)
    want = "a (peak_frequency, Hs) pair (rad/s, m), a PartialSpectrum or a mapping of its fields"
    frequency, height = items_of(value, path, (2,), want)
    fields = {"peak_frequency": frequency, "significant_wave_height": height}
    return to_message(ocean_pb2.PartialSpectrum, fields, path)


def layer(
    extent: Union[float, Sequence[float]] = 1000.0,
    n: Union[int, Sequence[int]] = 256,
    *,
    spectrum: Union[str, int] = "jonswap",
    spreading: Union[str, int] = "mitsuyasu",
    dispersion: Union[str, int] = "deep",
    wind_speed: float = 10.0,
    wind_direction: float = 0.0,
    fetch: float = 100000.0,
    depth: float = 100.0,
    capillary_length: float = 0.0027,
    peak_enhancement: Optional[float] = None,
    sigma_below_peak: Optional[float] = None,
    sigma_above_peak: Optional[float] = None,
    phillips_amplitude: Optional[float] = None,
    phillips_cutoff: Optional[float] = None,
    phillips_exponent: Optional[float] = None,
    partials: Sequence[
        Union[Tuple[float, float], Mapping[str, Any], ocean_pb2.PartialSpectrum]
    ] = (),
    gravity: Optional[float] = None,
    k_min: float = 0.0,
    k_max: float = 0.0,
    seed: int = 1,
    drift: Sequence[float] = (0.0, 0.0),
) -> ocean_pb2.LayerSpec:
    """One layer of a tile: a periodic patch with its own extent, FFT grid, spectrum and seed.

    The defaults are those of ``squall ocean tile`` (the command line). None leaves an optional
    field unset: the server then takes the model's published default, given below.

    Args:
        extent: patch size Lx (or (Lx, Ly)), m; in [0.001, 1e6].
        n: FFT grid nx (or (nx, ny)); each even and >= 2.
        spectrum: "phillips", "pierson_moskowitz", "jonswap", "modified_jonswap", "tma",
            "multipeak".
        spreading: "isotropic", "pierson_cos2", "krylov", "mitsuyasu", "jonswap", "von_mises",
            "hyperbolic"; "unspecified" only with Phillips (which has its own |k.w|^p factor).
        dispersion: "deep", "shallow", "capillary", "combined" (Gilligan Table 1).
        wind_speed: U at 10 m, m/s; in (0, 100] (Multipeak with a spreading that does not use the
            wind: [0, 100]).
        wind_direction: direction the wind blows towards, rad.
        fetch: JONSWAP / modified JONSWAP / TMA fetch, m; in (0, 1e8].
        depth: water depth (shallow / combined dispersion, TMA), m; in (0, 1e5].
        capillary_length: capillary / combined dispersion, m; in [0, 1] (water: about 2.7e-3).
        peak_enhancement: JONSWAP / TMA gamma, [1, 100]; unset: 3.3.
        sigma_below_peak, sigma_above_peak: JONSWAP / TMA peak widths, (0, 10]; unset: 0.07, 0.09.
        phillips_amplitude: Phillips A, m^2; unset: 1e-3.
        phillips_cutoff: Phillips small-wave cut-off length, m; unset: 0.
        phillips_exponent: Phillips p of |k.w|^p, [0, 64]; unset: 2.
        partials: Multipeak partial spectra, 1 to 4: (peak_frequency rad/s, significant_wave_height
            m) pairs, or PartialSpectrum messages / mappings (shape a, b, c, n, m).
        gravity: g, m/s^2, (0, 100]; unset: 9.81.
        k_min, k_max: band limit, rad/m (k_max 0: no upper limit).
        seed: random seed of the amplitudes (same seed, same sea on every device).
        drift: drift current (U_D,x, U_D,y), m/s, each in [-100, 100].
    """
    extent_x, extent_y = _pair(extent, "layer.extent", "a number or a pair (Lx, Ly), m")
    nx, ny = _pair(n, "layer.n", "an integer or a pair (nx, ny)")
    drift_x, drift_y = _pair(drift, "layer.drift", "a pair (U_D,x, U_D,y), m/s")
    partial_items = sequence(partials, "layer.partials", "a sequence of partial spectra")
    partial_messages = [_partial(p, f"layer.partials[{i}]") for i, p in enumerate(partial_items)]
    return message_from(
        ocean_pb2.LayerSpec,
        None,
        "layer",
        extent_x=extent_x,
        extent_y=extent_y,
        nx=nx,
        ny=ny,
        spectrum=spectrum,
        spreading=spreading,
        dispersion=dispersion,
        wind_speed=wind_speed,
        wind_direction=wind_direction,
        fetch=fetch,
        depth=depth,
        capillary_length=capillary_length,
        peak_enhancement=peak_enhancement,
        sigma_below_peak=sigma_below_peak,
        sigma_above_peak=sigma_above_peak,
        phillips_amplitude=phillips_amplitude,
        phillips_cutoff=phillips_cutoff,
        phillips_exponent=phillips_exponent,
        partials=partial_messages,
        gravity=gravity,
        k_min=k_min,
        k_max=k_max,
        seed=seed,
        drift_x=drift_x,
        drift_y=drift_y,
    )


def tile_spec(
    layers: Union[LayerLike, Sequence[LayerLike]] = (),
    *,
    choppiness: float = 1.0,
    b_correction: bool = False,
    output: Optional[Union[Sequence[float], Mapping[str, Any], ocean_pb2.OutputGrid]] = None,
    whitecap_threshold: Optional[float] = None,
    whitecap_decay_time: Optional[float] = None,
    pixel_scale: Optional[float] = None,
    slope_k_max: Optional[float] = None,
) -> ocean_pb2.TileSpec:
    """A tile: the sum of 1 to 8 layers, sampled on an output grid.

    Args:
        layers: LayerSpec messages (see ``layer``) or mappings of their fields (one layer alone
            is fine). Empty: one ``layer()`` with its defaults.
        choppiness: lambda, [-100, 100]; positive sharpens the crests, 0: no horizontal
            displacement. Default 1 (as the command line; the proto's own default is 0).
        b_correction: the multi-layer correction B(k)^(-1/2) (eq 56-57).
        output: the output grid: (nx, ny) samples over the first layer's extent, (nx, ny, extent_x,
            extent_y) with extents in m, or an OutputGrid. None: the first layer's grid and extent.
        whitecap_threshold: W = 1 where J- < threshold, [unit 1]; unset: 0.3.
        whitecap_decay_time: e-folding time T of the whitecap map, s, > 0; unset: 4 s.
        pixel_scale: R for the unresolved slope variance (eq 96), m, > 0; unset: the output cell
            size.
        slope_k_max: upper wavenumber of the eq-96 integral, rad/m, > 0; unset: 1000.
    """
    if isinstance(layers, (ocean_pb2.LayerSpec, Mapping)):
        layers = [layers]
    items = sequence(layers, "tile.layers", "a layer or a sequence of layers")
    layer_messages = [
        to_message(ocean_pb2.LayerSpec, l, f"tile.layers[{i}]") for i, l in enumerate(items)
    ]
    if not layer_messages:
        layer_messages = [layer()]
    grid: Any = output
    if output is not None and not isinstance(output, (Mapping, ocean_pb2.OutputGrid)):
        want = "(nx, ny) or (nx, ny, extent_x, extent_y), or an OutputGrid"
        values = items_of(output, "tile.output", (2, 4), want)
        sizes = [integer(v, f"tile.output.n{n}", 0, UINT32_MAX) for n, v in zip("xy", values)]
        extents = [number(v, f"tile.output.extent_{n}") for n, v in zip("xy", values[2:])]
        grid = dict(zip(("nx", "ny", "extent_x", "extent_y"), sizes + extents))
    return message_from(
        ocean_pb2.TileSpec,
        None,
        "tile",
        layers=layer_messages,
        choppiness=choppiness,
        b_correction=b_correction,
        output=grid,
        whitecap_threshold=whitecap_threshold,
        whitecap_decay_time=whitecap_decay_time,
        pixel_scale=pixel_scale,
        slope_k_max=slope_k_max,
    )


def as_tile_spec(spec: Optional[TileLike], path: str = "tile") -> ocean_pb2.TileSpec:
    """A TileSpec from a TileSpec, a mapping of its fields, one LayerSpec, or a sequence of layers.

    A layer or a sequence of layers goes through ``tile_spec`` (choppiness 1); a mapping is taken
    as the TileSpec's own fields (proto defaults: choppiness 0).
    """
    if spec is None:
        raise TypeError(f"{path}: a tile is needed (squall.ocean.tile_spec(...), or request=...)")
    if isinstance(spec, ocean_pb2.TileSpec):
        return spec
    if isinstance(spec, ocean_pb2.LayerSpec):
        return tile_spec([spec])
    if isinstance(spec, Mapping):
        return to_message(ocean_pb2.TileSpec, spec, path)
    want = "a TileSpec (squall.ocean.tile_spec(...)), a layer, a sequence of layers or a mapping"
    return tile_spec(sequence(spec, path, want))


def outputs_of(outputs: Union[str, int, Outputs], path: str = "outputs") -> List[Any]:
    """TileOutput numbers from names ("height", "displacement_x", "normal_z", "jacobian_minus",
    ...).
    """
    if isinstance(outputs, (str, int, np.integer)):
        outputs = [outputs]
    items = sequence(outputs, path, "an output name or a sequence of them")
    return [
        enum_value(ocean_pb2.TileOutput.DESCRIPTOR, o, f"{path}[{i}]") for i, o in enumerate(items)
    ]


def tile_request(
    spec: Optional[TileLike],
    time: float = 0.0,
    outputs: Union[str, Outputs] = ("height",),
    dtype: Any = "float32",
    request: Optional[ocean_pb2.GetTileRequest] = None,
) -> ocean_pb2.GetTileRequest:
    """The GetTileRequest of Ocean.tile's arguments (or `request` itself when given)."""
    if request is not None:
        return to_message(ocean_pb2.GetTileRequest, request)
    return ocean_pb2.GetTileRequest(
        tile=as_tile_spec(spec),
        time=common_pb2.SimTime(seconds=number(time, "time")),
        outputs=outputs_of(outputs),
        dtype=dtype_value(dtype),
    )


def stream_request(
    spec: Optional[TileLike],
    dt: Optional[float],
    frames: int = 0,
    t0: float = 0.0,
    outputs: Union[str, Outputs] = ("height",),
    dtype: Any = "float32",
    request: Optional[ocean_pb2.StreamTilesRequest] = None,
) -> ocean_pb2.StreamTilesRequest:
    """The StreamTilesRequest of Ocean.stream's arguments (or `request` itself when given)."""
    if request is not None:
        return to_message(ocean_pb2.StreamTilesRequest, request)
    if dt is None:
        raise TypeError("stream: dt (seconds between frames, > 0) is required")
    return ocean_pb2.StreamTilesRequest(
        tile=as_tile_spec(spec),
        t0=common_pb2.SimTime(seconds=number(t0, "t0")),
        dt=number(dt, "dt"),
        frame_count=integer(frames, "frames", 0, UINT32_MAX),
        outputs=outputs_of(outputs),
        dtype=dtype_value(dtype),
    )


def sample_request(
    spec: Optional[TileLike],
    points: Optional[ArrayLike],
    time: float = 0.0,
    invert_displacement: bool = False,
    request: Optional[ocean_pb2.SampleSurfaceRequest] = None,
) -> ocean_pb2.SampleSurfaceRequest:
    """The SampleSurfaceRequest of Ocean.sample's arguments (or `request` itself when given)."""
    if request is not None:
        return to_message(ocean_pb2.SampleSurfaceRequest, request)
    if points is None:
        raise TypeError("sample: points (an array of shape (n, 2), m) are required")
    message = ocean_pb2.SampleSurfaceRequest(
        tile=as_tile_spec(spec),
        time=common_pb2.SimTime(seconds=number(time, "time")),
        invert_displacement=flag(invert_displacement, "invert_displacement"),
    )
    message.points.extend(points_to_vec3(points))
    return message


class TileAssembler:
    """Reassembles StreamTiles' chunks into whole frames (``add`` returns a Tile at a frame's last
    chunk; ``finish``, at the stream's end, checks that no frame is left half-built).

    A frame is chunk_count consecutive TileChunks; the FieldPieces of one field, concatenated in
    chunk order (rows row_offset .. row_offset + ny), give the field, bit for bit GetTile's. Each
    frame's frame_index is one more than the previous frame's. Anything else (a chunk out of
    order, a frame begun before the previous one is complete, a piece whose bytes disagree with
    its header) raises SquallError INTERNAL as the chunk arrives.
    """

    METHOD = "Ocean.StreamTiles"

    def __init__(self) -> None:
        self._frame = -1  # the frame begun last; -1: none yet
        self._count = 0
        self._next = 0  # the chunk expected next; 0: no frame pending
        self._fields: Dict[str, Tuple[common_pb2.Field, List[bytes], List[int]]] = {}
        self._head = ocean_pb2.TileChunk()

    def _fail(self, message: str) -> SquallError:
        return SquallError(grpc.StatusCode.INTERNAL, f"client: stream: {message}", self.METHOD)

    def _begin(self, chunk: ocean_pb2.TileChunk) -> None:
        """Starts a frame at its chunk 0, once the previous frame is complete and when its
        frame_index follows that frame's."""
        if self._next != 0:
            raise self._fail(
                f"frame {chunk.frame_index} began after chunk {self._next - 1} of the "
                f"{self._count} chunks of frame {self._frame}"
            )
        if self._frame >= 0 and chunk.frame_index != self._frame + 1:
            raise self._fail(f"frame {chunk.frame_index} follows frame {self._frame}")
        self._frame, self._count = chunk.frame_index, chunk.chunk_count
        self._fields = {}
        self._head = chunk

    def _check_piece(self, piece: ocean_pb2.FieldPiece, header: common_pb2.Field) -> None:
        """Checks a piece's dtype and nz against its field's header, and its byte count against
        its own nx, ny and dtype."""
        f = piece.field
        size = bytes_per_value(f.dtype)
        if size is None:
            raise self._fail(f"field {f.name} has dtype {f.dtype}, not float32 or float16")
        if f.dtype != header.dtype or f.nz != header.nz:
            raise self._fail(
                f"piece of {f.name} at row {piece.row_offset} has dtype {f.dtype} and nz {f.nz}, "
                f"the field dtype {header.dtype} and nz {header.nz}"
            )
        want = f.nx * f.ny * max(f.nz, 1) * size
        if len(f.data) != want:
            raise self._fail(
                f"piece of {f.name} at row {piece.row_offset} has {len(f.data)} bytes, want "
                f"nx * ny * max(nz, 1) * {size} = {want}"
            )

    def add(self, chunk: ocean_pb2.TileChunk) -> Optional[Tile]:
        """Takes the stream's next chunk: the frame's Tile at its last chunk, else None."""
        if chunk.chunk_index >= chunk.chunk_count:
            raise self._fail(
                f"chunk {chunk.chunk_index}/{chunk.chunk_count} of frame {chunk.frame_index} "
                "is past the frame's chunk count"
            )
        if chunk.chunk_index == 0:
            self._begin(chunk)
        elif (chunk.frame_index, chunk.chunk_index, chunk.chunk_count) != (
            self._frame,
            self._next,
            self._count,
        ):
            expected = (
                f"chunk {self._next}/{self._count} of frame {self._frame}"
                if self._next
                else "chunk 0 of a frame"
            )
            raise self._fail(
                f"chunk {chunk.chunk_index}/{chunk.chunk_count} of frame {chunk.frame_index} "
                f"out of sequence (expected {expected})"
            )
        for piece in chunk.pieces:
            f = piece.field
            entry = self._fields.get(f.name)
            if entry is None:
                if piece.row_offset != 0:
                    raise self._fail(
                        f"field {f.name} starts at row {piece.row_offset}, expected 0"
                    )
                header = common_pb2.Field(
                    name=f.name, unit=f.unit, nx=f.nx, ny=piece.full_ny, nz=f.nz, dtype=f.dtype
                )
                header.spacing.CopyFrom(f.spacing)
                header.origin.CopyFrom(
                    f.origin
                )  # the first piece starts at row 0: the field's origin
                entry = (header, [], [0])
                self._fields[f.name] = entry
            header, parts, rows = entry
            if piece.row_offset != rows[0] or f.nx != header.nx or rows[0] + f.ny > header.ny:
                raise self._fail(
                    f"piece of {f.name} at row {piece.row_offset} "
                    f"does not continue the {rows[0]} rows"
                )
            self._check_piece(piece, header)
            parts.append(f.data)
            rows[0] += f.ny
        self._next += 1
        if self._next < self._count:
            return None
        self._next = 0
        response = ocean_pb2.GetTileResponse(time=self._head.time, stats=self._head.stats)
        for name, (header, parts, rows) in self._fields.items():
            if rows[0] != header.ny:
                raise self._fail(f"field {name} ended after {rows[0]} of {header.ny} rows")
            header.data = b"".join(parts)
            response.fields.append(header)
        self._fields = {}
        return Tile(response, self._frame)

    def finish(self) -> None:
        """The stream has ended normally: SquallError INTERNAL when it ended inside a frame (that
        frame is dropped; a second call raises nothing)."""
        if self._next == 0:
            return
        done, self._next = self._next, 0
        self._fields = {}
        raise self._fail(
            f"the stream ended after chunk {done - 1} of the {self._count} chunks "
            f"of frame {self._frame}"
        )


class Ocean:
    """``client.ocean``: the Ocean service (see the module docstring). Every method also takes a
    ready-made request message (``request=``) for full control, and ``timeout`` (s; None: the
    client's default)."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = rpc_client(ocean_pb2_grpc.OceanStub, connection.channel)

    def tile(
        self,
        spec: Optional[TileLike] = None,
        *,
        time: float = 0.0,
        outputs: Union[str, Outputs] = ("height",),
        dtype: Any = "float32",
        timeout: Optional[float] = None,
        request: Optional[ocean_pb2.GetTileRequest] = None,
    ) -> Tile:
        """One tile at time t: the requested output fields (GetTile).

        Args:
            spec: the tile (``tile_spec(...)``, a TileSpec, a layer or a list of layers).
            time: t, s (absolute simulation time; any t without history).
            outputs: field names, each at most once, in this order: "height", "displacement_x",
                "displacement_y" (m), "slope_x", "slope_y", "normal_x", "normal_y", "normal_z",
                "jacobian", "jacobian_minus", "jacobian_plus", "whitecap" (1).
            dtype: "float32" or "float16" (transfer and array type).

        Returns:
            A Tile: dict of (ny, nx) arrays keyed by output name, with ``time`` and
            ``unresolved_slope_variance``. RESOURCE_EXHAUSTED past --max-message-bytes (use
            stream()).
        """
        message = tile_request(spec, time, outputs, dtype, request)
        response = self._connection.unary("Ocean.GetTile", self._rpc.GetTile, message, timeout)
        return Tile(response)

    def stream(
        self,
        spec: Optional[TileLike] = None,
        *,
        dt: Optional[float] = None,
        frames: int = 0,
        t0: float = 0.0,
        outputs: Union[str, Outputs] = ("height",),
        dtype: Any = "float32",
        timeout: Optional[float] = None,
        request: Optional[ocean_pb2.StreamTilesRequest] = None,
    ) -> Stream[Tile]:
        """Frames at t0, t0 + dt, ... of one tile (StreamTiles), reassembled from their chunks.

        Args:
            spec, outputs, dtype: as for ``tile``.
            dt: time step between frames, s, > 0 (also the whitecap map's decay step). Required.
            frames: number of frames; 0: until the stream is cancelled (or the deadline passes).
            t0: time of frame 0, s.

        Returns:
            An iterator of Tiles (``frame_index`` 0, 1, ...), each equal to GetTile's for its time
            bit for bit. It holds one of the server's --max-streams slots until it ends or is
            cancelled (``cancel()``, or use it in a ``with`` block). Chunks that do not make whole
            frames in order (see TileAssembler), a stream ending inside a frame among them, raise
            SquallError INTERNAL.
        """
        message = stream_request(spec, dt, frames, t0, outputs, dtype, request)
        assembler = TileAssembler()
        return self._connection.stream(
            "Ocean.StreamTiles",
            self._rpc.StreamTiles,
            message,
            assembler.add,
            timeout,
            finish=assembler.finish,
        )

    def sample(
        self,
        spec: Optional[TileLike] = None,
        points: Optional[ArrayLike] = None,
        *,
        time: float = 0.0,
        invert_displacement: bool = False,
        timeout: Optional[float] = None,
        request: Optional[ocean_pb2.SampleSurfaceRequest] = None,
    ) -> Samples:
        """Height, displacement and normal of the surface at world points (SampleSurface).

        Args:
            spec: the tile (its output grid and whitecap settings are ignored).
            points: world points (x, y), m: an array of shape (n, 2) (or (n, 3), z ignored); 1 to
                1e6.
            time: t, s.
            invert_displacement: False: values of the surface point displaced FROM (x, y); True: of
                the one that lands ON (x, y) after the horizontal displacement.

        Returns:
            Samples: float64 arrays of shape (n,): height, displacement_x, displacement_y (m),
            normal_x, normal_y, normal_z (1), source_x, source_y (m).
        """
        message = sample_request(spec, points, time, invert_displacement, request)
        response = self._connection.unary(
            "Ocean.SampleSurface", self._rpc.SampleSurface, message, timeout
        )
        return Samples(response)
