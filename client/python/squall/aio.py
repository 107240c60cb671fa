"""squall.aio: the asyncio flavour of squall.Client (grpc.aio), with async iterators for the
streams.

The same arguments and results as the synchronous client; every call is awaited, every stream is an
async iterator. Create the client inside a running event loop::

    import asyncio, squall, squall.aio

    async def main():
        async with squall.aio.Client("127.0.0.1:50051") as client:
            spec = squall.ocean.tile_spec([squall.ocean.layer(extent=200, n=64)])
            tile = await client.ocean.tile(spec, time=1.0)
            async for frame in client.ocean.stream(spec, dt=0.1, frames=10):
                print(frame.time, frame["height"].std())
            async with client.ewave.session(nx=64, ny=64, dx=0.05) as session:
                frame = await session.step(0.05)

    asyncio.run(main())
"""

from __future__ import annotations

import asyncio
import time
import weakref
from functools import partial
from typing import (
    Any,
    AsyncIterable,
    AsyncIterator,
    Awaitable,
    Callable,
    Generator,
    Generic,
    Iterable,
    Iterator,
    List,
    Mapping,
    Optional,
    Sequence,
    Tuple,
    TypeVar,
    Union,
)

import grpc
import grpc.aio

from squall import clouds as _clouds
from squall import ewave as _ewave
from squall import ocean as _ocean
from squall import textures as _textures
from squall._calls import (
    DEFAULT_ADDRESS,
    RUN_AHEAD,
    UNDO_TIMEOUT,
    UNDONE,
    Resends,
    Settings,
    Undo,
    address_of,
    propose_session_id,
    raise_feeder_error,
    resolve_token,
    warn_plaintext_token,
)
from squall._errors import SquallError
from squall._pb import (
    clouds_pb2,
    clouds_pb2_grpc,
    ewave_pb2,
    ewave_pb2_grpc,
    ocean_pb2,
    ocean_pb2_grpc,
    rpc_client,
    server_pb2,
    server_pb2_grpc,
    textures_pb2,
    textures_pb2_grpc,
)
from squall._results import (
    BakedVelocity,
    DeformFrame,
    EvolutionFrame,
    EWaveFrame,
    Image,
    Samples,
    TextureFrame,
    Tile,
    Volume,
)
from squall.client import (
    HEALTH_CHECK,
    channel_options,
    decode_health_response,
    encode_health_request,
    health_service,
)

T = TypeVar("T")
S = TypeVar("S", bound="Steering[Any]")

__all__ = ["Client", "AsyncStream", "EWaveSession", "Interactive", "DeformInteractive"]


def _cancelling() -> Optional[bool]:
    """Whether the running task is being cancelled (``Task.cancelling()``, Python 3.11 and later);
    None where asyncio cannot tell."""
    task = asyncio.current_task()
    cancelling = getattr(task, "cancelling", None)
    if cancelling is None:
        return None
    return bool(cancelling() > 0)


def _cancelled_call(closed: bool, method: str) -> Optional[SquallError]:
    """The error of a call that raised asyncio.CancelledError: grpc.aio raises it for a call
    cancelled in this process, as ``Client.close()`` does to every call in flight. When the
    awaiting task is not itself being cancelled, the call's end is reported as the sync client
    reports it: SquallError (CANCELLED) naming the method. None when the task is being cancelled
    (its CancelledError must propagate), and, where asyncio cannot tell (before Python 3.11),
    unless the client was closed (`closed`)."""
    cancelling = _cancelling()
    if cancelling or (cancelling is None and not closed):
        return None
    reason = "the client was closed" if closed else "the call was cancelled"
    return SquallError(grpc.StatusCode.CANCELLED, f"client: {reason}", method)


class Connection:
    """An asyncio channel and the client's Settings; runs calls and raises SquallError."""

    def __init__(self, channel: grpc.aio.Channel, settings: Settings) -> None:
        self.channel = channel
        self.settings = settings
        self._streams: "weakref.WeakSet[Any]" = weakref.WeakSet()

    def track(self, call: Any) -> Any:
        """Registers a streaming call, which ``cancel_streams`` ends; returns it."""
        self._streams.add(call)
        return call

    def cancel_streams(self) -> None:
        """Cancels the streaming calls still running. grpc.aio's channel.close() cancels the calls
        it finds waiting in a task of their own (unary calls, streams not yet started), not the
        streams already running, which would otherwise go on after the client is closed."""
        for call in list(self._streams):
            call.cancel()

    async def unary(
        self,
        method: str,
        function: Callable[..., Any],
        request: Any,
        timeout: Optional[float] = None,
        session: Optional[str] = None,
    ) -> Any:
        """function(request) within the call's deadline, sent again while it is cancelled
        unanswered (Resends)."""
        sends = Resends(self.settings, self.settings.deadline(timeout, stream=False))
        while True:
            metadata = self.settings.metadata(session)  # RuntimeError once the client is closed
            try:
                return await function(request, timeout=sends.timeout(), metadata=metadata)
            except grpc.RpcError as error:
                pause = sends.pause(error, method)
            except asyncio.CancelledError:
                cancelled = _cancelled_call(self.settings.closed, method)
                if cancelled is None:
                    raise
                raise cancelled from None
            await asyncio.sleep(pause)

    async def create(
        self,
        method: str,
        function: Callable[..., Any],
        request: Any,
        timeout: Optional[float],
        prefix: str,
        undo: Callable[[str], Undo],
    ) -> Any:
        """squall._calls.Connection.create, awaited."""

        async def once() -> Any:
            proposed = propose_session_id(prefix)
            try:
                return await self.unary(method, function, request, timeout, session=proposed)
            except SquallError as error:
                if error.code in UNDONE:
                    try:
                        await self.unary(*undo(proposed), UNDO_TIMEOUT, session=proposed)
                    except Exception:  # never made, squalld unreachable or the client closed:
                        pass  # the session's idle TTL ends it
                raise

        try:
            return await once()
        except SquallError as error:
            if error.code != grpc.StatusCode.ALREADY_EXISTS:
                raise
        return await once()

    def stream(
        self,
        method: str,
        function: Callable[..., Any],
        request: Any,
        convert: Callable[[Any], Optional[T]],
        timeout: Optional[float] = None,
        session: Optional[str] = None,
        feeder: Any = None,
        finish: Optional[Callable[[], None]] = None,
    ) -> "AsyncStream[T]":
        call = function(
            request,
            timeout=self.settings.deadline(timeout, stream=True),
            metadata=self.settings.metadata(session),
        )
        self.track(call)
        return AsyncStream(call, method, convert, feeder, finish, self.settings)


class AsyncStream(AsyncIterator[T], Generic[T]):
    """An async iterator over a streaming call's messages, converted (numpy arrays).

    ``cancel()`` (or leaving an ``async with`` block around it, or dropping the last reference to
    it, as after ``break`` in ``async for``) ends the call and frees its --max-streams slot; errors
    raise SquallError while iterating, CANCELLED when the client is closed under it. `convert` and
    `finish` are as squall._calls.Stream's; `settings` are the client's (whether it was closed).
    """

    def __init__(
        self,
        call: Any,
        method: str,
        convert: Callable[[Any], Optional[T]],
        feeder: Any = None,
        finish: Optional[Callable[[], None]] = None,
        settings: Optional[Settings] = None,
    ) -> None:
        self._call = call
        self._iterator = call.__aiter__()
        self._method = method
        self._convert = convert
        self._cancelled = False
        self._feeder = feeder
        self._finish = finish
        self._settings = settings

    def __aiter__(self) -> "AsyncStream[T]":
        return self

    def _end_feeder(self, failed: Optional[SquallError] = None) -> None:
        """The call has ended: the feeder stops waiting; its error, if any, is raised (see
        squall._calls.raise_feeder_error)."""
        if self._feeder is None:
            return
        self._feeder.close()
        raise_feeder_error(self._feeder, failed)

    async def __anext__(self) -> T:
        while True:
            try:
                message = await self._iterator.__anext__()
            except StopAsyncIteration:
                self._end_feeder()
                if self._finish is not None:
                    self._finish()
                raise
            except asyncio.CancelledError:
                if self._cancelled and not _cancelling():
                    raise StopAsyncIteration from None
                closed = self._settings is not None and self._settings.closed
                cancelled = _cancelled_call(closed, self._method)
                if cancelled is None:
                    raise
                if self._feeder is not None:
                    self._feeder.close()
                raise cancelled from None
            except grpc.RpcError as error:
                if self._cancelled and error.code() == grpc.StatusCode.CANCELLED:
                    self._end_feeder()
                    raise StopAsyncIteration from None
                failed = SquallError.from_rpc(error, self._method)
                self._end_feeder(failed)
                raise failed from None
            try:
                item = self._convert(message)
            except BaseException:
                self.cancel()  # the server would stream on, holding its --max-streams slot
                raise
            if item is not None:
                if self._feeder is not None:
                    self._feeder.taken()
                return item

    def cancel(self) -> None:
        """Ends the call now (no-op when it already ended); iteration then stops."""
        self._cancelled = True
        self._call.cancel()
        if self._feeder is not None:
            self._feeder.close()

    close = cancel

    async def __aenter__(self) -> "AsyncStream[T]":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        self.cancel()

    def __del__(self) -> None:
        # As squall._calls.Stream's: grpc.aio's call is held by reference cycles (its response
        # generator, its request task) and would keep the server's stream slot until the garbage
        # collector finds them. Call.cancel() is synchronous (a no-op on an ended call); the loop
        # may be gone by now, hence the quiet excepts.
        try:
            self._call.cancel()
        except Exception:
            pass
        try:
            if self._feeder is not None:
                self._feeder.close()
        except Exception:  # __init__ failed early, or the loop is closed
            pass


def _awaitable_next(items: Iterator[Any]) -> Callable[[], Awaitable[Any]]:
    """next(items) as a coroutine function, StopAsyncIteration at the end (as __anext__)."""

    async def pull() -> Any:
        try:
            return next(items)
        except StopIteration:
            raise StopAsyncIteration from None

    return pull


class _AsyncFeeder:
    """The request side of a bidirectional call from a (sync or async) iterable: RequestFeeder,
    at most `ahead` items read beyond the replies the AsyncStream has returned."""

    def __init__(
        self,
        items: Union[Iterable[Any], AsyncIterable[Any]],
        convert: Callable[[Any, int], Any],
        ahead: int = RUN_AHEAD,
    ) -> None:
        self._items = items
        self._convert = convert
        self._window = asyncio.Semaphore(ahead)  # created in the loop that runs the call
        self._closed = False
        self.error: Optional[BaseException] = None

    def taken(self) -> None:
        """The caller took one reply: one more item may be read."""
        self._window.release()

    def close(self) -> None:
        """The call has ended: no more items are read, and the request task stops waiting."""
        self._closed = True
        self._window.release()

    async def __aiter__(self) -> AsyncIterator[Any]:
        pull: Callable[[], Awaitable[Any]]
        if hasattr(self._items, "__aiter__"):
            pull = self._items.__aiter__().__anext__
        else:
            pull = _awaitable_next(iter(self._items))
        index = 0
        try:
            while True:
                await self._window.acquire()
                if self._closed:
                    return
                try:
                    item = await pull()
                except StopAsyncIteration:
                    return
                yield self._convert(item, index)
                index += 1
        except Exception as error:  # handed to the reading side
            self.error = error


class Ocean:
    """``client.ocean`` (asyncio): squall.ocean.Ocean, awaited; ``stream`` is an async iterator."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = rpc_client(ocean_pb2_grpc.OceanStub, connection.channel)

    async def tile(
        self,
        spec: Optional[_ocean.TileLike] = None,
        *,
        time: float = 0.0,
        outputs: Union[str, _ocean.Outputs] = ("height",),
        dtype: Any = "float32",
        timeout: Optional[float] = None,
        request: Optional[ocean_pb2.GetTileRequest] = None,
    ) -> Tile:
        """One tile at time t, s (see squall.ocean.Ocean.tile)."""
        message = _ocean.tile_request(spec, time, outputs, dtype, request)
        return Tile(
            await self._connection.unary("Ocean.GetTile", self._rpc.GetTile, message, timeout)
        )

    def stream(
        self,
        spec: Optional[_ocean.TileLike] = None,
        *,
        dt: Optional[float] = None,
        frames: int = 0,
        t0: float = 0.0,
        outputs: Union[str, _ocean.Outputs] = ("height",),
        dtype: Any = "float32",
        timeout: Optional[float] = None,
        request: Optional[ocean_pb2.StreamTilesRequest] = None,
    ) -> AsyncStream[Tile]:
        """Frames at t0 + k dt (s), reassembled from their chunks (squall.ocean.Ocean.stream)."""
        message = _ocean.stream_request(spec, dt, frames, t0, outputs, dtype, request)
        assembler = _ocean.TileAssembler()
        return self._connection.stream(
            "Ocean.StreamTiles",
            self._rpc.StreamTiles,
            message,
            assembler.add,
            timeout,
            finish=assembler.finish,
        )

    async def sample(
        self,
        spec: Optional[_ocean.TileLike] = None,
        points: Any = None,
        *,
        time: float = 0.0,
        invert_displacement: bool = False,
        timeout: Optional[float] = None,
        request: Optional[ocean_pb2.SampleSurfaceRequest] = None,
    ) -> Samples:
        """Surface samples at world points (n, 2), m (see squall.ocean.Ocean.sample)."""
        message = _ocean.sample_request(spec, points, time, invert_displacement, request)
        return Samples(
            await self._connection.unary(
                "Ocean.SampleSurface", self._rpc.SampleSurface, message, timeout
            )
        )


class EWaveSession:
    """One eWave session (asyncio); ``async with`` closes it. See squall.ewave.EWaveSession."""

    def __init__(self, service: "EWave", response: ewave_pb2.EWaveSessionResponse) -> None:
        self._service = service
        self.id: str = response.session_id
        self.config: ewave_pb2.EWaveConfig = response.config
        self.max_dt: float = response.max_dt
        self.steps: int = response.step  # as squall.ewave.EWaveSession.steps
        self.last_retry_key: Optional[bytes] = None  # as squall.ewave.EWaveSession.last_retry_key
        self.closed = False

    @property
    def shape(self) -> Tuple[int, int]:
        """(ny, nx) of the session's fields (ValueError for an ``attach`` given no config)."""
        return _ewave.session_shape(self.config)

    async def step(
        self,
        dt: Optional[float] = None,
        *,
        inputs: Optional[Union[ewave_pb2.EWaveInputs, Mapping[str, Any]]] = None,
        after_step: Optional[int] = None,
        retry_key: Optional[bytes] = None,
        timeout: Optional[float] = None,
        **kwargs: Any,
    ) -> EWaveFrame:
        """One step of dt seconds (keywords of squall.ewave.inputs): the fields after it. As
        squall.ewave.EWaveSession.step: made once however often it is retried with its key;
        after_step checked."""
        request = _ewave.unary_step_request(
            self.id, _ewave.as_inputs(inputs, dt, **kwargs), after_step, retry_key
        )
        self.last_retry_key = request.retry_key
        conn = self._service._connection
        frame = EWaveFrame(
            await conn.unary("EWave.Step", self._service._rpc.Step, request, timeout, self.id)
        )
        self.steps = frame.step
        return frame

    def run(
        self, items: Union[Iterable[Any], AsyncIterable[Any]], *, timeout: Optional[float] = None
    ) -> AsyncStream[EWaveFrame]:
        """Steps over the Run stream: one frame per item (a sync or async iterable of EWaveInputs,
        mappings of squall.ewave.inputs' arguments, dt values or EWaveStepRequests of this
        session), items read at most 2 ahead of the frames taken: a caller that stops after its
        n-th frame has had at most n + 2 steps applied by the stream. An exception raised by
        `items` is raised by the iterator, as in squall.ewave.EWaveSession.run: from the
        SquallError of a step that failed too."""
        feeder = _AsyncFeeder(items, lambda item, i: _ewave.step_request(self.id, item, i))
        conn = self._service._connection
        return conn.stream(
            "EWave.Run",
            self._service._rpc.Run,
            feeder.__aiter__(),
            EWaveFrame,
            timeout,
            self.id,
            feeder,
        )

    async def state(self, *, timeout: Optional[float] = None) -> bytes:
        """The session as opaque bytes for restore."""
        request = ewave_pb2.EWaveSessionRequest(session_id=self.id)
        conn = self._service._connection
        reply: ewave_pb2.EWaveStateResponse = await conn.unary(
            "EWave.GetState", self._service._rpc.GetState, request, timeout, self.id
        )
        return reply.state

    async def restore(self, state: bytes, *, timeout: Optional[float] = None) -> "EWaveSession":
        """A new session continuing `state`."""
        return await self._service.restore(state, timeout=timeout)

    async def close(self, *, timeout: Optional[float] = None) -> None:
        """Ends the session on the server. Idempotent, as squall.ewave.EWaveSession.close and
        ``Clouds.release``: a session already gone (NOT_FOUND, e.g. closed by a first attempt
        whose answer was lost, which the client's retry then found gone) counts as closed."""
        if self.closed:
            return
        request = ewave_pb2.EWaveSessionRequest(session_id=self.id)
        conn = self._service._connection
        try:
            await conn.unary(
                "EWave.CloseSession", self._service._rpc.CloseSession, request, timeout, self.id
            )
        except SquallError as error:
            if error.code != grpc.StatusCode.NOT_FOUND:
                raise
        self.closed = True

    async def __aenter__(self) -> "EWaveSession":
        return self

    async def __aexit__(self, exc_type: Any, *exc: Any) -> None:
        await _close_quietly(self, exc_type)


async def _close_quietly(session: EWaveSession, exc_type: Any) -> None:
    """squall.ewave.close_quietly, awaited: while a block's exception propagates, a SquallError of
    the close would hide it and is dropped."""
    if exc_type is None:
        await session.close()
        return
    try:
        await session.close()
    except SquallError:
        pass


class _PendingSession:
    """``await client.ewave.session(...)`` or ``async with client.ewave.session(...) as s``."""

    def __init__(self, create: Callable[[], Awaitable[EWaveSession]]) -> None:
        self._create = create
        self._session: Optional[EWaveSession] = None

    def __await__(self) -> Generator[Any, None, EWaveSession]:
        return self._create().__await__()

    async def __aenter__(self) -> EWaveSession:
        self._session = await self._create()
        return self._session

    async def __aexit__(self, exc_type: Any, *exc: Any) -> None:
        if self._session is not None:
            await _close_quietly(self._session, exc_type)


class EWave:
    """``client.ewave`` (asyncio): sessions (see squall.ewave.EWave)."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = rpc_client(ewave_pb2_grpc.EWaveStub, connection.channel)

    def session(
        self,
        config: Optional[Union[ewave_pb2.EWaveConfig, Mapping[str, Any]]] = None,
        *,
        timeout: Optional[float] = None,
        **kwargs: Any,
    ) -> _PendingSession:
        """Creates a session from an EWaveConfig or squall.ewave.config's keyword arguments:
        await it, or use it in ``async with`` (closed at the end)."""
        request = ewave_pb2.EWaveCreateSessionRequest(config=_ewave.as_config(config, **kwargs))

        async def create() -> EWaveSession:
            response = await self._connection.create(
                "EWave.CreateSession",
                self._rpc.CreateSession,
                request,
                timeout,
                "",
                partial(_ewave.close_call, self._rpc),
            )
            return EWaveSession(self, response)

        return _PendingSession(create)

    async def restore(self, state: bytes, *, timeout: Optional[float] = None) -> EWaveSession:
        """A new session continuing a state snapshot."""
        request = _ewave.restore_request(state)
        undo = partial(_ewave.close_call, self._rpc)
        return EWaveSession(
            self,
            await self._connection.create(
                "EWave.Restore", self._rpc.Restore, request, timeout, "", undo
            ),
        )

    def attach(
        self, session_id: str, config: Optional[ewave_pb2.EWaveConfig] = None
    ) -> EWaveSession:
        """A handle on an existing session id; nothing is sent."""
        return EWaveSession(self, _ewave.attached(session_id, config))


class Clouds:
    """``client.clouds`` (asyncio): see squall.clouds.Clouds."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = rpc_client(clouds_pb2_grpc.CloudsStub, connection.channel)

    async def build(
        self,
        cloud: Optional[_clouds.ModelLike] = None,
        *,
        keep: bool = False,
        return_vdb: bool = False,
        path: Optional[_clouds.PathLike] = None,
        timeout: Optional[float] = None,
        request: Optional[clouds_pb2.BuildVolumeRequest] = None,
    ) -> Volume:
        """Builds a volume (summary, .vdb bytes or file if asked, id if kept)."""
        message = _clouds.build_request(cloud, keep, return_vdb or path is not None, request)
        if message.keep:
            undo = partial(_clouds.release_call, self._rpc)
            build = self._connection.create(
                "Clouds.BuildVolume", self._rpc.BuildVolume, message, timeout, "cloud-", undo
            )
        else:
            build = self._connection.unary(
                "Clouds.BuildVolume", self._rpc.BuildVolume, message, timeout
            )
        return _clouds.volume_of(await build, message.return_vdb, path)

    async def render(
        self,
        source: Optional[_clouds.SourceLike] = None,
        settings: Optional[_clouds.SettingsLike] = None,
        *,
        timeout: Optional[float] = None,
        request: Optional[clouds_pb2.RenderRequest] = None,
        **kwargs: Any,
    ) -> Image:
        """Ray-marches a model, a stored Volume or a volume id: an (H, W, C) Image."""
        message = _clouds.render_request(source, settings, kwargs, request)
        response = await self._connection.unary(
            "Clouds.Render",
            self._rpc.Render,
            message,
            timeout,
            session=_clouds.stored_session(message),
        )
        return Image.from_proto(response.image, response.summary)

    def evolve(
        self,
        cloud: Optional[_clouds.ModelLike] = None,
        times: Optional[Sequence[float]] = None,
        *,
        evolution: Any = None,
        settings: Optional[_clouds.SettingsLike] = None,
        include_vdb: bool = False,
        timeout: Optional[float] = None,
        request: Optional[clouds_pb2.StreamEvolutionRequest] = None,
        **kwargs: Any,
    ) -> AsyncStream[EvolutionFrame]:
        """One frame per time (s) of an evolving model (async iterator)."""
        message = _clouds.evolution_request(
            cloud, times, evolution, settings, include_vdb, kwargs, request
        )
        return self._connection.stream(
            "Clouds.StreamEvolution",
            self._rpc.StreamEvolution,
            message,
            _clouds.evolution_frame,
            timeout,
        )

    async def release(
        self, volume: Union[str, Volume], *, timeout: Optional[float] = None
    ) -> None:
        """Drops a stored volume. Idempotent, as squall.clouds.Clouds.release and
        ``EWaveSession.close``: a volume no longer stored (NOT_FOUND, e.g. released by a first
        attempt whose answer was lost, which the client's retry then found gone) counts as
        released."""
        message = clouds_pb2.ReleaseVolumeRequest(volume_id=_clouds.volume_id_of(volume))
        try:
            await self._connection.unary(
                "Clouds.ReleaseVolume",
                self._rpc.ReleaseVolume,
                message,
                timeout,
                session=message.volume_id,
            )
        except SquallError as error:
            if error.code != grpc.StatusCode.NOT_FOUND:
                raise


class Steering(Generic[T]):
    """A running bidirectional stream steered message by message (asyncio): the base of
    ``Interactive`` and ``DeformInteractive``; ``async with`` ends it. See
    squall.textures.Steering.
    """

    METHOD = ""

    def __init__(
        self,
        call: Any,
        start: Any,
        convert: Callable[[Any], T],
        settings: Optional[Settings] = None,
    ) -> None:
        self._call = call
        self._start: Any = start  # sent with the first message only
        self._convert = convert
        self._settings = settings  # the client's: whether it was closed
        self.frames_received = 0
        self._ended = False  # the call has ended (its error, if any, was raised)

    def _cancelled_call(self) -> Optional[SquallError]:
        """The SquallError (CANCELLED) of the call cancelled under a task that is not itself being
        cancelled (the client was closed), else None: the module's _cancelled_call."""
        closed = self._settings is not None and self._settings.closed
        return _cancelled_call(closed, self.METHOD)

    def _check_open(self) -> None:
        if self._ended:
            raise SquallError(
                grpc.StatusCode.FAILED_PRECONDITION, "client: the stream has ended", self.METHOD
            )

    async def _exchange(self, message: Any, frames: int) -> List[T]:
        """Writes one message and reads the `frames` frames it asks for. Anything raised while
        reading them (a frame that fails conversion, the task cancelled) cancels the stream: the
        frames left unread would otherwise be returned by the next ``send``."""
        self._start = None
        out = []
        try:
            try:
                await self._call.write(message)
                for _ in range(int(frames)):
                    frame = await self._call.read()
                    if frame is grpc.aio.EOF:
                        self._ended = True
                        await self._raise_status()
                        raise SquallError(
                            grpc.StatusCode.INTERNAL,
                            "client: the stream ended early",
                            self.METHOD,
                        )
                    out.append(self._convert(frame))
            except grpc.RpcError as error:
                self._ended = True
                raise SquallError.from_rpc(error, self.METHOD) from None
            except asyncio.InvalidStateError:  # written after the call ended
                self._ended = True
                await self._raise_status()
                raise SquallError(
                    grpc.StatusCode.FAILED_PRECONDITION,
                    "client: the stream has ended",
                    self.METHOD,
                ) from None
            except asyncio.CancelledError:
                self._ended = True
                cancelled = self._cancelled_call()
                if cancelled is None:
                    raise
                raise cancelled from None
        except BaseException:
            self.cancel()
            raise
        self.frames_received += len(out)
        return out

    async def _raise_status(self, *quiet: grpc.StatusCode) -> None:
        """Raises the ended call's status as SquallError, unless it is OK or one of `quiet`."""
        code = await self._call.code()
        if code != grpc.StatusCode.OK and code not in quiet:
            metadata = tuple(await self._call.initial_metadata() or ())
            metadata += tuple(await self._call.trailing_metadata() or ())
            raise SquallError(code, await self._call.details(), self.METHOD, metadata)

    async def close(self) -> None:
        """Ends the request side and waits for the call's status (raised unless send raised it).
        As in the sync client, a call that ended CANCELLED (the client closed under it) raises
        nothing."""
        if self._ended:
            return
        self._ended = True
        try:
            await self._call.done_writing()
            while await self._call.read() is not grpc.aio.EOF:
                pass
        except grpc.RpcError as error:
            if error.code() != grpc.StatusCode.CANCELLED:
                raise SquallError.from_rpc(error, self.METHOD) from None
            return
        except asyncio.CancelledError:
            if self._cancelled_call() is None:
                raise
            return
        await self._raise_status(grpc.StatusCode.CANCELLED)

    def cancel(self) -> None:
        """Ends the call now; ``close`` (and leaving ``async with``) then raises nothing, as in the
        sync client."""
        self._ended = True
        self._call.cancel()

    async def __aenter__(self: S) -> S:
        return self

    async def __aexit__(self, exc_type: Any, *exc: Any) -> None:
        if exc_type is None:
            await self.close()
        else:
            self.cancel()

    def __del__(self) -> None:
        # As AsyncStream's and the sync Steering's: dropped neither closed nor left in ``async
        # with``, the call would keep the server's --max-streams slot until grpc.aio frees it
        # (whenever the garbage collector gets to it, or never while anything else holds it) or
        # --stream-idle-timeout ends it. Call.cancel() is synchronous (a no-op on an ended call);
        # the loop may be gone by now, hence the quiet except.
        try:
            self._call.cancel()
        except Exception:  # __init__ failed early, or the loop is closed
            pass


class Interactive(Steering[TextureFrame]):
    """A running AdvectInteractive stream (asyncio); ``async with`` ends it. See
    squall.textures.Interactive.
    """

    METHOD = "Textures.AdvectInteractive"

    def __init__(
        self,
        call: Any,
        start: textures_pb2.AdvectTextureRequest,
        settings: Optional[Settings] = None,
    ) -> None:
        super().__init__(call, start, TextureFrame, settings)

    async def send(
        self,
        frames: int = 1,
        *,
        velocity: Any = None,
        dt: Optional[float] = None,
        substeps: Optional[int] = None,
        spin: Optional[float] = None,
        final_scale: Optional[float] = None,
    ) -> List[TextureFrame]:
        """Applies the changes given and returns `frames` more frames (see
        squall.textures.Interactive.send).

        A message that fails validation raises SquallError naming "control[n].<field>", but
        the server sends no reply to one with ``frames=0``: send() returns [] once the message
        is written, and that message's error is raised only by the next send() that asks for
        frames, or by close() (the end of the ``async with`` block); a send(frames=0) in
        between returns [] too (or raises the error, once the server has ended the call), and
        cancel() drops it.
        """
        self._check_open()
        message = _textures.control_message(
            self._start, frames, velocity, dt, substeps, spin, final_scale
        )
        return await self._exchange(message, message.frames)


class DeformInteractive(Steering[DeformFrame]):
    """A running DeformInteractive stream (asyncio); ``async with`` ends it. See
    squall.textures.DeformInteractive.
    """

    METHOD = "Textures.DeformInteractive"

    def __init__(
        self,
        call: Any,
        start: textures_pb2.DeformTextureRequest,
        settings: Optional[Settings] = None,
    ) -> None:
        super().__init__(call, start, DeformFrame, settings)

    async def send(
        self,
        frames: int = 1,
        *,
        d_mu: Optional[float] = None,
        d_mu_map: Any = None,
        deformation: Any = None,
        strokes: Optional[Sequence[Any]] = None,
        clear_strokes: bool = False,
    ) -> List[DeformFrame]:
        """Applies the changes given and returns `frames` more frames (see
        squall.textures.DeformInteractive.send).

        A message that fails validation raises SquallError naming "control[n].<field>", but
        the server sends no reply to one with ``frames=0``: send() returns [] once the message
        is written, and that message's error is raised only by the next send() that asks for
        frames, or by close() (the end of the ``async with`` block); a send(frames=0) in
        between returns [] too (or raises the error, once the server has ended the call), and
        cancel() drops it.
        """
        self._check_open()
        message = _textures.deform_control_message(
            self._start, frames, d_mu, d_mu_map, deformation, strokes, clear_strokes
        )
        return await self._exchange(message, message.frames)


class Textures:
    """``client.textures`` (asyncio): see squall.textures.Textures (advect, interactive,
    bake_velocity, deform, deform_interactive)."""

    def __init__(self, connection: Connection) -> None:
        self._connection = connection
        self._rpc = rpc_client(textures_pb2_grpc.TexturesStub, connection.channel)

    def advect(
        self,
        *,
        method: Union[str, int] = "lagrangian",
        velocity: Any = None,
        texture: Any = None,
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
    ) -> AsyncStream[TextureFrame]:
        """Streams the frames of an advected texture (async iterator); the arguments of
        squall.textures.Textures.advect (frames required)."""
        if request is None and frames is None:
            raise TypeError("advect: frames (1..100000) is required")
        message = _textures.advect_request(
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
            session=_textures.followed_session(message),
        )

    def interactive(
        self,
        start: Optional[Union[textures_pb2.AdvectTextureRequest, Mapping[str, Any]]] = None,
        *,
        timeout: Optional[float] = None,
        **kwargs: Any,
    ) -> Interactive:
        """Starts an AdvectInteractive stream steered by ``await Interactive.send(...)``."""
        request = _textures.interactive_start(start, kwargs)
        settings = self._connection.settings
        call = self._rpc.AdvectInteractive(
            timeout=settings.deadline(timeout, stream=True),
            metadata=settings.metadata(_textures.followed_session(request)),
        )
        return Interactive(self._connection.track(call), request, settings)

    async def bake_velocity(
        self,
        river: Any = None,
        *,
        size: Optional[Sequence[int]] = None,
        region: Any = None,
        psi: bool = False,
        dtype: Any = "float32",
        timeout: Optional[float] = None,
        request: Optional[textures_pb2.BakeVelocityRequest] = None,
    ) -> BakedVelocity:
        """A river's velocity on a grid (see squall.textures.Textures.bake_velocity)."""
        message = _textures.bake_request(
            river, size=size, region=region, psi=psi, dtype=dtype, request=request
        )
        return BakedVelocity(
            await self._connection.unary(
                "Textures.BakeVelocity", self._rpc.BakeVelocity, message, timeout
            )
        )

    def deform(
        self,
        image: Any = None,
        rigidity: Any = None,
        *,
        control: Union[str, int] = "constant",
        d_mu: Optional[float] = None,
        d_mu_map: Any = None,
        kappa: Optional[float] = None,
        deformation_start: Any = None,
        deformation_end: Any = None,
        strokes: Optional[Sequence[Any]] = None,
        paper_dt_factor: bool = False,
        frames: Optional[int] = None,
        dt: Optional[float] = None,
        substeps: Optional[int] = None,
        stack_levels: int = 0,
        chart: Any = None,
        planes: Union[str, int, Sequence[Union[str, int]]] = ("color",),
        dtype: Any = "float32",
        tolerance: Optional[float] = None,
        max_iterations: Optional[int] = None,
        timeout: Optional[float] = None,
        request: Optional[textures_pb2.DeformTextureRequest] = None,
    ) -> AsyncStream[DeformFrame]:
        """Streams the frames of a deformed texture (async iterator); the arguments of
        squall.textures.Textures.deform (frames required)."""
        if request is None and frames is None:
            raise TypeError("deform: frames (1..100000) is required")
        message = _textures.deform_request(
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
        image: Any = None,
        rigidity: Any = None,
        *,
        start: Optional[Union[textures_pb2.DeformTextureRequest, Mapping[str, Any]]] = None,
        timeout: Optional[float] = None,
        **kwargs: Any,
    ) -> DeformInteractive:
        """Starts a DeformInteractive stream steered by ``await DeformInteractive.send(...)``."""
        request = _textures.deform_interactive_start(start, image, rigidity, kwargs)
        settings = self._connection.settings
        call = self._rpc.DeformInteractive(
            timeout=settings.deadline(timeout, stream=True), metadata=settings.metadata()
        )
        return DeformInteractive(self._connection.track(call), request, settings)


class Client:
    """The asyncio client of one squalld: the arguments of squall.Client; use ``async with`` or
    ``await client.close()``. Create it inside the event loop that uses it."""

    def __init__(
        self,
        address: str = DEFAULT_ADDRESS,
        timeout: Optional[float] = 30.0,
        token: Optional[str] = None,
        *,
        stream_timeout: Optional[float] = None,
        request_id: Optional[str] = None,
        credentials: Optional[grpc.ChannelCredentials] = None,
        options: Sequence[Tuple[str, Any]] = (),
        retries: int = 5,
        token_file: Optional[str] = None,
        own_connection: bool = False,
    ) -> None:
        self.address = address_of(address)
        settings = Settings(
            timeout, stream_timeout, resolve_token(token, token_file), request_id, retries
        )
        grpc_options = channel_options(retries, own_connection, options)
        warn_plaintext_token(address, settings.token, credentials is not None)
        if credentials is None:
            channel = grpc.aio.insecure_channel(address, options=grpc_options)
        else:
            channel = grpc.aio.secure_channel(address, credentials, options=grpc_options)
        self._connection = Connection(channel, settings)
        self._server = rpc_client(server_pb2_grpc.ServerStub, channel)
        self._health = channel.unary_unary(
            HEALTH_CHECK,
            request_serializer=encode_health_request,
            response_deserializer=decode_health_response,
        )
        self.ocean = Ocean(self._connection)
        self.ewave = EWave(self._connection)
        self.clouds = Clouds(self._connection)
        self.textures = Textures(self._connection)

    @property
    def channel(self) -> grpc.aio.Channel:
        return self._connection.channel

    async def info(self, *, timeout: Optional[float] = None) -> server_pb2.GetInfoResponse:
        """Server.GetInfo."""
        request = server_pb2.GetInfoRequest()  # the request id goes as x-request-id (any length)
        reply: server_pb2.GetInfoResponse = await self._connection.unary(
            "Server.GetInfo", self._server.GetInfo, request, timeout
        )
        return reply

    async def health(self, service: str = "", *, timeout: Optional[float] = None) -> str:
        """gRPC health: "SERVING", "NOT_SERVING", ..."""
        request = health_service(service)
        status: str = await self._connection.unary("Health.Check", self._health, request, timeout)
        return status

    async def wait_until_serving(self, timeout: float = 60.0) -> bool:
        """Polls health until SERVING (True) or `timeout` seconds passed (False)."""
        end = time.monotonic() + timeout
        while True:
            try:
                if (
                    await self.health(timeout=max(0.1, min(2.0, end - time.monotonic())))
                    == "SERVING"
                ):
                    return True
            except SquallError:
                pass
            if time.monotonic() >= end:
                return False
            await asyncio.sleep(0.1)

    async def close(self) -> None:
        """Closes the channel: the calls and streams in flight end, raising SquallError (CANCELLED)
        as in the sync client; later calls raise RuntimeError."""
        self._connection.settings.closed = True
        self._connection.cancel_streams()
        await self._connection.channel.close()

    async def __aenter__(self) -> "Client":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()
