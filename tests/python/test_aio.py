"""squall.aio against a real squalld: the same answers as the synchronous client, async iterators."""

from __future__ import annotations

import asyncio
import gc
import re
import threading
import time
from functools import partial
from typing import Any, AsyncIterator, Callable, Coroutine, Iterator, List, TypeVar

import grpc
import numpy as np
import pytest

import squall
import squall.aio
from squall._calls import propose_session_id
from squall.v1 import ewave_pb2, ewave_pb2_grpc, textures_pb2, textures_pb2_grpc

from conftest import LostReply, in_process_server
from test_ewave import RefusesTheFirstStep, assert_raised_from_the_server, config, hull_inputs
from test_ocean import OUTPUTS, small_tile

R = TypeVar("R")


def run(coroutine, seconds: float = 120):
    return asyncio.run(asyncio.wait_for(coroutine, seconds))


def test_ocean(client: squall.Client, daemon) -> None:
    spec = small_tile()

    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            assert await aclient.health() == "SERVING"
            assert (await aclient.info()).ready
            tile = await aclient.ocean.tile(spec, time=1.0, outputs=OUTPUTS)
            frames = [
                f
                async for f in aclient.ocean.stream(
                    spec, dt=0.5, frames=2, t0=1.0, outputs=OUTPUTS
                )
            ]
            samples = await aclient.ocean.sample(spec, [[1.0, 2.0]], time=1.0)
            with pytest.raises(squall.SquallError) as error:
                await aclient.ocean.tile(spec, time=float("nan"))
            assert (
                error.value.code == grpc.StatusCode.INVALID_ARGUMENT
                and "time.seconds" in error.value.message
            )
            return tile, frames, samples

    tile, frames, samples = run(main())
    expected = client.ocean.tile(spec, time=1.0, outputs=OUTPUTS)
    for name in OUTPUTS:
        assert tile[name].tobytes() == expected[name].tobytes()
        assert frames[0][name].tobytes() == expected[name].tobytes()
    assert [f.time for f in frames] == [1.0, 1.5]
    assert samples["height"] == pytest.approx(
        client.ocean.sample(spec, [[1.0, 2.0]], time=1.0)["height"]
    )


def test_ewave_session(client: squall.Client, daemon) -> None:
    async def inputs():  # an async generator feeds the Run stream
        for n in range(1, 4):  # continuing after step 1
            await asyncio.sleep(0)
            yield hull_inputs(n)

    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            async with aclient.ewave.session(**config()) as session:
                first = await session.step(**hull_inputs(0))
                assert session.steps == 1
                state = await session.state()
                rest = [f async for f in session.run(hull_inputs(n) for n in range(1, 3))]
                copy = await aclient.ewave.restore(state)
                assert copy.steps == 1
                replay = [f async for f in copy.run(inputs())]
                await copy.close()
                with pytest.raises(squall.SquallError) as error:
                    await copy.step(0.02)
                assert error.value.code == grpc.StatusCode.NOT_FOUND
            return [first] + rest, replay

    frames, replay = run(main())
    assert [f.step for f in frames] == [1, 2, 3] and [f.step for f in replay] == [2, 3, 4]
    with client.ewave.session(**config()) as session:  # the same steps, synchronously
        for n, frame in enumerate(frames):
            expected = session.step(**hull_inputs(n))
            assert frame["height"].tobytes() == expected["height"].tobytes()
    for a, b in zip(replay, frames[1:]):  # restored after step 1: the same steps 2 and 3
        assert a["height"].tobytes() == b["height"].tobytes()


def test_run_reads_at_most_two_items_ahead_of_the_frames_taken(daemon) -> None:
    """As the synchronous client's: leaving the loop after frame n leaves at most n + 2 steps
    applied by the stream."""
    taken, ahead = 5, 2
    pulled = []

    def endless():
        while True:
            pulled.append(len(pulled))
            yield 0.02

    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            async with aclient.ewave.session(**config()) as session:
                async with session.run(endless()) as frames:
                    async for frame in frames:
                        if frame.step == taken:
                            break
                    await asyncio.sleep(0.5)  # room for a request task that runs ahead to do so
                    assert taken <= len(pulled) <= taken + ahead
                return (await session.step(0.02)).step

    assert taken + 1 <= run(main()) <= taken + 1 + ahead


def test_closing_a_session_already_gone_is_quiet_and_hides_no_error(daemon) -> None:
    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            async with aclient.ewave.session(**config()) as session:
                await aclient.ewave.attach(session.id).close()  # closed elsewhere: NOT_FOUND
            assert session.closed
            # a close that fails (here: no session id) while the block's error propagates
            with pytest.raises(KeyError, match="the body's"):
                async with aclient.ewave.attach(""):
                    raise KeyError("the body's")
            with pytest.raises(squall.SquallError) as error:
                async with aclient.ewave.attach(""):
                    pass
            assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT

    run(main())


def test_an_abandoned_creation_closes_the_session_it_proposed(daemon) -> None:
    """The asyncio client's Connection.create as the sync one's: squalld made the eWave session,
    the reply was lost to the client's deadline, and the client closes the id it proposed (the call
    is the real CreateSession; only its reply is lost)."""

    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            rpc = aclient.ewave._rpc

            proposed: List[str] = []

            async def late_create(request: Any, timeout: float, metadata: Any) -> None:
                proposed.append(dict(metadata)["x-squall-session"])
                await rpc.CreateSession(request, timeout=60, metadata=metadata)
                raise LostReply()

            request = ewave_pb2.EWaveCreateSessionRequest(config=squall.ewave.config(**config()))
            undo = partial(squall.ewave.close_call, rpc)
            connection = aclient.ewave._connection
            with pytest.raises(squall.SquallError) as lost:
                create = "EWave.CreateSession", late_create, request, 60
                await connection.create(*create, "", undo)
            assert lost.value.code == grpc.StatusCode.DEADLINE_EXCEEDED
            with pytest.raises(squall.SquallError) as gone:
                await aclient.ewave.attach(proposed[0]).state()
            assert gone.value.code == grpc.StatusCode.NOT_FOUND, "the session is still live"

    run(main())


def test_a_create_whose_answer_was_lost_is_made_again_under_a_fresh_id(
    daemon, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The asyncio client's Connection.create as the sync one's: ALREADY_EXISTS for the id it drew
    (the session an earlier attempt made, its answer lost) closes that session and creates one
    under a fresh id."""

    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            made = await aclient.ewave.session(**config())
            draws = [made.id]
            monkeypatch.setattr(
                squall.aio,
                "propose_session_id",
                lambda prefix="": draws.pop() if draws else propose_session_id(prefix),
            )
            session = await aclient.ewave.session(**config())
            assert session.id != made.id
            with pytest.raises(squall.SquallError) as gone:
                await made.state()
            assert gone.value.code == grpc.StatusCode.NOT_FOUND, "the first one is still live"
            await session.close()

    run(main())


def small_texture_stream() -> dict:
    """The arguments of a small texture stream (advect, interactive)."""
    return dict(
        texture=squall.textures.noise(bands=2),
        size=(16, 16),
        dt=0.1,
        velocity=squall.textures.analytic("uniform", velocity_x=0.1),
    )


def test_clouds_and_textures(client: squall.Client, daemon) -> None:
    model = squall.clouds.model(spheres=[(0, 0, 0, 8)])
    camera = squall.clouds.camera(eye=(0, -40, 0), width=8, height=8)
    start = small_texture_stream()

    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            image = await aclient.clouds.render(model, camera=camera)
            volume = await aclient.clouds.build(model, keep=True)
            await aclient.clouds.release(volume)
            evolution = [f async for f in aclient.clouds.evolve(model, [0.0, 1.0], camera=camera)]
            frames = [f async for f in aclient.textures.advect(frames=2, **start)]
            async with aclient.textures.interactive(**start) as steer:
                steered = await steer.send(frames=2)
            with pytest.raises(TypeError, match="frames"):
                aclient.textures.interactive(**start, frames=2)
            return image, volume, evolution, frames, steered

    image, volume, evolution, frames, steered = run(main())
    assert image.pixels.tobytes() == client.clouds.render(model, camera=camera).pixels.tobytes()
    assert volume.id and [f.time for f in evolution] == [0.0, 1.0]
    expected = list(client.textures.advect(frames=2, **start))
    assert len(frames) == len(steered) == len(expected) == 2
    for a, b, c in zip(frames, steered, expected):
        assert a.index == b.index == c.index
        assert a["final_0"].tobytes() == b["final_0"].tobytes() == c["final_0"].tobytes()


def test_a_cancelled_steering_stream_ends_quietly_as_in_the_sync_client(daemon) -> None:
    start = small_texture_stream()

    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            async with aclient.textures.interactive(**start) as steer:
                assert len(await steer.send(frames=1)) == 1
                steer.cancel()  # leaving the block raises nothing
            with pytest.raises(squall.SquallError):
                await steer.send(frames=1)  # the stream has ended

    run(main())
    with squall.Client(daemon.address) as client:
        with client.textures.interactive(**start) as steer:
            steer.send(frames=1)
            steer.cancel()


async def two_frames_once_the_slot_is_back(aclient: "squall.aio.Client", spec: Any) -> List[int]:
    """The frame indices of a two-frame stream, opened as soon as the one-stream daemon's slot is free
    again (RESOURCE_EXHAUSTED until squalld notices the last stream's end), within 10 s."""
    deadline = time.monotonic() + 10
    while True:
        try:
            return [
                f.frame_index
                async for f in aclient.ocean.stream(spec, dt=0.1, frames=2, outputs="height")
            ]
        except squall.SquallError as e:
            assert e.code == grpc.StatusCode.RESOURCE_EXHAUSTED and time.monotonic() < deadline, e
            await asyncio.sleep(0.05)


def test_cancelled_async_stream_releases_its_slot(tight_daemon) -> None:
    spec = small_tile()

    async def main():
        async with squall.aio.Client(tight_daemon.address) as aclient:
            endless = aclient.ocean.stream(spec, dt=0.1, outputs="height")
            assert (await endless.__anext__()).frame_index == 0
            endless.cancel()
            assert [f async for f in endless] == []
            return await two_frames_once_the_slot_is_back(aclient, spec)

    assert run(main()) == [0, 1]


def run_without_collector(main: Coroutine[Any, Any, R]) -> R:
    """run(main) with the garbage collector held off: what it frees, reference counts free."""
    gc.disable()
    try:
        return run(main)
    finally:
        gc.enable()


@pytest.mark.parametrize("call", ["ewave.run", "ocean.stream"])
def test_an_async_stream_left_by_break_releases_its_slot(tight_daemon, call: str) -> None:
    """As the synchronous client's Stream: an AsyncStream left by ``break`` and never cancelled
    cancels its call once nothing refers to it. The garbage collector is held off: grpc.aio's call
    sits in reference cycles (its response generator, its request task), which it would break only
    at some later collection, the slot held until then; the one-stream daemon takes another stream
    within seconds."""
    spec = small_tile()

    def endless() -> Any:
        while True:
            yield 0.02

    async def main() -> List[int]:
        async with squall.aio.Client(tight_daemon.address) as aclient:
            if call == "ewave.run":
                async with aclient.ewave.session(**config()) as session:
                    async for frame in session.run(endless()):
                        assert frame.step == 1
                        break
                    return await two_frames_once_the_slot_is_back(aclient, spec)
            async for tile in aclient.ocean.stream(spec, dt=0.1, outputs="height"):
                assert tile.frame_index == 0
                break
            return await two_frames_once_the_slot_is_back(aclient, spec)

    assert run_without_collector(main()) == [0, 1]


def test_an_async_steering_stream_dropped_unclosed_releases_its_slot(tight_daemon) -> None:
    """As an AsyncStream's: an Interactive neither closed nor left in ``async with`` gives its slot
    back once nothing refers to it, the garbage collector held off (its call is in no reference
    cycle: grpc.aio cancels it as it is freed)."""
    spec = small_tile()

    async def main() -> List[int]:
        async with squall.aio.Client(tight_daemon.address) as aclient:
            steer = aclient.textures.interactive(**small_texture_stream())
            assert len(await steer.send(frames=1)) == 1
            del steer
            return await two_frames_once_the_slot_is_back(aclient, spec)

    assert run_without_collector(main()) == [0, 1]


class SteeredUntilCancelled(textures_pb2_grpc.TexturesServicer):
    """A Textures service whose interactive streams answer each message's frames until the request
    side ends; `cancelled` is set when a call ends. The tests' clients neither end their request
    side nor set a deadline, so a call ends only when cancelled. (Its end is what tells: after a
    cancel the server may never run the handler again, and the sync server's request iterator
    may then raise grpc.RpcError or end as if half-closed.)"""

    def __init__(self) -> None:
        self.cancelled = threading.Event()

    def AdvectInteractive(self, request_iterator, context):  # type: ignore[no-untyped-def]
        return self._answer(request_iterator, context, textures_pb2.TextureFrame)

    def DeformInteractive(self, request_iterator, context):  # type: ignore[no-untyped-def]
        return self._answer(request_iterator, context, textures_pb2.DeformFrame)

    def _answer(
        self, controls: Iterator[Any], context: grpc.ServicerContext, frame: Callable[..., Any]
    ) -> Iterator[Any]:
        context.add_callback(self.cancelled.set)
        try:
            for control in controls:
                for index in range(control.frames):
                    yield frame(index=index)
        except grpc.RpcError:  # cancelled while waiting for a message
            pass


STEERINGS = {
    "interactive": lambda textures: textures.interactive(size=(8, 8)),
    "deform_interactive": lambda textures: textures.deform_interactive(
        np.zeros((8, 8)), np.zeros((8, 8)), control="brush"
    ),
}


@pytest.mark.parametrize("steering", list(STEERINGS))
def test_a_dropped_async_steering_stream_cancels_its_call_though_the_call_lives_on(
    steering: str,
) -> None:
    """As AsyncStream's: a Steering stream dropped unclosed cancels its call itself, not only when
    grpc.aio frees the call. Here the call sits in a reference cycle, as grpc.aio's calls can,
    with the garbage collector held off: freeing the Steering is what must cancel it."""
    service = SteeredUntilCancelled()

    async def main(address: str) -> bool:
        async with squall.aio.Client(address) as aclient:
            steer = STEERINGS[steering](aclient.textures)
            assert len(await steer.send(frames=1)) == 1
            cycle: List[Any] = [steer._call]
            cycle.append(cycle)  # keeps the call, not the Steering, until a collection
            del cycle, steer
            return await asyncio.to_thread(service.cancelled.wait, 5)

    add = textures_pb2_grpc.add_TexturesServicer_to_server
    with in_process_server(add, service) as address:
        cancelled = run_without_collector(main(address))
    assert cancelled, "the server saw no cancel: the dropped stream keeps its slot"


def test_a_message_that_fails_to_convert_ends_its_async_stream(tight_daemon) -> None:
    """As the synchronous client's: the call is cancelled, its --max-streams slot given back."""
    spec = small_tile()

    def unreadable(chunk):
        raise ValueError("cannot read this chunk")

    async def main():
        async with squall.aio.Client(tight_daemon.address) as aclient:
            request = squall.ocean.stream_request(spec, 0.1, 0, 0.0, "height", "float32", None)
            endless = aclient._connection.stream(
                "Ocean.StreamTiles", aclient.ocean._rpc.StreamTiles, request, unreadable
            )
            with pytest.raises(ValueError, match="cannot read"):
                await endless.__anext__()
            return await two_frames_once_the_slot_is_back(aclient, spec)

    assert run(main()) == [0, 1]


def test_a_texture_that_follows_an_ewave_session_names_it(daemon) -> None:
    """As the synchronous client (test_routing.py): both texture streams on an eWave session's
    current send x-squall-session, which squalld's request log shows."""

    async def main():
        async with squall.aio.Client(daemon.address) as aclient:
            async with aclient.ewave.session(nx=16, ny=16, dx=0.1) as session:
                start = dict(velocity=session.id, size=(16, 16))
                frames = [f async for f in aclient.textures.advect(frames=1, **start)]
                async with aclient.textures.interactive(**start) as steer:
                    await steer.send(frames=1)
                return session.id, len(frames)

    session_id, frames = run(main())
    assert frames == 1
    log = daemon.log()
    for method in ("AdvectTexture", "AdvectInteractive"):
        pattern = rf"method=/squall\.v1\.Textures/{method} status=OK .*? session={session_id}\b"
        assert re.search(pattern, log), method


def large_tile() -> Any:
    """A 1024 x 1024 tile: tens of milliseconds of work, in flight when the client closes."""
    return squall.ocean.tile_spec(
        [squall.ocean.layer(extent=200, n=256, seed=3)], output=(1024, 1024)
    )


@pytest.fixture(params=["Task.cancelling", "client.close"])
def task_state(request: Any, monkeypatch: pytest.MonkeyPatch) -> str:
    """Both ways squall.aio tells the client's closing from the task's own cancellation: asyncio's
    Task.cancelling() (Python 3.11 and later), and the client's closed flag where asyncio cannot
    tell (older Pythons, imitated here)."""
    if request.param == "Task.cancelling":
        if not hasattr(asyncio.Task, "cancelling"):
            pytest.skip("Task.cancelling() needs Python 3.11")
    else:
        monkeypatch.setattr(squall.aio, "_cancelling", lambda: None)
    return str(request.param)


def assert_closed_under(error: squall.SquallError, method: str) -> None:
    """Checks that `error` is the CANCELLED of a `method` call whose client was closed."""
    assert error.code == grpc.StatusCode.CANCELLED, error
    assert error.method == method and "client was closed" in error.message, error


def test_closing_the_client_fails_a_call_in_flight_as_in_the_sync_client(
    daemon, task_state: str
) -> None:
    """grpc.aio raises asyncio.CancelledError for the calls that closing the channel cancels; the
    client raises SquallError (CANCELLED) instead, as the sync client does, so that the task
    awaiting the call fails (a TaskGroup reports it) rather than looking cancelled."""
    spec = large_tile()

    async def main() -> None:
        aclient = squall.aio.Client(daemon.address)
        tile = asyncio.create_task(aclient.ocean.tile(spec))
        await asyncio.sleep(0)  # the call is made
        await aclient.close()
        with pytest.raises(squall.SquallError) as error:
            await tile
        assert_closed_under(error.value, "Ocean.GetTile")

    async def in_a_task_group() -> None:
        aclient = squall.aio.Client(daemon.address)
        async with asyncio.TaskGroup() as group:  # type: ignore[attr-defined]
            group.create_task(aclient.ocean.tile(spec))
            await asyncio.sleep(0)
            await aclient.close()

    run(main(), 20)
    if hasattr(asyncio, "TaskGroup"):
        with pytest.raises(ExceptionGroup) as failed:  # noqa: F821 (Python 3.11)
            run(in_a_task_group(), 20)
        assert [type(e) for e in failed.value.exceptions] == [squall.SquallError]
        assert_closed_under(failed.value.exceptions[0], "Ocean.GetTile")


def test_closing_the_client_fails_its_streams_in_flight(daemon, task_state: str) -> None:
    """Server streams and bidirectional streams (EWave.Run) alike: SquallError (CANCELLED)."""

    def endless() -> Any:
        while True:
            yield 0.02

    async def main() -> None:
        aclient = squall.aio.Client(daemon.address)
        session = await aclient.ewave.session(**config())
        tiles = aclient.ocean.stream(small_tile(), dt=0.1, outputs="height")
        steps = session.run(endless())
        assert (await tiles.__anext__()).frame_index == 0
        assert (await steps.__anext__()).step == 1
        await aclient.close()
        for stream, method in ((tiles, "Ocean.StreamTiles"), (steps, "EWave.Run")):
            with pytest.raises(squall.SquallError) as error:
                async for _ in stream:
                    pass
            assert_closed_under(error.value, method)

    run(main(), 20)


def test_closing_the_client_fails_a_steering_send_and_ends_its_streams_quietly(
    daemon, task_state: str
) -> None:
    """A send() in flight raises SquallError (CANCELLED); a steering stream left open ends quietly
    at the end of its ``async with`` block, as the sync client's close() does."""
    start = small_texture_stream()

    async def main() -> None:
        aclient = squall.aio.Client(daemon.address)
        async with aclient.textures.interactive(**start) as steer:
            async with aclient.textures.interactive(**start) as idle:
                assert len(await steer.send(frames=1)) == len(await idle.send(frames=1)) == 1
                sending = asyncio.create_task(steer.send(frames=100))
                await asyncio.sleep(0)  # the message is being written
                await aclient.close()
                with pytest.raises(squall.SquallError) as error:
                    await sending
                assert_closed_under(error.value, "Textures.AdvectInteractive")
        with pytest.raises(squall.SquallError) as ended:
            await idle.send(frames=1)
        assert ended.value.code == grpc.StatusCode.FAILED_PRECONDITION

    run(main(), 20)
    client = squall.Client(daemon.address)
    with client.textures.interactive(**start) as steer:
        steer.send(frames=1)
        client.close()


def test_cancelling_the_awaiting_task_still_raises_cancelled_error(
    daemon, task_state: str
) -> None:
    """Cancelling the task that awaits a call, a stream or a send (or its asyncio deadline)
    cancels the call and propagates as asyncio.CancelledError (TimeoutError), not SquallError."""
    spec = large_tile()

    async def main() -> None:
        async with squall.aio.Client(daemon.address) as aclient:
            tiles = aclient.ocean.stream(spec, dt=0.1, outputs="height")
            steer = aclient.textures.interactive(**small_texture_stream())
            for awaited in (aclient.ocean.tile(spec), tiles.__anext__(), steer.send(frames=100)):
                task = asyncio.create_task(awaited)
                await asyncio.sleep(0)
                task.cancel()
                with pytest.raises(asyncio.CancelledError):
                    await task
            with pytest.raises(asyncio.TimeoutError):
                await asyncio.wait_for(aclient.ocean.tile(spec), 0.001)
            assert await aclient.health() == "SERVING"

    run(main(), 20)


def test_a_send_after_the_call_ended_ok_raises_failed_precondition(daemon) -> None:
    """As the sync client's send() on a stream that has ended: SquallError (FAILED_PRECONDITION),
    not the asyncio.InvalidStateError of grpc.aio's write."""

    async def main() -> None:
        async with squall.aio.Client(daemon.address) as aclient:
            steer = aclient.textures.interactive(**small_texture_stream())
            assert len(await steer.send(frames=1)) == 1
            await steer._call.done_writing()  # squalld then ends the call OK
            with pytest.raises(squall.SquallError) as error:
                await steer.send(frames=1)
            assert error.value.code == grpc.StatusCode.FAILED_PRECONDITION, error.value
            assert error.value.method == "Textures.AdvectInteractive"
            assert "ended" in error.value.message

    run(main(), 20)


class EndedCall:
    """A grpc.aio steering call that squalld has ended with `code` (its read raises it)."""

    def __init__(self, code: grpc.StatusCode) -> None:
        self._code = code

    async def done_writing(self) -> None:
        pass

    async def read(self) -> Any:
        empty = grpc.aio.Metadata()
        raise grpc.aio.AioRpcError(self._code, empty, empty, "ended by the server")

    async def code(self) -> grpc.StatusCode:
        return self._code

    def cancel(self) -> bool:
        return False


@pytest.mark.parametrize("steering", [squall.aio.Interactive, squall.aio.DeformInteractive])
def test_close_ignores_a_cancelled_call_as_in_the_sync_client(steering: Any) -> None:
    """The sync Steering.close() raises the call's error unless it is CANCELLED; so does the
    asyncio one."""

    async def main() -> None:
        await steering(EndedCall(grpc.StatusCode.CANCELLED), None).close()
        with pytest.raises(squall.SquallError) as error:
            await steering(EndedCall(grpc.StatusCode.INTERNAL), None).close()
        assert error.value.code == grpc.StatusCode.INTERNAL
        assert error.value.method == steering.METHOD

    run(main(), 20)


def test_an_async_run_iterables_error_is_raised_from_the_servers_status() -> None:
    """As the sync client's (test_ewave.py): the server refuses a step, then the caller's async
    iterable raises; its error is raised from the server's SquallError."""
    service = RefusesTheFirstStep()

    async def failing_inputs() -> AsyncIterator[float]:
        yield 0.02
        await asyncio.to_thread(service.refused.wait, 10)
        raise RuntimeError("the caller's inputs failed")

    async def main(address: str) -> None:
        async with squall.aio.Client(address) as aclient:
            [frame async for frame in aclient.ewave.attach("0" * 32).run(failing_inputs())]

    with in_process_server(ewave_pb2_grpc.add_EWaveServicer_to_server, service) as address:
        with pytest.raises(RuntimeError, match="the caller's inputs failed") as raised:
            run(main(address), 30)
    assert service.refused.is_set()
    assert_raised_from_the_server(raised.value)
