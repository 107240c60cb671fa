"""What the calls return: dicts of numpy arrays keyed by field name, with the reply's metadata."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, Iterator, List, Optional, Tuple

import numpy as np
from numpy.typing import NDArray

from squall._convert import field_to_array
from squall._pb import clouds_pb2, common_pb2, ewave_pb2, ocean_pb2, textures_pb2


# The arrays' type as a string: np.floating[...] is subscriptable at run time from numpy 1.22 on.
class FieldSet(Dict[str, "NDArray[np.floating[Any]]"]):
    """Arrays keyed by field name ("height", "displacement_x", ...), in the order the server sent
    them.

    A 2D field is an array of shape (ny, nx) (x fastest: ``a[j, i]`` is sample (i, j)), float32, or
    float16 when float16 was asked for. Per field, ``units[name]`` is its unit ("m", "1", "m^2/s"),
    ``spacing[name]`` and ``origin[name]`` the (x, y, z) sample spacing and world position of
    sample (0, 0) (metres, or du for textures).
    """

    def __init__(self, fields: Iterable[common_pb2.Field] = (), path: str = "fields") -> None:
        super().__init__()
        self.units: Dict[str, str] = {}
        self.spacing: Dict[str, Tuple[float, float, float]] = {}
        self.origin: Dict[str, Tuple[float, float, float]] = {}
        for f in fields:
            self[f.name] = field_to_array(f, f"{path}.{f.name}")
            self.units[f.name] = f.unit
            self.spacing[f.name] = (f.spacing.x, f.spacing.y, f.spacing.z)
            self.origin[f.name] = (f.origin.x, f.origin.y, f.origin.z)

    def _shapes(self) -> str:
        return ", ".join(f"{k}: {v.dtype}{list(v.shape)}" for k, v in self.items())


class Tile(FieldSet):
    """One ocean tile (GetTile, or one frame of StreamTiles).

    Attributes:
        time: simulation time t of the tile, s.
        unresolved_slope_variance: sigma_U^2 of TileSpec.pixel_scale (Gilligan eq 96), slope^2.
        frame_index: 0, 1, ... in a stream (0 for GetTile).
    """

    def __init__(self, response: ocean_pb2.GetTileResponse, frame_index: int = 0) -> None:
        super().__init__(response.fields)
        self.time: float = response.time.seconds
        self.unresolved_slope_variance: float = response.stats.unresolved_slope_variance
        self.frame_index = frame_index
        self.response = response  # the reassembled GetTileResponse

    def __repr__(self) -> str:
        return f"Tile(t={self.time} s, frame {self.frame_index}; {self._shapes()})"


class EWaveFrame(FieldSet):
    """The surface after one eWave step.

    Attributes:
        session_id: the session stepped.
        step: steps the session has done (1 after its first step).
        time: simulation time after the step, s.
    """

    def __init__(self, frame: ewave_pb2.EWaveFrame) -> None:
        super().__init__(frame.fields)
        self.session_id: str = frame.session_id
        self.step: int = frame.step
        self.time: float = frame.time.seconds

    def __repr__(self) -> str:
        return f"EWaveFrame(step {self.step}, t={self.time} s; {self._shapes()})"


class TextureFrame(FieldSet):
    """One frame of an advected texture: planes keyed by name ("final", "raw_0", "coverage", ...).

    Attributes:
        index: frame index, 0 .. frames - 1.
        time: t0 + index dt, s.
        stats: the frame's squall.v1.FrameStats (particles, stage timings, ...).
        mean, stddev: per final plane, over the fluid pixels (dimensionless).
        uncovered_pixels: fluid pixels no sample covered.
        checkpoint: resume state after this frame (when checkpoint_every asked for it), else b"".
    """

    def __init__(self, frame: textures_pb2.TextureFrame) -> None:
        super().__init__(frame.planes, "planes")
        self.index: int = frame.index
        self.time: float = frame.time
        self.stats: textures_pb2.FrameStats = frame.stats
        self.mean: Tuple[float, ...] = tuple(frame.stats.mean)
        self.stddev: Tuple[float, ...] = tuple(frame.stats.stddev)
        self.uncovered_pixels: int = frame.stats.uncovered_pixels
        self.checkpoint: bytes = frame.checkpoint

    def __repr__(self) -> str:
        return f"TextureFrame({self.index}, t={self.time} s; {self._shapes()})"


class BakedVelocity(FieldSet):
    """A river's velocity baked on a grid of nodes (Textures.BakeVelocity).

    Arrays of shape (ny, nx) keyed "u", "v" (du/s; 0 on solid nodes), "psi" (du^2/s; only when
    asked, evaluated on solid nodes too) and "fluid" (1 on water nodes, 0 on land and inside
    obstacles); ``a[j, i]`` is node (i, j) at (x0 + i (x1 - x0) / (nx - 1), y0 + j (y1 - y0) /
    (ny - 1)), which ``spacing`` and ``origin`` give per field (du).

    Attributes:
        u, v, fluid: the arrays above; psi: the stream function, or None unless asked.
        flow_rates: Q of each channel, du^2/s, given or from the junctions.
        left_psi, right_psi: psi on each channel's left and right bank, du^2/s.
        obstacle_psi: psi on each obstacle, du^2/s.
        undefined_nodes: water nodes with no boundary within the search radius (v = 0 there).
        reply: the squall.v1.BakeVelocityReply.
    """

    SLOTS = ("u", "v", "psi", "fluid")

    def __init__(self, reply: textures_pb2.BakeVelocityReply) -> None:
        super().__init__()
        for slot in self.SLOTS:  # keyed by the reply's field, whatever name the Field carries
            if not reply.HasField(slot):
                continue
            f = getattr(reply, slot)
            self[slot] = field_to_array(f, f"reply.{slot}")
            self.units[slot] = f.unit
            self.spacing[slot] = (f.spacing.x, f.spacing.y, f.spacing.z)
            self.origin[slot] = (f.origin.x, f.origin.y, f.origin.z)
        self.flow_rates: List[float] = list(reply.flow_rates)
        self.left_psi: List[float] = list(reply.left_psi)
        self.right_psi: List[float] = list(reply.right_psi)
        self.obstacle_psi: List[float] = list(reply.obstacle_psi)
        self.undefined_nodes: int = reply.undefined_nodes
        self.reply = reply

    @property
    def u(self) -> NDArray[np.floating[Any]]:
        return self["u"]

    @property
    def v(self) -> NDArray[np.floating[Any]]:
        return self["v"]

    @property
    def fluid(self) -> NDArray[np.floating[Any]]:
        return self["fluid"]

    @property
    def psi(self) -> Optional[NDArray[np.floating[Any]]]:
        return self.get("psi")

    def __repr__(self) -> str:
        return f"BakedVelocity(Q={self.flow_rates}; {self._shapes()})"


class DeformFrame(FieldSet):
    """One frame of a deformed texture (Textures.DeformTexture / DeformInteractive): planes keyed by
    name ("color_<c>", "warp_x", "warp_y", "reference_time", "level", "flow_x", "flow_y"), arrays
    of shape (H, W) (``a[j, i]`` is texel (i, j), centred at (i + 0.5, j + 0.5)).

    Attributes:
        index: frame index, 0 first (the undeformed texture).
        time: index dt, s.
        solver_iterations, solver_residual: the flow solve's iterations and final relative
            residual (the same in every frame).
        max_warp: the largest |W(u) - u|, texels.
        max_residual: the largest residual warp of the stack, texels (max_warp without one).
        min_reference, max_reference: the smallest and largest t* (summed d mu) of a texel.
    """

    def __init__(self, frame: textures_pb2.DeformFrame) -> None:
        super().__init__(frame.planes, "planes")
        self.index: int = frame.index
        self.time: float = frame.time
        self.solver_iterations: int = frame.solver_iterations
        self.solver_residual: float = frame.solver_residual
        self.max_warp: float = frame.max_warp
        self.max_residual: float = frame.max_residual
        self.min_reference: float = frame.min_reference
        self.max_reference: float = frame.max_reference

    def __repr__(self) -> str:
        return f"DeformFrame({self.index}, t={self.time} s, max_warp={self.max_warp}; {self._shapes()})"


class Samples(Dict[str, NDArray[np.float64]]):
    """SampleSurface's answer: one float64 array of shape (n,) per quantity, in point order.

    Keys: "height", "displacement_x", "displacement_y" (m), "normal_x", "normal_y", "normal_z" (1),
    "source_x", "source_y" (m: the sampled surface point before displacement).
    """

    KEYS = (
        "height",
        "displacement_x",
        "displacement_y",
        "normal_x",
        "normal_y",
        "normal_z",
        "source_x",
        "source_y",
    )

    def __init__(self, response: ocean_pb2.SampleSurfaceResponse) -> None:
        super().__init__((k, np.array(getattr(response, k), dtype=np.float64)) for k in self.KEYS)
        self.response = response

    @property
    def position(self) -> NDArray[np.float64]:
        """(n, 3) positions of the sampled surface points (source + displacement, height), m."""
        return np.stack(
            [
                self["source_x"] + self["displacement_x"],
                self["source_y"] + self["displacement_y"],
                self["height"],
            ],
            axis=1,
        )


@dataclass(eq=False)  # compared by identity: == on numpy pixels has no single truth value
class Image:
    """A ray-marched cloud image.

    Attributes:
        pixels: float32 array of shape (height, width, channels), row 0 at the top.
        channels: channel names: "radiance_<i>" per wavelength (W m^-2 sr^-1 m^-1),
            "transmittance_<i>" per wavelength (1), then "depth" (m: where the first wavelength's
            transmittance falls below 0.5; -1 where it stays >= 0.5, thin cloud included).
        summary: the rendered volume's squall.v1.VolumeSummary.
    """

    pixels: NDArray[np.float32]
    channels: Tuple[str, ...]
    summary: Optional[clouds_pb2.VolumeSummary] = None

    @classmethod
    def from_proto(
        cls, image: clouds_pb2.CloudImage, summary: Optional[clouds_pb2.VolumeSummary] = None
    ) -> "Image":
        count = image.width * image.height * len(image.channels)
        if len(image.data) != 4 * count:
            raise ValueError(
                f"image.data has {len(image.data)} bytes, "
                f"want width * height * channels * 4 = {4 * count}"
            )
        planes = np.frombuffer(image.data, dtype="<f4").reshape(
            len(image.channels), image.height, image.width
        )
        pixels = np.ascontiguousarray(planes.transpose(1, 2, 0), dtype=np.float32)
        return cls(pixels, tuple(image.channels), summary)

    def __getitem__(self, channel: str) -> NDArray[np.float32]:
        """One channel by name, shape (height, width); KeyError for a name it does not have."""
        if channel not in self.channels:
            raise KeyError(f"{channel!r}: the image's channels are {', '.join(self.channels)}")
        return self.pixels[:, :, self.channels.index(channel)]

    def __array__(
        self, dtype: Optional[np.dtype[Any]] = None, copy: Optional[bool] = None
    ) -> NDArray[Any]:
        """The pixels, for np.asarray (NumPy 2's copy: True always copies, False never)."""
        converts = dtype is not None and np.dtype(dtype) != self.pixels.dtype
        if copy is False and converts:
            raise ValueError(f"the pixels are {self.pixels.dtype}: {dtype} needs a copy")
        if converts:
            return self.pixels.astype(dtype)
        return self.pixels.copy() if copy else self.pixels

    @property
    def shape(self) -> Tuple[int, ...]:
        return self.pixels.shape

    def __iter__(self) -> Iterator[str]:
        return iter(self.channels)


@dataclass
class Volume:
    """A built cloud volume.

    Attributes:
        summary: squall.v1.VolumeSummary (bounds m, voxel size m, active voxels, bytes, ...).
        vdb: the grids ("density", and "temperature" when modeled) as .vdb file bytes, if asked.
    """

    summary: clouds_pb2.VolumeSummary
    vdb: Optional[bytes] = None

    @property
    def id(self) -> Optional[str]:
        """The volume id when it is stored on the server (keep=True), else None."""
        return self.summary.volume_id or None


@dataclass
class EvolutionFrame:
    """One frame of Clouds.StreamEvolution: time (s), image, summary, .vdb bytes if asked."""

    time: float
    image: Image
    summary: clouds_pb2.VolumeSummary
    vdb: Optional[bytes] = field(default=None)
