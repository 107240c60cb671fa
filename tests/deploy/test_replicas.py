"""Three squalld replicas behind a real L7 gRPC proxy (Envoy, and nginx), on loopback.

- Stateless calls spread over all replicas (each serves at least 20%, counted from x-squall-replica).
- Five eWave sessions, created through the proxy under ids the client proposes, each stick to one
  replica.
- SIGTERM on a replica holding sessions, mid-run: its sessions move through the shared --state-dir
  and continue on other replicas; every step succeeds (the client's retry policy, and Envoy's);
  every frame is bit-identical to an uninterrupted reference run; the terminated squalld exits 0
  within its grace period. Until the proxy's hash ring changes, each session stays on one replica
  and the other sessions on theirs. Envoy's ring changes once its health check takes the replica
  out: each survivor gets more points on it, which may move a session between them, through a
  handover (the replica the new ring picks asks the holder for it and answers UNAVAILABLE, and the
  retry goes elsewhere, until the holder has handed it over). So with Envoy the steps are checked
  before and after that; on the new ring a session moves at most once more, never back.
- Eight threads sampling through one squall.Client while a replica drains and exits: no call fails
  behind Envoy; behind nginx at most 1% fail, each UNAVAILABLE naming the drain.

Every process is started detached with its PID recorded and stopped by PID. Paths come from ctest's
environment (tests/deploy/lb.cmake).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
import urllib.request
from collections import Counter
from pathlib import Path
from typing import Dict, Iterator, List, Tuple

import grpc
import pytest

import squall
from squall._calls import SESSION_KEY, propose_session_id, retry_options, cancelled_unanswered
from squall._errors import REPLICA_KEY
from squall.v1 import ewave_pb2, ewave_pb2_grpc, ocean_pb2, ocean_pb2_grpc

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
from processes import Process, free_port, wait_for  # noqa: E402  (tests/support)

SOURCE_DIR = Path(os.environ.get("SQUALL_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BINARY_DIR = Path(os.environ.get("SQUALL_BINARY_DIR", SOURCE_DIR / "build"))
SQUALLD = os.environ.get("SQUALL_SQUALLD", str(BINARY_DIR / "squalld"))
TOOLS = Path(os.environ.get("SQUALL_TOOLS", BINARY_DIR / "deploy-tools"))
GRACE = 10.0
DRAINING = "squalld is shutting down; retry on another replica"  # a draining squalld's UNAVAILABLE
SESSIONS, STEPS, DRAIN_AT = 5, 8, 3


def serving(address: str) -> bool:
    with squall.Client(address, timeout=2, retries=1) as client:
        return client.wait_until_serving(0.5)


class Replica(Process):
    def __init__(self, name: str, state_dir: Path, directory: Path) -> None:
        self.name = name
        self.address = f"127.0.0.1:{free_port()}"
        flags = ["--listen", self.address, "--replica-id", name, "--state-dir", str(state_dir)]
        flags += ["--fft", "vkfft", "--grace-period", str(GRACE), "--drain-wait", "2"]
        cache = {"POCL_CACHE_DIR": str(BINARY_DIR / "pocl-cache")}
        super().__init__([SQUALLD, *flags], directory / f"{name}.log", cache)


def start_proxy(
    kind: str, listen: str, upstreams: List[str], directory: Path, admin: str
) -> Process:
    generator = [sys.executable, str(SOURCE_DIR / "deploy/lb/proxy-config.py"), kind]
    generator += ["--listen", listen] + [a for u in upstreams for a in ("--upstream", u)]
    if kind == "envoy":
        generator += ["--admin", admin]
        config = directory / "envoy.yaml"
        config.write_text(subprocess.check_output(generator, text=True))
        argv = [str(TOOLS / "bin/envoy"), "-c", str(config), "--log-level", "warn"]
        argv += ["--base-id", str(free_port())]  # several Envoys on one host need their own
    else:
        prefix = directory / "nginx"
        prefix.mkdir()
        generator += ["--prefix", str(prefix)]
        config = directory / "nginx.conf"
        config.write_text(subprocess.check_output(generator, text=True))
        argv = ["/usr/sbin/nginx", "-p", str(prefix), "-c", str(config), "-g", "daemon off;"]
    return Process(argv, directory / f"{kind}.log")


class Cluster:
    """Three replicas sharing a state directory behind the proxy `kind`; whatever started is stopped
    (by PID) if the rest fails to start."""

    def __init__(self, kind: str, directory: Path) -> None:
        self.kind = kind
        self.started: List[Process] = []
        try:
            self._start(directory)
        except BaseException:
            self.stop()
            raise

    def _start(self, directory: Path) -> None:
        state = directory / "state"
        self.replicas = [Replica(f"r{i}", state, directory) for i in range(3)]
        self.started += self.replicas
        for r in self.replicas:
            wait_for(lambda: serving(r.address), 300, f"{r.name} SERVING")
        self.address = f"127.0.0.1:{free_port()}"
        self.admin = f"127.0.0.1:{free_port()}"  # Envoy's admin interface
        upstreams = [r.address for r in self.replicas]
        proxy = start_proxy(self.kind, self.address, upstreams, directory, self.admin)
        self.started.append(proxy)
        wait_for(lambda: serving(self.address), 60, f"{self.kind} forwarding to a SERVING replica")
        # Envoy: every replica has passed an active health check (1 s interval) before traffic counts.
        time.sleep(2)
        options = [("grpc.max_receive_message_length", -1)] + retry_options(5)
        self.channel = grpc.insecure_channel(self.address, options=options)
        self.ocean = ocean_pb2_grpc.OceanStub(self.channel)
        self.ewave = ewave_pb2_grpc.EWaveStub(self.channel)

    def ring_without(self, replica: Replica) -> bool:
        """Whether the proxy's hash ring has left `replica` out: Envoy's once its active health check
        has failed (its admin interface's /clusters); nginx's never (its consistent hash walks past a
        failed server)."""
        if self.kind != "envoy":
            return False
        direct = urllib.request.build_opener(urllib.request.ProxyHandler({}))  # no http_proxy
        with direct.open(f"http://{self.admin}/clusters", timeout=5) as page:
            flags = f"squalld::{replica.address}::health_flags::"
            return any(
                line.startswith(flags) and "failed_active_hc" in line
                for line in page.read().decode().splitlines()
            )

    def stop(self) -> None:
        if hasattr(self, "channel"):
            self.channel.close()
        for process in reversed(self.started):
            process.stop()


@pytest.fixture(params=["envoy", "nginx"])
def cluster(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Cluster]:
    c = Cluster(request.param, tmp_path)
    yield c
    c.stop()


def replica_of(call: grpc.Call) -> str:
    return dict(call.initial_metadata())[REPLICA_KEY]


def sample_request() -> ocean_pb2.SampleSurfaceRequest:
    request = ocean_pb2.SampleSurfaceRequest()
    layer = request.tile.layers.add()
    layer.extent_x = layer.extent_y = 50
    layer.nx = layer.ny = 16
    layer.spectrum = ocean_pb2.SPECTRUM_MODEL_PIERSON_MOSKOWITZ
    layer.spreading = ocean_pb2.SPREADING_MODEL_MITSUYASU
    layer.dispersion = ocean_pb2.DISPERSION_MODEL_DEEP
    layer.wind_speed = 8
    request.points.add(x=1, y=2)
    return request


def create_request() -> ewave_pb2.EWaveCreateSessionRequest:
    return ewave_pb2.EWaveCreateSessionRequest(config=dict(nx=48, ny=32, dx=0.01, dy=0.01))


def step_request(session_id: str, n: int) -> ewave_pb2.EWaveStepRequest:
    # the Python client's retry key: a step sent again is made once
    request = ewave_pb2.EWaveStepRequest(session_id=session_id, retry_key=f"{n}".encode())
    request.inputs.dt = 0.01
    request.inputs.outputs.append(ewave_pb2.EWAVE_OUTPUT_HEIGHT)
    circle = request.inputs.shapes.add().circle
    circle.center_x, circle.center_y, circle.radius = 0.1 + 0.02 * n, 0.16, 0.03
    return request


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> List[bytes]:
    """The steps' height fields from one session on one plain squalld that nothing interrupts."""
    directory = tmp_path_factory.mktemp("reference")
    plain = Replica("reference", directory / "state", directory)
    try:
        wait_for(lambda: serving(plain.address), 300, "the reference squalld SERVING")
        with squall.Client(plain.address) as client:
            stub = ewave_pb2_grpc.EWaveStub(client.channel)
            session = stub.CreateSession(create_request())
            return [
                stub.Step(step_request(session.session_id, n)).fields[0].data for n in range(STEPS)
            ]
    finally:
        plain.stop()


def step(
    cluster: Cluster, session_id: str, n: int, retry_seconds: float
) -> Tuple[bytes, str, int]:
    """One step through the proxy: its height bytes, the replica, and how many times the test
    itself had to call again (nginx: UNAVAILABLE outlasting the channel's retry policy, or a call
    that reached the victim as its server closed, which gRPC cancels before squalld sees it and
    the Python client sends again)."""
    md = ((SESSION_KEY, session_id),)
    deadline, again = time.monotonic() + retry_seconds, 0
    while True:
        try:
            frame, call = cluster.ewave.Step.with_call(
                step_request(session_id, n), metadata=md, timeout=30
            )
            return frame.fields[0].data, replica_of(call), again
        except grpc.RpcError as error:
            retryable = error.code() == grpc.StatusCode.UNAVAILABLE or cancelled_unanswered(error)
            if not retryable or time.monotonic() > deadline:
                raise
            again += 1
            time.sleep(0.2)


def test_stateless_calls_spread_over_the_replicas(cluster: Cluster) -> None:
    served: Counter = Counter()
    for _ in range(300):
        _, call = cluster.ocean.SampleSurface.with_call(sample_request(), timeout=30)
        served[replica_of(call)] += 1
    assert set(served) == {"r0", "r1", "r2"}, served
    assert min(served.values()) >= 0.2 * 300, served


def test_sessions_stick_and_move_bit_for_bit_on_sigterm(
    cluster: Cluster, reference: List[bytes]
) -> None:
    ids = [propose_session_id() for _ in range(SESSIONS)]
    homes: Dict[str, str] = {}
    for session_id in ids:
        created, call = cluster.ewave.CreateSession.with_call(
            create_request(), metadata=((SESSION_KEY, session_id),), timeout=30
        )
        assert created.session_id == session_id
        homes[session_id] = replica_of(call)
    for n in range(DRAIN_AT):
        for session_id in ids:
            height, replica, again = step(cluster, session_id, n, 0)
            assert replica == homes[session_id], "a session's calls stick to its replica"
            assert height == reference[n]

    busiest = Counter(homes.values()).most_common(1)[0][0]
    victim = next(r for r in cluster.replicas if r.name == busiest)
    os.kill(victim.pid, signal.SIGTERM)
    signalled = time.monotonic()
    # nginx only fails over once the draining replica's port closes (--drain-wait 2 s); the
    # channel's own retries may run out before that, so the test calls again for that long, as it
    # does (as the Python client does) when a call reaches the victim as its server closes.
    patience = 0 if cluster.kind == "envoy" else 15
    # The replicas that served each session other than the victim, in turn, per state of the proxy's
    # ring (with the victim, without it).
    served: Dict[Tuple[bool, str], List[str]] = {}
    for n in range(DRAIN_AT, STEPS):
        if n == DRAIN_AT + 1 and cluster.kind == "envoy":  # the later steps on Envoy's new ring
            wait_for(lambda: cluster.ring_without(victim), 30, "Envoy's ring without the victim")
        for session_id in ids:
            ring = cluster.ring_without(victim)
            height, replica, again = step(cluster, session_id, n, patience)
            assert height == reference[n], f"{session_id} step {n} differs from the reference"
            if ring != cluster.ring_without(victim):
                continue  # the ring changed during the call
            if replica == busiest:
                # the victim serves its sessions until its drain wrote them, none from then on
                assert homes[session_id] == busiest and not ring
                assert (ring, session_id) not in served, "a moved session went back to the victim"
                continue
            if homes[session_id] != busiest and not ring:
                assert replica == homes[session_id], "the other sessions stay where they were"
            served.setdefault((ring, session_id), []).append(replica)
    # On the ring with the victim a session stays on one replica. On the ring without it (Envoy's
    # later one), it moves at most once from where it was: to the replica that ring picks, once the
    # one that served it before has handed it over; never back.
    for (ring, session_id), replicas in served.items():
        before = [] if not ring else served.get((False, session_id), [])[-1:]
        replicas = before + replicas
        runs = [r for i, r in enumerate(replicas) if i == 0 or replicas[i - 1] != r]
        assert len(runs) <= (
            2 if ring else 1
        ), f"{session_id} moved {len(runs) - 1} times: {replicas}"
    assert victim.popen.wait(GRACE + 5) == 0, victim.log.read_text()[-3000:]
    assert time.monotonic() - signalled < GRACE + 5
    moved = {i for _, i in served if homes[i] == busiest}
    assert len(moved) == Counter(homes.values())[busiest] >= 1, "every session of the victim moved"


def test_calls_survive_a_replica_draining_under_load(cluster: Cluster) -> None:
    """Eight threads sample the surface through one squall.Client while a replica is SIGTERM'd and
    goes. The channel's retry policy sends UNAVAILABLE (draining, a proxy's 502) elsewhere; the
    client itself sends again a call that reached the replica as its server closed, which gRPC
    cancels before squalld sees it (nginx passes that on, rarely: the resend's own test is
    test_routing.py's). Behind Envoy every call succeeds. nginx keeps sending calls to the replica
    until its port closes, and picks a replica per attempt: the five attempts of a few calls all
    reach it (1 of 3,608 in one CI run), which come back UNAVAILABLE naming the drain; never
    anything else."""
    request, stop = sample_request(), threading.Event()
    answered: List[int] = []
    errors: List[str] = []

    def sample(client: squall.Client) -> None:
        while not stop.is_set():
            try:
                answered.append(len(client.ocean.sample(request=request)["height"]))
            except squall.SquallError as error:
                errors.append(str(error))

    victim = cluster.replicas[0]
    with squall.Client(cluster.address) as client:
        threads = [threading.Thread(target=sample, args=(client,)) for _ in range(8)]
        for thread in threads:
            thread.start()
        try:
            time.sleep(1)
            os.kill(victim.pid, signal.SIGTERM)
            exited = victim.popen.wait(GRACE + 5)
            time.sleep(1)
        finally:
            stop.set()
            for thread in threads:
                thread.join()
    assert exited == 0, victim.log.read_text()[-3000:]
    failed = f"{len(errors)} of {len(errors) + len(answered)} calls failed: {errors[:3]}"
    if cluster.kind == "envoy":
        assert not errors, failed
    else:
        assert all(e.endswith("UNAVAILABLE: " + DRAINING) for e in errors), failed
        assert len(errors) <= 0.01 * len(answered), failed
    assert len(answered) >= 100 and set(answered) == {1}
