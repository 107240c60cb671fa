"""eWave sessions (squall.v1.EWave): stateful interactive waves driven by obstructions and sources.

A session holds the height h and velocity potential phi on an nx x ny periodic grid; each step
advances it by dt through obstructions (maps and shapes), sources, an ambient sea, a drift current
and the edge trim (J. Tessendorf, "Gilligan" (2017) sec. 3 and App B, "eWave"). Grid frame: cell
(i, j) has its centre at ((i + 0.5) dx, (j + 0.5) dy), m. Per-cell input maps are arrays of shape
(ny, nx).

Example::

    with client.ewave.session(nx=128, ny=64, dx=0.01, source_scale=1.0) as session:
        hull = squall.ewave.ellipse(0.3, 0.32, 0.12, 0.04)
        frame = session.step(0.05, shapes=[hull], outputs=("height", "phi"))
        frame["height"].shape   # (64, 128), m
"""

from __future__ import annotations

import inspect
import os
from functools import partial
from typing import Any, Callable, Dict, Iterable, Mapping, Optional, Sequence, Tuple, Union

import grpc
import numpy as np

from squall._calls import Connection, RequestFeeder, Stream, Undo
from squall._convert import (
    UINT32_MAX,
    UINT64_MAX,
    ArrayLike,
    FieldLike,
    byte_string,
    dtype_value,
    enum_value,
    float_array,
    floats,
    integer,
    items_of,
    message_from,
    number,
    sequence,
    shown,
    to_field,
    to_message,
    vec3,
)
from squall._errors import SquallError
from squall._pb import ewave_pb2, ewave_pb2_grpc, rpc_client
from squall._results import EWaveFrame
from squall.ocean import TileLike, as_tile_spec

EWaveConfig = ewave_pb2.EWaveConfig
EWaveInputs = ewave_pb2.EWaveInputs
ShapeLike = Union[ewave_pb2.EWaveShape, Mapping[str, Any]]
InputsLike = Union[ewave_pb2.EWaveInputs, ewave_pb2.EWaveStepRequest, Mapping[str, Any], float]

__all__ = [
    "config",
    "inputs",
    "circle",
    "ellipse",
    "box",
    "polygon",
    "EWave",
    "EWaveSession",
    "EWaveFrame",
]


def config(
    nx: int,
    ny: int,
    dx: float,
    dy: Optional[float] = None,
    *,
    dispersion: Union[str, int, None] = None,
    gravity: Optional[float] = None,
    depth: float = 0.0,
    capillary_length: float = 0.0,
    trim: Optional[bool] = None,
    trim_width: float = 0.0,
    trim_alpha: Optional[float] = None,
    friction_time: float = 0.0,
    source_scale: float = 0.0,
    mask_phi: bool = False,
    double_precision: bool = False,
    displacement_scale: Optional[float] = None,
    initial_height: Optional[FieldLike] = None,
    initial_phi: Optional[FieldLike] = None,
    start_time: Optional[float] = None,
    initial_ocean: Optional[TileLike] = None,
    ambient_ocean: Optional[TileLike] = None,
) -> ewave_pb2.EWaveConfig:
    """A session's grid and physics (fixed for the session's life). None: the proto's default.

    Args:
        nx, ny: grid cells along x and y, each >= 2 (any size); nx * ny at most --max-grid-cells.
        dx, dy: cell size, m, in [1e-6, 1e6]; dy None: dx.
        dispersion: "deep" (default), "shallow", "capillary", "combined".
        gravity: g, m/s^2, in (0, 1000]; unset: 9.81.
        depth: water depth, m, at most 1e5: > 0 with shallow or combined dispersion (the default
            0 suits deep and capillary only).
        capillary_length: capillary / combined dispersion, m, in [0, 1] (water: about 2.7e-3).
        trim: the power-law taper at the edges (eq 82); unset: True.
        trim_width: taper width L, m; 0: 8% of the shorter side.
        trim_alpha: taper exponent, (0, 10]; unset: 0.05.
        friction_time: relaxation time tau (eqs 72-73), s; 0: no friction.
        source_scale: S0 of eq 75, m/s: the obstruction is also a height source S0 (1 - O).
        mask_phi: also multiply phi by the obstruction (bounds ``dt`` as the trim does).
        double_precision: keep h, phi and the FFTs in float64 (needs an fp64 device).
        displacement_scale: lambda of the horizontal displacement and normals; unset: 1.
        initial_height: h at the start, m: array (ny, nx); unset: zero.
        initial_phi: phi at the start, m^2/s: array (ny, nx); unset: zero.
        start_time: the session's time before its first step, s; unset: 0.
        initial_ocean: start from an ocean tile (h and its linear-theory phi); exclusive with
            initial_height / initial_phi.
        ambient_ocean: ambient sea h_A from an ocean tile, evaluated every step that brings none.
    """
    dx = number(dx, "config.dx")  # nx, ny and dx have no default: None is refused, not sent as 0
    return message_from(
        ewave_pb2.EWaveConfig,
        None,
        "config",
        nx=integer(nx, "config.nx", 0, UINT32_MAX),
        ny=integer(ny, "config.ny", 0, UINT32_MAX),
        dx=dx,
        dy=dx if dy is None else dy,
        dispersion=dispersion,
        gravity=gravity,
        depth=depth,
        capillary_length=capillary_length,
        trim=trim,
        trim_width=trim_width,
        trim_alpha=trim_alpha,
        friction_time=friction_time,
        source_scale=source_scale,
        mask_phi=mask_phi,
        double_precision=double_precision,
        displacement_scale=displacement_scale,
        initial_height=(
            None if initial_height is None else to_field(initial_height, "config.initial_height")
        ),
        initial_phi=None if initial_phi is None else to_field(initial_phi, "config.initial_phi"),
        start_time=start_time,
        initial_ocean=(
            None if initial_ocean is None else as_tile_spec(initial_ocean, "config.initial_ocean")
        ),
        ambient_ocean=(
            None if ambient_ocean is None else as_tile_spec(ambient_ocean, "config.ambient_ocean")
        ),
    )


def _numbers(shape: str, **values: Any) -> Dict[str, float]:
    """A shape's arguments, each a number (TypeError naming "<shape>.<argument>" else)."""
    return {name: number(value, f"{shape}.{name}") for name, value in values.items()}


def circle(center_x: float, center_y: float, radius: float) -> ewave_pb2.EWaveShape:
    """A circular obstruction: centre (m, grid frame) and radius (m, > 0)."""
    values = _numbers("circle", center_x=center_x, center_y=center_y, radius=radius)
    return ewave_pb2.EWaveShape(circle=ewave_pb2.EWaveCircle(**values))


def ellipse(
    center_x: float, center_y: float, semi_axis_a: float, semi_axis_b: float, heading: float = 0.0
) -> ewave_pb2.EWaveShape:
    """An elliptic obstruction (a hull): centre (m), semi-axes along / across the heading (m, > 0),
    heading (rad, counter-clockwise from +x)."""
    values = _numbers(
        "ellipse",
        center_x=center_x,
        center_y=center_y,
        semi_axis_a=semi_axis_a,
        semi_axis_b=semi_axis_b,
        heading=heading,
    )
    return ewave_pb2.EWaveShape(ellipse=ewave_pb2.EWaveEllipse(**values))


def box(
    center_x: float, center_y: float, half_length: float, half_width: float, heading: float = 0.0
) -> ewave_pb2.EWaveShape:
    """A rectangular obstruction: centre (m), half extents along / across the heading (m, > 0),
    heading (rad)."""
    values = _numbers(
        "box",
        center_x=center_x,
        center_y=center_y,
        half_length=half_length,
        half_width=half_width,
        heading=heading,
    )
    return ewave_pb2.EWaveShape(box=ewave_pb2.EWaveBox(**values))


def polygon(vertices: ArrayLike) -> ewave_pb2.EWaveShape:
    """A polygonal obstruction: vertices (n, 2) in m (grid frame), either winding, n >= 3."""
    points = float_array(vertices, "polygon.vertices", "vertices of shape (n, 2), m")
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise ValueError(f"polygon: want vertices of shape (n, 2), got {points.shape}")
    return ewave_pb2.EWaveShape(polygon=ewave_pb2.EWavePolygon(vertices=[vec3(p) for p in points]))


def inputs(
    dt: float,
    *,
    obstruction: Optional[FieldLike] = None,
    shapes: Sequence[ShapeLike] = (),
    ambient_height: Optional[FieldLike] = None,
    ambient_ocean: Optional[TileLike] = None,
    source_height: Optional[FieldLike] = None,
    source_phi: Optional[FieldLike] = None,
    drift: Sequence[float] = (0.0, 0.0),
    drift_field: Optional[Tuple[FieldLike, FieldLike]] = None,
    outputs: Union[str, Sequence[Union[str, int]]] = ("height",),
    dtype: Any = "float32",
) -> ewave_pb2.EWaveInputs:
    """What acts on the surface during one step. Maps are arrays of shape (ny, nx), float32 or
    float16.

    Args:
        dt: time step, s, in (0, 1e4] (the propagator is exact; with the trim or mask_phi on, at
            most the period of the grid's shortest wave).
        obstruction: O per cell: 1 open water, 0 solid, between: partial; unset: 1.
        shapes: obstruction shapes rasterized into O (``circle``, ``ellipse``, ``box``,
            ``polygon``), at most 1024.
        ambient_height: ambient sea h_A, m, subtracted where obstructed.
        ambient_ocean: the ambient sea as an ocean tile (exclusive with ambient_height).
        source_height: height source S_h (eq 60), m/s.
        source_phi: potential source S_phi (eq 61), m^2/s^2.
        drift: uniform drift current (U_D,x, U_D,y), m/s, when no drift_field is given.
        drift_field: per-cell drift current (u, v), m/s, two arrays (ny, nx).
        outputs: fields the frame returns, in this order: "height", "displacement_x",
            "displacement_y" (m), "normal_x", "normal_y", "normal_z" (1), "phi" (m^2/s).
        dtype: "float32" or "float16" for the returned fields.
    """
    if isinstance(outputs, (str, int, np.integer)):
        outputs = [outputs]
    drift_x, drift_y = floats(drift, "inputs.drift", "a pair (U_D,x, U_D,y), m/s", (2,))
    shape_items = sequence(shapes, "inputs.shapes", "a sequence of shapes")
    output_items = sequence(outputs, "inputs.outputs", "an output name or a sequence of them")
    message = message_from(
        ewave_pb2.EWaveInputs,
        None,
        "inputs",
        dt=dt,
        obstruction=None if obstruction is None else to_field(obstruction, "inputs.obstruction"),
        shapes=[
            to_message(ewave_pb2.EWaveShape, s, f"inputs.shapes[{i}]")
            for i, s in enumerate(shape_items)
        ],
        ambient_height=(
            None if ambient_height is None else to_field(ambient_height, "inputs.ambient_height")
        ),
        ambient_ocean=(
            None if ambient_ocean is None else as_tile_spec(ambient_ocean, "inputs.ambient_ocean")
        ),
        source_height=(
            None if source_height is None else to_field(source_height, "inputs.source_height")
        ),
        source_phi=None if source_phi is None else to_field(source_phi, "inputs.source_phi"),
        drift_x=drift_x,
        drift_y=drift_y,
        outputs=[
            enum_value(ewave_pb2.EWaveOutput.DESCRIPTOR, o, f"inputs.outputs[{i}]")
            for i, o in enumerate(output_items)
        ],
        dtype=dtype_value(dtype, "inputs.dtype"),
    )
    if drift_field is not None:
        want = "a pair (u, v) of arrays (ny, nx), m/s"
        u, v = items_of(drift_field, "inputs.drift_field", (2,), want)
        message.drift_field_x.CopyFrom(to_field(u, "inputs.drift_field_x"))
        message.drift_field_y.CopyFrom(to_field(v, "inputs.drift_field_y"))
    return message


_INPUTS_ARGUMENTS = frozenset(inspect.signature(inputs).parameters)


def as_config(value: Any = None, **kwargs: Any) -> ewave_pb2.EWaveConfig:
    """An EWaveConfig from a message / mapping of its fields, or from ``config``'s keyword
    arguments.
    """
    if value is not None:
        if kwargs:
            raise TypeError("session: pass either a config or its keyword arguments, not both")
        return to_message(ewave_pb2.EWaveConfig, value, "config")
    return config(**kwargs)


def as_inputs(
    value: Any = None, dt: Optional[float] = None, **kwargs: Any
) -> ewave_pb2.EWaveInputs:
    """EWaveInputs from a message or mapping of its fields, a number (dt), or ``inputs``'
    arguments.
    """
    if value is None:
        if dt is None:
            raise TypeError("step: dt (s, > 0) is required")
        return inputs(dt, **kwargs)
    if kwargs or dt is not None:
        raise TypeError("step: pass either inputs or dt and keyword arguments, not both")
    if isinstance(value, (bool, np.bool_)):  # True is an int, but no dt of 1 s
        raise TypeError(f"inputs.dt = {shown(value)}: want a number")
    if isinstance(value, (int, float, np.integer, np.floating)):
        return inputs(float(value))
    if isinstance(value, Mapping) and set(value) <= _INPUTS_ARGUMENTS:
        return inputs(**value)  # inputs()' keyword arguments (drift=..., drift_field=...)
    return to_message(ewave_pb2.EWaveInputs, value, "inputs")  # the message's own fields


def step_request(session_id: str, item: InputsLike, index: int = 0) -> ewave_pb2.EWaveStepRequest:
    """The EWaveStepRequest of one item of ``run``: an EWaveStepRequest (its own session_id, else
    this session's), EWaveInputs, a mapping of ``inputs``' keyword arguments, or a dt in s."""
    if isinstance(item, ewave_pb2.EWaveStepRequest):
        if item.session_id:
            return item
        request = ewave_pb2.EWaveStepRequest()
        request.CopyFrom(item)
        request.session_id = session_id
        return request
    return ewave_pb2.EWaveStepRequest(session_id=session_id, inputs=as_inputs(item))


def unary_step_request(
    session_id: str,
    inputs: ewave_pb2.EWaveInputs,
    after_step: Optional[int] = None,
    retry_key: Optional[bytes] = None,
) -> ewave_pb2.EWaveStepRequest:
    """The EWaveStepRequest of ``step``: its retry_key (None: a fresh one, 16 random bytes), which
    gRPC's retries of the call send again, so that a step whose reply was lost is made once; and
    after_step if given."""
    return ewave_pb2.EWaveStepRequest(
        session_id=session_id,
        inputs=inputs,
        retry_key=os.urandom(16) if retry_key is None else byte_string(retry_key, "retry_key"),
        after_step=(
            None if after_step is None else integer(after_step, "after_step", 0, UINT64_MAX)
        ),
    )


def close_call(rpc: Any, session_id: str) -> Undo:
    """Connection.create's `undo` for a new session: what closes `session_id`.

    The undo is a triple: the method's name ("EWave.CloseSession"), the connection's
    CloseSession callable (`rpc.CloseSession`) and an EWaveSessionRequest for `session_id`.
    """
    request = ewave_pb2.EWaveSessionRequest(session_id=session_id)
    return ("EWave.CloseSession", rpc.CloseSession, request)


def restore_request(state: Any) -> ewave_pb2.EWaveRestoreRequest:
    """The Restore of `state`: the bytes of a ``state()`` snapshot, or any buffer of them (a
    number, which bytes() makes that many zero bytes, is a TypeError)."""
    try:
        view = memoryview(state)
    except TypeError:
        kind = type(state).__name__
        raise TypeError(f"state must be the bytes of a state() snapshot, not {kind}") from None
    return ewave_pb2.EWaveRestoreRequest(state=bytes(view))


def close_quietly(close: Callable[[], None], exc_type: Any) -> None:
    """``close()`` at the end of a ``with`` block: while the block's exception propagates, a
    SquallError of the close (squalld gone, the deadline passed) would hide it and is dropped."""
    if exc_type is None:
        close()
        return
    try:
        close()
    except SquallError:
        pass


def attached(session_id: str, config: Any) -> ewave_pb2.EWaveSessionResponse:
    """What ``attach`` knows of a session: its id (a str) and the config given, if any."""
    if not isinstance(session_id, str):
        raise TypeError(f"session_id = {shown(session_id)}: want a session id (str)")
    known = to_message(ewave_pb2.EWaveConfig, config, "config")
    return ewave_pb2.EWaveSessionResponse(session_id=session_id, config=known)


def session_shape(config: ewave_pb2.EWaveConfig) -> Tuple[int, int]:
    """(ny, nx) of a session's config; ValueError when the config is not known (no grid)."""
    if config.nx == 0 or config.ny == 0:
        raise ValueError(
            "the session's grid is not known here: pass its config to attach(session_id, config)"
        )
    return (config.ny, config.nx)


class EWaveSession:
    """One eWave session (sync). A context manager: leaving the ``with`` block closes the session.

    Attributes:
        id: the session id (32 hex digits): a bearer secret, whoever holds it can drive the
            session.
        config: the EWaveConfig in force (defaults filled in); for a session from ``attach``,
            the config given to it (empty when none was).
        max_dt: the longest step, s: with the trim or mask_phi on, the period of the grid's
            shortest wave (longer steps then grow without bound); 0 for a session from ``attach``
            (unknown).
        steps: the steps the session had made when this object last heard: 0 after ``create``,
            the saved state's after ``restore``, then each ``step()``'s frame's; a ``step(...,
            after_step=session.steps)`` fails when another caller has stepped it since. 0 for a
            session from ``attach``; frames of ``run`` carry their own ``step``.
        last_retry_key: the retry key of the last ``step()`` sent (None before the first): the
            same key reads that step's frame again, where the step was made but its call raised.
    """

    def __init__(self, service: "EWave", response: ewave_pb2.EWaveSessionResponse) -> None:
        self._service = service
        self.id: str = response.session_id
        self.config: ewave_pb2.EWaveConfig = response.config
        self.max_dt: float = response.max_dt
        self.steps: int = response.step
        self.last_retry_key: Optional[bytes] = None
        self.closed = False

    @property
    def shape(self) -> Tuple[int, int]:
        """(ny, nx): the shape of the session's fields and input maps (ValueError for an
        ``attach`` given no config)."""
        return session_shape(self.config)

    def step(
        self,
        dt: Optional[float] = None,
        *,
        inputs: Optional[Union[ewave_pb2.EWaveInputs, Mapping[str, Any]]] = None,
        after_step: Optional[int] = None,
        retry_key: Optional[bytes] = None,
        timeout: Optional[float] = None,
        **kwargs: Any,
    ) -> EWaveFrame:
        """Advances the session by one step and returns the fields after it (EWave.Step). The
        request carries a retry key, so the client's own retries of it make one step.

        Args:
            dt: time step, s; the other keyword arguments are those of ``squall.ewave.inputs``
                (obstruction, shapes, source_height, ..., outputs, dtype).
            inputs: instead of dt and keywords: EWaveInputs (or a mapping of its fields).
            after_step: the step count the session must be at (the ``step`` of the last frame
                this caller saw): SquallError ABORTED, the session unchanged, when another
                caller has stepped it since. None: no check.
            retry_key: up to 64 bytes naming this step; None: a fresh random key. A caller that
                may try a step() again after it raised (DEADLINE_EXCEEDED, UNAVAILABLE after the
                retries) passes a key of its own, and the same key again: the step is made once.
                The key sent is kept as ``last_retry_key``: a step() that raised after the step
                was made (a frame too wide for float16) reads that frame with it.
        """
        request = unary_step_request(
            self.id, as_inputs(inputs, dt, **kwargs), after_step, retry_key
        )
        self.last_retry_key = request.retry_key
        conn = self._service._connection
        frame = EWaveFrame(
            conn.unary("EWave.Step", self._service._rpc.Step, request, timeout, session=self.id)
        )
        self.steps = frame.step
        return frame

    def run(
        self, items: Iterable[InputsLike], *, timeout: Optional[float] = None
    ) -> Stream[EWaveFrame]:
        """Steps over the bidirectional Run stream: one frame per item, in order.

        Args:
            items: an iterable (may be a generator) of EWaveInputs, mappings of ``inputs``' keyword
                arguments, dt values (s), or EWaveStepRequests (which may name another session: the
                stream is routed by this session's id, so behind a session-affine proxy in front of
                several replicas only this session's are sure to be found). Items are read as
                frames are taken, at most 2 ahead of them: a caller that stops after its n-th frame
                (leaves the loop, cancels) has had at most n + 2 steps applied by the stream.

        Returns:
            An iterator of EWaveFrames; it holds one --max-streams slot until it ends or is
            cancelled. A failing step ends it with a SquallError naming the message
            ("Run message 3: ..."). An exception raised by `items` (or by converting an item)
            ends the requests and is raised by the iterator once the call has ended: from that
            SquallError (its ``__cause__``) when a step failed too.
        """
        feeder = RequestFeeder(items, lambda item, i: step_request(self.id, item, i))
        conn = self._service._connection
        return conn.stream(
            "EWave.Run", self._service._rpc.Run, feeder, EWaveFrame, timeout, self.id, feeder
        )

    def state(self, *, timeout: Optional[float] = None) -> bytes:
        """The whole session (config, step, time, h, phi) as opaque bytes for ``EWave.restore``."""
        request = ewave_pb2.EWaveSessionRequest(session_id=self.id)
        conn = self._service._connection
        reply: ewave_pb2.EWaveStateResponse = conn.unary(
            "EWave.GetState", self._service._rpc.GetState, request, timeout, self.id
        )
        return reply.state

    def restore(self, state: bytes, *, timeout: Optional[float] = None) -> "EWaveSession":
        """A new session continuing `state` (from ``state()`` of this or another session); this one
        stays.
        """
        return self._service.restore(state, timeout=timeout)

    def close(self, *, timeout: Optional[float] = None) -> None:
        """Ends the session on the server (its id is NOT_FOUND afterwards).

        Idempotent, the rule of ``Clouds.release``: a session already gone (NOT_FOUND) counts as
        closed. A first attempt may have closed it and had its answer lost (the connection broke
        after squalld acted), the client's retry policy sending it again to find it gone; or it
        was closed elsewhere, or evicted after --session-ttl idle. An id never made (``attach`` of a
        typo) is not told apart from these. Any other error raises SquallError, the session
        perhaps still live, and ``closed`` stays False.
        """
        if self.closed:
            return
        request = ewave_pb2.EWaveSessionRequest(session_id=self.id)
        conn = self._service._connection
        try:
            conn.unary(
                "EWave.CloseSession", self._service._rpc.CloseSession, request, timeout, self.id
            )
        except SquallError as error:
            if error.code != grpc.StatusCode.NOT_FOUND:
                raise
        self.closed = True

    def __enter__(self) -> "EWaveSession":
        return self

    def __exit__(self, exc_type: Any, *exc: Any) -> None:
        close_quietly(self.close, exc_type)

    def __repr__(self) -> str:
        return f"EWaveSession({self.id[:8]}..., {self.config.nx} x {self.config.ny})"


class EWave:
    """``client.ewave``: the EWave service (sessions, steps, the Run stream, state and restore)."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = rpc_client(ewave_pb2_grpc.EWaveStub, connection.channel)

    def session(
        self,
        config: Optional[Union[ewave_pb2.EWaveConfig, Mapping[str, Any]]] = None,
        *,
        timeout: Optional[float] = None,
        **kwargs: Any,
    ) -> EWaveSession:
        """Creates a session (CreateSession) from an EWaveConfig, or from the keyword arguments
        of ``squall.ewave.config`` (nx, ny, dx, ...). A ``with`` block closes it at the end."""
        request = ewave_pb2.EWaveCreateSessionRequest(config=as_config(config, **kwargs))
        undo = partial(close_call, self._rpc)
        response = self._connection.create(
            "EWave.CreateSession", self._rpc.CreateSession, request, timeout, "", undo
        )
        return EWaveSession(self, response)

    def restore(self, state: bytes, *, timeout: Optional[float] = None) -> EWaveSession:
        """A new session (new id) continuing a ``state()`` snapshot bit-identically (Restore)."""
        request = restore_request(state)
        undo = partial(close_call, self._rpc)
        response = self._connection.create(
            "EWave.Restore", self._rpc.Restore, request, timeout, "", undo
        )
        return EWaveSession(self, response)

    def attach(
        self, session_id: str, config: Optional[ewave_pb2.EWaveConfig] = None
    ) -> EWaveSession:
        """A handle on an existing session id (e.g. from another process); nothing is sent. No
        RPC returns a live session's config: without `config`, ``shape`` raises ValueError."""
        return EWaveSession(self, attached(session_id, config))
