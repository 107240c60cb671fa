"""client.ewave against a real squalld: sessions, Step, the Run stream, GetState / Restore, errors."""

from __future__ import annotations

import os
import signal
import threading
import time
from typing import Iterator

import grpc
import numpy as np
import pytest

import squall
import squall.v1.ewave_pb2_grpc
from squall.v1 import ewave_pb2

from conftest import Daemon, _start, in_process_server
from processes import wait_for

NX, NY, DX = 48, 32, 0.01


def config() -> dict:
    return dict(nx=NX, ny=NY, dx=DX, source_scale=1.0)


def hull_inputs(n: int) -> dict:
    """A hull moving along +x through the middle of the grid, and a partly open obstruction."""
    obstruction = np.ones((NY, NX), dtype=np.float32)
    obstruction[2:5, 40:44] = 0.5
    return dict(
        dt=0.02,
        shapes=[squall.ewave.ellipse(0.1 + 0.004 * n, NY * DX / 2, 0.06, 0.02)],
        obstruction=obstruction,
        outputs=("height", "phi", "normal_z"),
    )


def test_a_session_made_after_its_caller_gave_up_is_closed(
    client: squall.Client, daemon: Daemon
) -> None:
    """A CreateSession whose 5 ms deadline passes while squalld builds the session (tens of ms for
    a 1018 x 1022 grid): the caller never learns the id, so squalld closes the session."""
    stub = squall.v1.ewave_pb2_grpc.EWaveStub(client.channel)
    proposed = os.urandom(16).hex()
    create = ewave_pb2.EWaveCreateSessionRequest(
        config=squall.ewave.config(nx=1018, ny=1022, dx=0.1)
    )
    with pytest.raises(grpc.RpcError) as late:
        stub.CreateSession(create, timeout=0.005, metadata=(("x-squall-session", proposed),))
    assert late.value.code() == grpc.StatusCode.DEADLINE_EXCEEDED
    ended = "method=/squall.v1.EWave/CreateSession status=CANCELLED"
    wait_for(
        lambda: any(ended in line and proposed in line for line in daemon.log().splitlines()),
        30,
        "squalld's log line of the late CreateSession",
    )
    with pytest.raises(squall.SquallError) as gone:
        client.ewave.attach(proposed).state()
    assert gone.value.code == grpc.StatusCode.NOT_FOUND


def test_session_steps_and_closes(client: squall.Client) -> None:
    with client.ewave.session(**config()) as session:
        assert len(session.id) == 32 and session.shape == (NY, NX)
        assert session.config.HasField("gravity")  # the config in force, defaults filled in
        # trimmed: the period of the shortest wave, 2 pi / omega(pi sqrt(2) / dx) in deep water
        assert session.max_dt == pytest.approx(2 * np.pi / np.sqrt(9.81 * np.pi * np.sqrt(2) / DX))
        for n in range(3):
            frame = session.step(**hull_inputs(n))
        assert frame.step == 3 and frame.time == pytest.approx(0.06)
        assert list(frame) == ["height", "phi", "normal_z"]
        assert frame["height"].shape == (NY, NX) and frame.units["phi"] == "m^2/s"
        assert frame.origin["height"][:2] == pytest.approx(
            (DX / 2, DX / 2)
        )  # centre of cell (0, 0)
        assert float(np.abs(frame["height"]).max()) > 0  # the hull (a height source) made waves
        session_id = session.id
    assert session.closed
    with pytest.raises(squall.SquallError) as error:
        client.ewave.attach(session_id).step(0.02)
    assert error.value.code == grpc.StatusCode.NOT_FOUND


def test_run_stream_equals_unary_steps(client: squall.Client) -> None:
    with client.ewave.session(**config()) as streamed, client.ewave.session(**config()) as stepped:
        frames = list(
            streamed.run(hull_inputs(n) for n in range(5))
        )  # a generator: read as frames come
        assert [f.step for f in frames] == [1, 2, 3, 4, 5]
        assert all(f.session_id == streamed.id for f in frames)
        for n, frame in enumerate(frames):
            expected = stepped.step(**hull_inputs(n))
            for name in expected:
                assert frame[name].tobytes() == expected[name].tobytes(), (n, name)


def test_state_and_restore_continue_bit_identically(client: squall.Client) -> None:
    with client.ewave.session(**config()) as session:
        assert session.steps == 0
        for n in range(3):
            session.step(**hull_inputs(n))
        state = session.state()
        assert isinstance(state, bytes) and len(state) > 2 * NX * NY * 4
        with client.ewave.restore(state) as copy:
            assert copy.id != session.id and copy.config.nx == NX
            assert session.steps == copy.steps == 3  # the saved state's: its next after_step
            a, b = session.step(**hull_inputs(3)), copy.step(**hull_inputs(3))
            assert a.step == b.step == 4
            for name in a:
                assert a[name].tobytes() == b[name].tobytes(), name


def test_a_step_sent_again_with_its_key_is_made_once(client: squall.Client) -> None:
    """Each step() draws a fresh 16-byte retry key; a step sent again with its key (as gRPC's
    retries send it) is made once, and after_step refuses a step another caller has overtaken."""
    inputs = ewave_pb2.EWaveInputs(dt=0.02)
    keys = {squall.ewave.unary_step_request("id", inputs).retry_key for _ in range(2)}
    assert len(keys) == 2 and all(len(key) == 16 for key in keys)
    with client.ewave.session(**config()) as session:
        session.step(**hull_inputs(0))
        made = session.step(**hull_inputs(1), retry_key=b"a step sent twice")
        again = session.step(**hull_inputs(1), retry_key=b"a step sent twice")
        assert made.step == again.step == 2
        for name in made:
            assert made[name].tobytes() == again[name].tobytes(), name
        with pytest.raises(squall.SquallError) as error:
            session.step(0.02, after_step=1)
        assert error.value.code == grpc.StatusCode.ABORTED
        assert "after_step = 1, but the session has made 2 steps" in error.value.message
        assert session.step(0.02, after_step=session.steps).step == session.steps == 3


def test_a_frame_too_wide_for_float16_is_refused_and_its_step_read_again(
    client: squall.Client,
) -> None:
    """Heights of 1e5 m asked as float16 (largest 65504): refused naming inputs.dtype once the
    step is made, and the same key reads that step's frame as float32."""
    with client.ewave.session(nx=16, ny=16, dx=0.1, initial_height=np.full((16, 16), 1e5)) as s:
        with pytest.raises(squall.SquallError) as error:
            s.step(0.02, outputs=["height"], dtype="float16", retry_key=b"wide")
        assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
        assert error.value.message.startswith("inputs.dtype: height = ")
        assert "the step was made (the session is at step 1)" in error.value.message
        frame = s.step(0.02, outputs=["height"], retry_key=b"wide")
        assert frame.step == 1 and np.all(np.abs(frame["height"]) > 65504)
        # A key the client drew: the session keeps it, so the step's frame is not lost either.
        with pytest.raises(squall.SquallError) as error:
            s.step(0.02, outputs=["height"], dtype="float16")
        assert "the step was made (the session is at step 2)" in error.value.message
        frame = s.step(0.02, outputs=["height"], retry_key=s.last_retry_key)
        assert frame.step == s.steps == 2


def test_errors_name_the_field(client: squall.Client) -> None:
    with client.ewave.session(**config()) as session:
        with pytest.raises(squall.SquallError) as error:
            session.step(0.0)
        assert (
            error.value.code == grpc.StatusCode.INVALID_ARGUMENT
            and "inputs.dt" in error.value.message
        )
        with pytest.raises(squall.SquallError) as error:
            session.step(0.02, obstruction=np.ones((NY, NX - 1)))
        assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
        assert "inputs.obstruction" in error.value.message
        # a failing message ends the Run stream after the frames before it
        items = [hull_inputs(0), hull_inputs(1), dict(dt=-1.0), hull_inputs(3)]
        received = []
        with pytest.raises(squall.SquallError) as error:
            for frame in session.run(items):
                received.append(frame.step)
        assert received == [1, 2]
        assert error.value.code == grpc.StatusCode.INVALID_ARGUMENT
        assert "Run message 2" in error.value.message and "inputs.dt" in error.value.message
        # a bad item on the client side surfaces as itself, not as a cancelled stream
        with pytest.raises(ValueError, match="outputs"):
            list(session.run([hull_inputs(0), dict(dt=0.02, outputs=("heigth",))]))
    with pytest.raises(squall.SquallError) as error:
        client.ewave.session(nx=NX, ny=NY, dx=-1.0)
    assert (
        error.value.code == grpc.StatusCode.INVALID_ARGUMENT and "config.dx" in error.value.message
    )


def test_a_bool_is_no_time_step(client: squall.Client) -> None:
    """True would be taken as dt = 1 s: run() raises TypeError after the frames before it."""
    with client.ewave.session(**config()) as session:
        for flag in (True, np.bool_(False)):
            received = []
            with pytest.raises(TypeError, match=r"^inputs\.dt = .*: want a number"):
                for frame in session.run([0.02, flag, 0.02]):
                    received.append(frame.step)
            assert len(received) == 1
        assert session.step(0.02).step == 3


def test_initial_height_from_numpy(client: squall.Client) -> None:
    x = (np.arange(NX) + 0.5) * DX
    bump = np.tile(0.01 * np.cos(2 * np.pi * x / (NX * DX)), (NY, 1)).astype(np.float32)
    with client.ewave.session(nx=NX, ny=NY, dx=DX, trim=False, initial_height=bump) as session:
        frame = session.step(1e-6)  # almost no time: the surface is still the initial bump
        np.testing.assert_allclose(frame["height"], bump, atol=1e-6)


def test_an_attached_session_knows_its_shape_only_from_a_config(client: squall.Client) -> None:
    with pytest.raises(ValueError, match="attach"):
        client.ewave.attach("0" * 32).shape
    config = squall.ewave.config(nx=32, ny=16, dx=0.1)
    assert client.ewave.attach("0" * 32, config).shape == (16, 32)


def test_run_reads_at_most_two_items_ahead_of_the_frames_taken(client: squall.Client) -> None:
    """gRPC asks for the next request as soon as the last is written; the feeder holds it back, so
    a caller that leaves the loop after frame n has had at most n + 2 steps applied by the
    stream."""
    taken, ahead = 5, 2
    pulled = []

    def endless() -> Iterator[float]:
        while True:
            pulled.append(len(pulled))
            yield 0.02

    with client.ewave.session(**config()) as session:
        with session.run(endless()) as frames:
            for frame in frames:
                if frame.step == taken:
                    break
            time.sleep(0.5)  # room for a request thread that runs ahead to do so
            assert taken <= len(pulled) <= taken + ahead
        assert taken + 1 <= session.step(0.02).step <= taken + 1 + ahead


def test_one_run_stream_steps_several_sessions(client: squall.Client) -> None:
    """A request naming another session steps that one (one squalld holds both)."""
    with client.ewave.session(**config()) as session, client.ewave.session(**config()) as other:
        items = [
            0.02,
            ewave_pb2.EWaveStepRequest(session_id=session.id, inputs=dict(dt=0.02)),
            ewave_pb2.EWaveStepRequest(session_id=other.id, inputs=dict(dt=0.02)),
        ]
        assert [frame.step for frame in session.run(items)] == [1, 2, 1]
        assert other.step(0.02).step == 2


def test_close_of_a_session_already_gone_is_quiet(client: squall.Client) -> None:
    with client.ewave.session(**config()) as session:
        client.ewave.attach(session.id).close()  # closed elsewhere (or expired): NOT_FOUND
    assert session.closed
    session.close()


def test_a_failing_close_does_not_hide_the_error_that_ended_the_block() -> None:
    """squalld gone mid-block: the step fails, and so does the close at the end of the block; the
    step's error is the one raised."""
    for daemon in _start([], "gone"):
        with squall.Client(daemon.address, timeout=30, retries=1) as client:
            with pytest.raises(squall.SquallError) as error:
                with client.ewave.session(**config()) as session:
                    session.step(0.02)
                    os.kill(daemon.pid, signal.SIGKILL)
                    wait_for(lambda: not daemon.running(), 10, "squalld gone")
                    session.step(0.02)
            assert error.value.method == "EWave.Step", error.value
            assert error.value.code == grpc.StatusCode.UNAVAILABLE, error.value
            assert not session.closed
            with pytest.raises(squall.SquallError) as error:
                session.close()  # outside a failing block nothing hides its error
            assert error.value.method == "EWave.CloseSession", error.value


def test_a_create_whose_answer_was_lost_is_made_again_under_a_fresh_id(
    client: squall.Client, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A CreateSession sent again after its answer was lost (gRPC retries a call whose connection
    broke) finds the id it proposed taken by the session its first attempt made: ALREADY_EXISTS,
    which for an id of 128 random bits means only that. The client closes that session and creates
    one under a fresh id: the caller gets a session, and none is left waiting for its TTL."""
    made = client.ewave.session(**config())  # the first attempt's, whose answer was lost
    draws = [made.id]

    def draw(prefix: str = "") -> str:
        return draws.pop() if draws else prefix + os.urandom(16).hex()

    monkeypatch.setattr(squall._calls, "propose_session_id", draw)
    with client.ewave.session(**config()) as session:
        assert session.id != made.id
        session.step(0.02)
    with pytest.raises(squall.SquallError) as gone:
        made.state()
    assert gone.value.code == grpc.StatusCode.NOT_FOUND, "the first attempt's session is still live"


ADD_EWAVE = squall.v1.ewave_pb2_grpc.add_EWaveServicer_to_server  # for in_process_server


class LostAfterTheStep(squall.v1.ewave_pb2_grpc.EWaveServicer):
    """An eWave service whose first Run stream ends UNAVAILABLE after it has read (and would have
    applied) a step, before any frame: as a connection lost after squalld stepped the session."""

    def __init__(self) -> None:
        self.calls = 0
        self.steps = 0

    def Run(self, request_iterator, context):  # type: ignore[no-untyped-def]
        self.calls += 1
        next(request_iterator)
        self.steps += 1
        if self.calls == 1:
            context.abort(grpc.StatusCode.UNAVAILABLE, "connection lost after the step")
        yield ewave_pb2.EWaveFrame(step=self.steps)


def test_a_run_stream_is_not_retried_so_no_step_is_applied_twice() -> None:
    """The client's retry policy (UNAVAILABLE, up to 5 attempts) covers every squall call but the
    Run stream, whose steps carry no retry key: gRPC would replay the step it had sent."""
    service = LostAfterTheStep()
    with in_process_server(ADD_EWAVE, service) as address:
        with squall.Client(address, retries=5) as client:
            with pytest.raises(squall.SquallError) as lost:
                list(client.ewave.attach("0" * 32).run([0.02]))
    assert lost.value.code == grpc.StatusCode.UNAVAILABLE, lost.value
    assert service.steps == 1, f"the step was sent {service.steps} times"


class RefusesTheFirstStep(squall.v1.ewave_pb2_grpc.EWaveServicer):
    """An eWave service that refuses the first message of a Run stream, as squalld a step that
    fails validation, and sets `refused`; its status goes out once the client's request side has
    ended. A caller's iterable that raises once `refused` is set so fails after the server did,
    and its error reaches the reading side before the server's status: the order in which the
    server's status used to be dropped."""

    MESSAGE = "Run message 0: inputs.dt = -1 must be in (0, max_dt]"

    def __init__(self) -> None:
        self.refused = threading.Event()

    def Run(self, request_iterator, context):  # type: ignore[no-untyped-def]
        next(request_iterator)
        self.refused.set()
        for _ in request_iterator:  # until the client's feeder has ended the request side
            pass
        context.abort(grpc.StatusCode.INVALID_ARGUMENT, self.MESSAGE)
        yield ewave_pb2.EWaveFrame()  # never reached: makes Run a response stream


def failing_inputs(refused: threading.Event) -> Iterator[float]:
    """One step's dt, then the caller's own failure, once the server has refused that step."""
    yield 0.02
    refused.wait(10)
    raise RuntimeError("the caller's inputs failed")


def assert_raised_from_the_server(raised: BaseException) -> None:
    """`raised`, the iterable's error, carries the server's refusal as its __cause__."""
    cause = raised.__cause__
    assert isinstance(cause, squall.SquallError), f"the server's status was dropped: {cause!r}"
    assert cause.code == grpc.StatusCode.INVALID_ARGUMENT, cause
    assert cause.method == "EWave.Run" and cause.message == RefusesTheFirstStep.MESSAGE, cause


def test_a_run_iterables_error_is_raised_from_the_servers_status() -> None:
    """The server refuses a step, then the caller's iterable raises: the iterable's error is raised
    (the caller's own), from the server's SquallError, which says why the stream ended."""
    service = RefusesTheFirstStep()
    with in_process_server(ADD_EWAVE, service) as address:
        with squall.Client(address) as client:
            with pytest.raises(RuntimeError, match="the caller's inputs failed") as raised:
                list(client.ewave.attach("0" * 32).run(failing_inputs(service.refused)))
    assert service.refused.is_set()
    assert_raised_from_the_server(raised.value)
