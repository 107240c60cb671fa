"""Routing through a session-affine proxy, from the client's side: sessions are created under ids
the client proposes (x-squall-session on the creating call, taken by squalld), every response names
its replica (x-squall-replica), the channel retries UNAVAILABLE, and the client sends again a call
that gRPC cancelled before squalld saw it. The retries at work, with several replicas behind a real
proxy: tests/deploy/test_replicas.py."""

from __future__ import annotations

import asyncio
import gc
import json
import os
import re
import threading
import time
from concurrent import futures
from typing import Any, Callable, Dict, List, Tuple

import grpc
import pytest

import squall
import squall.aio
from squall._calls import retry_options
from squall._errors import REPLICA_KEY
from squall.v1 import clouds_pb2_grpc, ewave_pb2, ewave_pb2_grpc, server_pb2, server_pb2_grpc

from conftest import Daemon


def created_ids(log: str, method: str) -> List[Tuple[str, str]]:
    """(status, x-squall-session) of every `method` call in squalld's request log."""
    pattern = rf"method=/squall\.v1\.{method} status=(\w+) .*? session=(\S+)"
    return re.findall(pattern, log)


def test_sessions_take_the_ids_the_client_proposes(client: squall.Client, daemon: Daemon) -> None:
    with client.ewave.session(nx=16, ny=16, dx=0.1) as session:
        restored = client.ewave.restore(session.state())
        restored.close()
    volume = client.clouds.build(
        dict(voxel_size=0.5, spheres=[dict(radius=2)]), keep=True
    )  # a stored volume: "cloud-" and 32 hex digits
    camera = squall.clouds.camera((0, -20, 0), (0, 0, 0), (0, 0, 1), width=8, height=8)
    client.clouds.render(volume, camera=camera)  # the stored volume's calls name it too
    client.clouds.release(volume.id)
    log = daemon.log()
    assert ("OK", session.id) in created_ids(log, "EWave/CreateSession")
    assert ("OK", restored.id) in created_ids(log, "EWave/Restore")
    assert ("OK", volume.id) in created_ids(log, "Clouds/BuildVolume")
    assert ("OK", volume.id) in created_ids(log, "Clouds/Render")
    assert ("OK", volume.id) in created_ids(log, "Clouds/ReleaseVolume")
    assert re.fullmatch(r"[0-9a-f]{32}", session.id) and re.fullmatch(
        r"cloud-[0-9a-f]{32}", volume.id
    )
    assert session.id != restored.id


def expect_already_exists(call: Callable[[], Any], message: str) -> None:
    with pytest.raises(grpc.RpcError) as error:
        call()
    assert error.value.code() == grpc.StatusCode.ALREADY_EXISTS
    assert error.value.details() == message


def test_a_proposed_id_that_is_taken_already_exists(client: squall.Client) -> None:
    """A creating call that proposes the id of a live session or stored volume gets ALREADY_EXISTS
    naming the metadata, and what lives under that id is left as it was."""
    ewave = ewave_pb2_grpc.EWaveStub(client.channel)
    with client.ewave.session(nx=16, ny=16, dx=0.1) as session:
        session.step(0.02)
        taken = (("x-squall-session", session.id),)
        message = f'metadata x-squall-session = "{session.id}" is already a live eWave session'
        create = ewave_pb2.EWaveCreateSessionRequest(
            config=squall.ewave.config(nx=8, ny=8, dx=0.1)
        )
        expect_already_exists(lambda: ewave.CreateSession(create, metadata=taken), message)
        restore = squall.ewave.restore_request(session.state())
        expect_already_exists(lambda: ewave.Restore(restore, metadata=taken), message)
        assert session.step(0.02).step == 2
    clouds = clouds_pb2_grpc.CloudsStub(client.channel)
    volume = client.clouds.build(dict(voxel_size=0.5, spheres=[dict(radius=2)]), keep=True)
    # A model whose build takes about a second, refused within a deadline of a fifth of that: the id
    # is checked before the build.
    large = dict(voxel_size=0.25, spheres=[dict(radius=80)])
    build = squall.clouds.build_request(large, keep=True, return_vdb=False, request=None)
    message = f'metadata x-squall-session = "{volume.id}" is already a live stored volume'
    taken = (("x-squall-session", volume.id),)
    expect_already_exists(lambda: clouds.BuildVolume(build, metadata=taken, timeout=0.2), message)
    client.clouds.release(volume.id)


def test_a_creating_call_proposes_one_id(client: squall.Client) -> None:
    """Two x-squall-session values on a creating call: a proxy may route on one and squalld take the
    other, so the call is refused by name."""
    ewave = ewave_pb2_grpc.EWaveStub(client.channel)
    create = ewave_pb2.EWaveCreateSessionRequest(config=squall.ewave.config(nx=8, ny=8, dx=0.1))
    twice = (("x-squall-session", "1" * 32), ("x-squall-session", "2" * 32))
    with pytest.raises(grpc.RpcError) as error:
        ewave.CreateSession(create, metadata=twice)
    assert error.value.code() == grpc.StatusCode.INVALID_ARGUMENT
    assert error.value.details().startswith("metadata x-squall-session is given 2 times")


def test_every_response_names_its_replica(daemon: Daemon) -> None:
    with squall.Client(daemon.address) as client:
        stub = server_pb2_grpc.ServerStub(client.channel)
        info, call = stub.GetInfo.with_call(server_pb2.GetInfoRequest())
    replica = dict(call.initial_metadata())[REPLICA_KEY]
    assert replica and replica == info.replica_id  # default "hostname:pid<N>" for --listen port 0
    with squall.Client(daemon.address) as client:
        with pytest.raises(squall.SquallError) as error:  # a refusal names it in its trailers
            client.ewave.attach("0" * 32).step(0.02)
    assert error.value.code == grpc.StatusCode.NOT_FOUND and error.value.replica == replica
    with squall.Client(daemon.address) as client:
        with client.ewave.session(nx=16, ny=16, dx=0.1) as session:
            with pytest.raises(squall.SquallError) as error:  # after a frame: the initial metadata
                list(session.run([0.02, -1.0]))
    assert "message 1" in error.value.message and error.value.replica == replica


def test_the_retry_policy_retries_unavailable_only() -> None:
    options: Dict[str, Any] = dict(retry_options(5))
    config = json.loads(options["grpc.service_config"])["methodConfig"][0]
    assert options["grpc.enable_retries"] == 1
    assert config["retryPolicy"]["retryableStatusCodes"] == ["UNAVAILABLE"]
    assert config["retryPolicy"]["maxAttempts"] == 5
    assert {"service": "squall.v1.EWave"} in config["name"]
    # one attempt: no retry policy, as the C++ client; gRPC's transparent retries (of calls that
    # never reached a server) stay on
    assert retry_options(1) == []


class ClosingServer:
    """A real gRPC server whose health check answers as a squalld replica whose server is closing
    (gRPC cancels a call that reaches it then, before squalld sees it: CANCELLED and no
    x-squall-replica) for the first `cancels` calls, then SERVING. `named`: its CANCELLED names a
    replica, as one squalld itself makes."""

    def __init__(self, cancels: int, named: bool = False) -> None:
        self.cancels, self.named, self.calls = cancels, named, 0
        handler = grpc.unary_unary_rpc_method_handler(self.check)  # bytes in, bytes out
        service = grpc.method_handlers_generic_handler("grpc.health.v1.Health", {"Check": handler})
        self.server = grpc.server(futures.ThreadPoolExecutor(2), handlers=(service,))
        self.address = f"127.0.0.1:{self.server.add_insecure_port('127.0.0.1:0')}"
        self.server.start()

    def check(self, request: bytes, context: grpc.ServicerContext) -> bytes:
        self.calls += 1
        if self.calls > self.cancels:
            return b"\x08\x01"  # HealthCheckResponse { status: SERVING }
        if self.named:
            context.set_trailing_metadata(((REPLICA_KEY, "r0"),))
        context.abort(grpc.StatusCode.CANCELLED, "CANCELLED")

    def __enter__(self) -> "ClosingServer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.server.stop(None)


async def health_of(address: str) -> str:
    async with squall.aio.Client(address) as client:
        return await client.health()


def test_a_call_cancelled_before_squalld_saw_it_is_sent_again() -> None:
    """Within the client's retries and the call's deadline, with the retry policy's backoff; a
    CANCELLED that names a replica (squalld's own) is not."""
    with ClosingServer(cancels=2) as server, squall.Client(server.address) as client:
        assert client.health() == "SERVING" and server.calls == 3
    with ClosingServer(cancels=2) as server:
        assert asyncio.run(health_of(server.address)) == "SERVING" and server.calls == 3
    with ClosingServer(cancels=9) as server, squall.Client(server.address, retries=3) as client:
        start = time.monotonic()
        with pytest.raises(squall.SquallError) as error:
            client.health()
        assert error.value.code == grpc.StatusCode.CANCELLED and server.calls == 3
        assert 0.3 <= time.monotonic() - start < 2  # paused 0.1 s, then 0.2 s
    with ClosingServer(cancels=9) as server, squall.Client(server.address) as client:
        start = time.monotonic()
        with pytest.raises(squall.SquallError) as error:
            client.health(timeout=0.75)  # sent at 0, 0.1, 0.3, 0.7 s; not 1.5 s, past the deadline
        assert error.value.code == grpc.StatusCode.CANCELLED
        assert server.calls <= 4 and time.monotonic() - start < 1.3
    with ClosingServer(cancels=9) as server, squall.Client(server.address) as client:
        threading.Timer(0.15, client.close).start()  # during the pause after the second send
        with pytest.raises(RuntimeError, match="closed"):
            client.health()
        assert server.calls == 2
    with ClosingServer(cancels=1, named=True) as server, squall.Client(server.address) as client:
        with pytest.raises(squall.SquallError) as error:
            client.health()
        assert error.value.code == grpc.StatusCode.CANCELLED and error.value.replica == "r0"
        assert server.calls == 1


def test_a_texture_that_follows_an_ewave_session_names_it(
    client: squall.Client, daemon: Daemon
) -> None:
    """AdvectTexture and AdvectInteractive on an eWave session's current send x-squall-session, so
    that a session-affine proxy routes them to the replica that holds the session."""
    with client.ewave.session(nx=16, ny=16, dx=0.1) as session:
        frames = list(client.textures.advect(velocity=session, frames=1, size=(16, 16)))
        with client.textures.interactive(velocity=session.id, size=(16, 16)) as run:
            run.send(frames=1)
        assert len(frames) == 1
    log = daemon.log()
    assert ("OK", session.id) in created_ids(log, "Textures/AdvectTexture")
    assert ("OK", session.id) in created_ids(log, "Textures/AdvectInteractive")


def connections_to(port: int) -> int:
    """This process's established TCP connections to 127.0.0.1:`port`: its sockets (by inode) in
    /proc/net/tcp and tcp6 (gRPC's are IPv6 with the IPv4-mapped address), addresses in hex."""
    inodes = set()
    for fd in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[len("socket:[") : -1])
    remotes = {f"0100007F:{port:04X}", f"0000000000000000FFFF00000100007F:{port:04X}"}
    count = 0
    for table in ("/proc/self/net/tcp", "/proc/self/net/tcp6"):
        with open(table) as lines:
            for line in list(lines)[1:]:
                fields = line.split()  # sl, local, remote, state (01: ESTABLISHED), ..., inode
                count += fields[2] in remotes and fields[3] == "01" and fields[9] in inodes
    return count


def test_clients_share_a_connection_unless_asked_for_their_own(daemon: Daemon) -> None:
    """As the C++ client's own_connection: a load generator's clients each have their own
    connection (a balancer in front spreads connections, not calls)."""
    gc.collect()  # earlier tests' clients closed now, not while this one counts
    before = connections_to(daemon.port)
    options = [("squall.test.pair", 1)]  # shares no connection with the other tests' clients
    shared = [squall.Client(daemon.address, options=options) for _ in range(2)]
    own = [squall.Client(daemon.address, options=options, own_connection=True) for _ in range(2)]
    try:
        for c in shared + own:
            assert c.health() == "SERVING"
        assert connections_to(daemon.port) - before == 1 + 2
    finally:
        for c in shared + own:
            c.close()
