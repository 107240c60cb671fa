"""Limits that protect squalld from its clients.

The one memory budget (--memory-budget): a flood of eWave sessions, and one of ocean streams whose
clients never read, is refused with RESOURCE_EXHAUSTED naming the budget before squalld's resident
memory passes it (measured above its level when idle); what the flood held is given back when it ends,
and squalld then serves as before; while 90% of the budget is reserved, health's "admission" says
NOT_SERVING (new work would be refused: a balancer of stateless work sends it elsewhere), while the
server's own name stays SERVING. --max-streams-per-client: one client (its
address, whatever its connections) cannot take more stream slots than that. Stored cloud volumes count
as sessions (--max-sessions), and their bytes leave the metrics when they are released. A small tile or
sample of large layers counts the layers' memory. --stream-idle-timeout: a stream that waits on its
client that long is cancelled."""

from __future__ import annotations

import contextlib
import threading
import time
from typing import Any, Callable, Iterator, List, Optional, Tuple, TypeVar

import grpc
import pytest

import squall
import squall.v1.textures_pb2_grpc
from conftest import Daemon, _start
from exposition import samples, value
from processes import wait_for
from test_load import resident_bytes, scrape

T = TypeVar("T")

BUDGET = 1 << 30
ALL_OUTPUTS = [
    n for n in squall.ocean.ocean_pb2.TileOutput.keys() if n != "TILE_OUTPUT_UNSPECIFIED"
]


@pytest.fixture(scope="module")
def budget_daemon() -> Iterator[Daemon]:
    """Only the memory budget limits this squalld: its session, stream and session-byte caps are high."""
    flags = ["--memory-budget", str(BUDGET), "--max-sessions", "1000", "--max-streams", "1000"]
    yield from _start(flags + ["--max-session-bytes", str(64 << 30)], "budget")


def refused_by_the_budget(error: squall.SquallError) -> bool:
    return error.code == grpc.StatusCode.RESOURCE_EXHAUSTED and "--memory-budget" in error.message


def test_a_session_flood_is_refused_within_the_budget(budget_daemon: Daemon) -> None:
    idle = resident_bytes(budget_daemon.pid)
    with squall.Client(budget_daemon.address, timeout=120) as client:
        sessions: List[squall.ewave.EWaveSession] = []
        with pytest.raises(squall.SquallError) as refused:
            for _ in range(100):
                sessions.append(client.ewave.session(nx=1024, ny=1024, dx=0.05))
                assert resident_bytes(budget_daemon.pid) - idle < BUDGET
        assert refused_by_the_budget(refused.value), refused.value
        assert 2 <= len(sessions) < 100
        grown = resident_bytes(budget_daemon.pid) - idle
        print(f"{len(sessions)} sessions of 1024^2, then refused; RSS +{grown >> 20} MiB")
        for session in sessions:
            session.close()
        again = client.ewave.session(nx=1024, ny=1024, dx=0.05)  # the bytes came back
        again.close()


def test_a_flood_of_unread_streams_is_refused_within_the_budget(budget_daemon: Daemon) -> None:
    idle = resident_bytes(budget_daemon.pid)
    spec = squall.ocean.tile_spec(
        [squall.ocean.layer(extent=500, n=1024, wind_speed=12, fetch=50000)], output=(1024, 1024)
    )
    with squall.Client(
        budget_daemon.address, timeout=120
    ) as client, contextlib.ExitStack() as held:
        streams = []
        with pytest.raises(squall.SquallError) as refused:
            for _ in range(100):
                stream = held.enter_context(client.ocean.stream(spec, dt=0.1, outputs=ALL_OUTPUTS))
                next(stream)  # its first frame arrives; the client never reads another
                streams.append(stream)
                assert resident_bytes(budget_daemon.pid) - idle < BUDGET
        assert refused_by_the_budget(refused.value), refused.value
        assert 2 <= len(streams) < 100
        grown = resident_bytes(budget_daemon.pid) - idle
        print(
            f"{len(streams)} unread streams of 12 fields at 1024^2, then refused; RSS +{grown >> 20} MiB"
        )
    with squall.Client(budget_daemon.address, timeout=120) as client:
        # the streams' memory comes back as squalld notices each cancel (at its next frame's write)
        tile = wait_for(
            lambda: admitted(lambda: client.ocean.tile(spec, time=1.0, outputs=ALL_OUTPUTS)),
            60,
            "a tile after the streams ended",
        )
        assert len(tile) == len(ALL_OUTPUTS)


def admitted(call: Callable[[], T]) -> Optional[T]:
    """call()'s result, or None when the memory budget refused it."""
    try:
        return call()
    except squall.SquallError as error:
        assert refused_by_the_budget(error), error
        return None


def test_a_small_tile_or_sample_of_large_layers_counts_their_memory() -> None:
    """An 8 x 8 output of every field from one 1024^2 layer: the tile's device buffers (34 MB, mostly
    the layer's four complex channel pairs) and the sample's copies of the layer (67 MB) pass a 30 MB
    budget, which the same calls on a 64^2 layer fit."""

    def spec(n: int) -> Any:
        return squall.ocean.tile_spec(
            [squall.ocean.layer(extent=500, n=n, wind_speed=12)], output=(8, 8)
        )

    for daemon in _start(["--memory-budget", str(30_000_000)], "layers"):
        with squall.Client(daemon.address, timeout=60) as client:
            with pytest.raises(squall.SquallError) as refused:
                client.ocean.tile(spec(1024), time=1.0, outputs=ALL_OUTPUTS)
            assert refused_by_the_budget(refused.value), refused.value
            assert "GetTile's tile" in refused.value.message, refused.value
            with pytest.raises(squall.SquallError) as refused:
                client.ocean.sample(spec(1024), [(1.0, 2.0)], time=1.0)
            assert refused_by_the_budget(refused.value), refused.value
            assert "SampleSurface's layers" in refused.value.message, refused.value
            assert len(client.ocean.tile(spec(64), time=1.0, outputs=ALL_OUTPUTS)) == len(
                ALL_OUTPUTS
            )
            client.ocean.sample(spec(64), [(1.0, 2.0)], time=1.0)


def call_and_cached_bytes(daemon: Daemon) -> Tuple[float, float]:
    """Of squall_memory_bytes, what calls hold, and what caches keep."""
    text = scrape(daemon)
    cached = value(text, "squall_memory_cached_bytes")
    return value(text, "squall_memory_bytes") - cached, cached


def settled_bytes(daemon: Daemon) -> Tuple[float, float]:
    """call_and_cached_bytes once two scrapes 0.5 s apart agree (within 20 s): the frame a stream
    computes ahead is done, and its spectrum is kept."""
    last: List[Tuple[float, float]] = [call_and_cached_bytes(daemon)]

    def unchanged() -> bool:
        time.sleep(0.4)
        now = call_and_cached_bytes(daemon)
        same = now == last[0] and now[1] > 0
        last[0] = now
        return same

    wait_for(unchanged, 20, "squall_memory_bytes to settle")
    return last[0]


def test_a_stream_whose_spectrum_is_built_again_keeps_its_reservation() -> None:
    """A stream reserves its frames' memory (W) and its spectrum's (S), which the spectra cache
    takes when it keeps the spectrum. A GetTile that needs the room takes the kept spectrum
    back; the stream's next frame builds it again, reserving it anew: the stream still holds W,
    not W - S."""

    def spec(seed: int) -> Any:
        layer = squall.ocean.layer(extent=500, n=256, wind_speed=12, seed=seed)
        return squall.ocean.tile_spec([layer], output=(256, 256))

    spectrum = 256 * 256 * 6 * 4  # six floats a mode
    flags = ["--metrics-listen", "127.0.0.1:0", "--memory-budget"]
    for daemon in _start(flags + [str(BUDGET)], "one stream"):
        with squall.Client(daemon.address, timeout=60) as client:
            with client.ocean.stream(spec(1), dt=0.1) as stream:
                next(stream)
                stream_bytes, cached = settled_bytes(daemon)
    assert cached >= spectrum
    # The stream (W), its kept spectrum (S), and room for W / 2 + S / 2 more: a GetTile of the
    # same output (W / 2) with a new spectrum (S) takes back the other caches' room and the kept
    # spectrum's.
    budget = int(1.5 * stream_bytes + 1.5 * spectrum)
    for daemon in _start(flags + [str(budget)], "a stream and a tile"):
        with squall.Client(daemon.address, timeout=60) as client:
            with client.ocean.stream(spec(1), dt=0.1) as stream:
                next(stream)
                # the frame computed ahead is done: the spectrum is not in use
                assert settled_bytes(daemon) == (stream_bytes, cached)
                client.ocean.tile(spec(2), time=1.0)
                # Past the frames written ahead: 25 MB, more than a transport holds.
                for _ in range(100):
                    next(stream)
                assert call_and_cached_bytes(daemon)[0] == stream_bytes


def test_one_client_cannot_take_more_streams_than_its_share() -> None:
    small = squall.ocean.tile_spec([squall.ocean.layer(extent=50, n=16, wind_speed=8)])
    for daemon in _start(["--max-streams", "4", "--max-streams-per-client", "2"], "per-client"):
        with squall.Client(daemon.address, timeout=60) as client:
            first = client.ocean.stream(small, dt=0.1)
            second = client.ocean.stream(small, dt=0.1)
            next(first), next(second)
            with pytest.raises(squall.SquallError) as refused:
                next(client.ocean.stream(small, dt=0.1))
            assert refused.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
            assert "--max-streams-per-client = 2" in refused.value.message, refused.value
            # a client is its address, not its connection: a second connection of this process is
            # the same client (another address finds its own share: limits_test.cpp)
            separate = [("grpc.use_local_subchannel_pool", 1)]
            with squall.Client(daemon.address, timeout=60, options=separate) as other:
                with pytest.raises(squall.SquallError) as refused:
                    next(other.ocean.stream(small, dt=0.1))
                assert refused.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
                assert "streams of ipv4:127.0.0.1:" in refused.value.message, refused.value
            first.cancel()
            # the slot comes back once the server notices the cancel (at its next frame)
            wait_for(lambda: opens(client, small), 10, "a third stream after a cancel")
            second.cancel()


def silent(release: threading.Event) -> Iterator[Any]:
    """A request stream that sends nothing until `release` is set."""
    release.wait()
    yield from ()


def test_a_stream_that_waits_on_its_client_past_the_idle_timeout_is_cancelled() -> None:
    """--stream-idle-timeout 0.5: a stream whose client sends nothing, or reads nothing, is cancelled
    after about half a second of waiting and its slot comes back; a stream whose frames take longer
    than that to compute, or whose client pauses less each time, goes on however long it runs."""
    small = squall.ocean.tile_spec([squall.ocean.layer(extent=50, n=16, wind_speed=8)])
    flags = ["--max-streams", "1", "--stream-idle-timeout", "0.5"]
    for daemon in _start(flags, "idle"):
        with squall.Client(daemon.address, timeout=60) as client:
            release = threading.Event()
            stub = squall.v1.textures_pb2_grpc.TexturesStub(client.channel)
            started = time.monotonic()
            with pytest.raises(grpc.RpcError) as ended:
                next(stub.AdvectInteractive(silent(release), timeout=30))
            waited = time.monotonic() - started
            release.set()
            assert ended.value.code() == grpc.StatusCode.CANCELLED and 0.5 <= waited < 5, waited
            assert opens(client, small)  # the one slot is free again
            gave_up = "waited on its client for 0.5 s (--stream-idle-timeout)"
            wait_for(lambda: gave_up in daemon.log(), 10, "the log of the first cancel")

            large = squall.ocean.tile_spec([squall.ocean.layer(extent=500, n=1024)])
            unread = client.ocean.stream(large, dt=0.1, outputs=("height", "normal_z"))
            next(unread)
            # squalld's writes wait on this client's flow control meanwhile, until it gives up
            wait_for(lambda: daemon.log().count(gave_up) >= 2, 30, "the unread stream's cancel")
            with pytest.raises(squall.SquallError) as ended_unread:
                list(unread)
            assert ended_unread.value.code == grpc.StatusCode.CANCELLED, ended_unread.value

            # Frames that take longer than the timeout to compute (about 0.8 s on 2 cores), each
            # taken at once: no waiting.
            slow = squall.ocean.tile_spec([squall.ocean.layer(extent=500, n=2048)] * 2)
            started = time.monotonic()
            with client.ocean.stream(slow, dt=0.1, frames=3, outputs=("height",)) as frames:
                assert len(list(frames)) == 3
            print(f"3 frames of two 2048^2 layers in {time.monotonic() - started:.1f} s")

            def paced() -> Iterator[float]:
                for _ in range(15):  # 1.5 s in all, never 0.5 s without a message
                    time.sleep(0.1)
                    yield 0.02

            with client.ewave.session(nx=16, ny=16, dx=0.1) as session:
                assert [frame.step for frame in session.run(paced())] == list(range(1, 16))


def opens(client: squall.Client, spec: Any) -> bool:
    try:
        with client.ocean.stream(spec, dt=0.1, frames=1) as stream:
            return len(list(stream)) == 1
    except squall.SquallError as error:
        assert error.code == grpc.StatusCode.RESOURCE_EXHAUSTED, error
        return False


def test_admission_is_not_serving_while_the_memory_budget_is_spent() -> None:
    """One unread StreamTiles of 12 fields at 256^2 reserves about 28.3 MB (two frames: the engine's
    fields, its device buffers, the reply) of a 30 MB budget: health's "admission" turns NOT_SERVING
    within a second, and SERVING again once the stream is cancelled. The server's and the services'
    names stay SERVING all along: a balancer hashing sessions to replicas does not move them."""
    spec = squall.ocean.tile_spec([squall.ocean.layer(extent=500, n=256, wind_speed=12)])
    for daemon in _start(["--memory-budget", str(30_000_000)], "admission"):
        with squall.Client(daemon.address, timeout=60) as client:
            assert client.health() == client.health("admission") == "SERVING"
            stream = client.ocean.stream(spec, dt=0.1, outputs=ALL_OUTPUTS)
            next(stream)
            wait_for(lambda: client.health("admission") == "NOT_SERVING", 5, "NOT_SERVING")
            for name in ("", "squall.v1.Ocean", "liveness"):  # busy, not broken or draining
                assert client.health(name) == "SERVING", name
            stream.cancel()
            wait_for(lambda: client.health("admission") == "SERVING", 5, "SERVING again")


@pytest.fixture(scope="module")
def volume_daemon() -> Iterator[Daemon]:
    """At most two live sessions (stored cloud volumes count), its metrics on a port of its own."""
    yield from _start(["--max-sessions", "2", "--metrics-listen", "127.0.0.1:0"], "volumes")


def volume_gauges(daemon: Daemon) -> Tuple[float, float]:
    """squall_stored_volumes and squall_stored_volume_bytes."""
    text = scrape(daemon)
    return value(text, "squall_stored_volumes"), value(text, "squall_stored_volume_bytes")


def test_kept_volumes_count_against_the_sessions_and_their_bytes_return_on_release(
    volume_daemon: Daemon,
) -> None:
    model = squall.clouds.model(voxel_size=1.0, spheres=[(0, 0, 0, 12)])
    with squall.Client(volume_daemon.address, timeout=120) as client:
        kept = [client.clouds.build(model, keep=True) for _ in range(2)]
        with pytest.raises(squall.SquallError) as refused:  # it used to keep any number
            client.clouds.build(model, keep=True)
        assert refused.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED
        assert "--max-sessions" in refused.value.message, refused.value.message
        count, two = volume_gauges(volume_daemon)
        assert count == 2 and two > 2 * 10_000
        client.clouds.release(kept[0])
        count, one = volume_gauges(volume_daemon)  # the released volume's bytes are given back
        assert count == 1 and one == pytest.approx(two / 2)
        again = client.clouds.build(model, keep=True)
        client.clouds.release(again)
        client.clouds.release(kept[1])
        assert volume_gauges(volume_daemon) == (0, 0)


def test_abandoned_sessions_and_dropped_streams_are_reclaimed_and_counted() -> None:
    """A session its client forgets is evicted after --session-ttl; a stream cancelled mid-way and one
    whose client stops reading until its deadline give back their slots; the metrics show all three.
    """
    small = squall.ocean.tile_spec([squall.ocean.layer(extent=50, n=16, wind_speed=8)])
    stream_calls = dict(service="squall.v1.Ocean", method="StreamTiles")
    for daemon in _start(["--session-ttl", "2", "--metrics-listen", "127.0.0.1:0"], "faults"):
        with squall.Client(daemon.address, timeout=60) as client:
            client.ewave.session(nx=64, ny=64, dx=0.05)  # never closed
            assert value(scrape(daemon), "squall_sessions_active") == 1
            cancelled = client.ocean.stream(small, dt=0.1)
            next(cancelled)
            cancelled.cancel()
            unread = client.ocean.stream(small, dt=0.1, timeout=1.5)
            next(unread)  # and no more
            wait_for(lambda: value(scrape(daemon), "squall_streams_active") == 0, 30, "slots back")
            wait_for(lambda: value(scrape(daemon), "squall_sessions_active") == 0, 30, "evicted")
            text = scrape(daemon)
            ended = [
                sum(samples(text, "squall_requests_total", code=code, **stream_calls))
                for code in ("CANCELLED", "DEADLINE_EXCEEDED")
            ]
            assert sum(ended) == 2, ended  # the server sees a passed deadline as its client gone
