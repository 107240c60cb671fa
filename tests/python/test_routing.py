"""Routing through a session-affine proxy, from the client's side: sessions are created under ids
the client proposes (x-squall-session on the creating call, taken by squalld), every response names
its replica (x-squall-replica), and the channel retries UNAVAILABLE. The retries at work, with
several replicas behind a real proxy: tests/deploy/test_replicas.py."""

from __future__ import annotations

import json
import re
from typing import Any, Dict, List, Tuple

import squall
from squall._calls import REPLICA_KEY, retry_options
from squall.v1 import server_pb2, server_pb2_grpc

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


def test_every_response_names_its_replica(daemon: Daemon) -> None:
    with squall.Client(daemon.address) as client:
        stub = server_pb2_grpc.ServerStub(client.channel)
        info, call = stub.GetInfo.with_call(server_pb2.GetInfoRequest())
    replica = dict(call.initial_metadata())[REPLICA_KEY]
    assert replica and replica == info.replica_id  # default "hostname:pid<N>" for --listen port 0


def test_the_retry_policy_retries_unavailable_only() -> None:
    options: Dict[str, Any] = dict(retry_options(5))
    config = json.loads(options["grpc.service_config"])["methodConfig"][0]
    assert options["grpc.enable_retries"] == 1
    assert config["retryPolicy"]["retryableStatusCodes"] == ["UNAVAILABLE"]
    assert config["retryPolicy"]["maxAttempts"] == 5
    assert {"service": "squall.v1.EWave"} in config["name"]
    assert dict(retry_options(1)) == {"grpc.enable_retries": 0}


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
