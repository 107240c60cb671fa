"""A bounded load on one squalld from eight clients at once: ocean tiles and samples, eWave sessions
stepping, cloud renders, mixed, for SQUALL_LOAD_SECONDS (default 20 s; a longer soak: set it). Asserts
no unexpected error, every eWave session's frames identical to the same steps run alone (concurrent
calls do not mix their state), the daemon SERVING afterwards, and its resident memory after the run at
most 64 MiB above what it was after a warm-up with the same load (no leak per call). Prints the
calls made and the p50 / p99 latency per kind."""

from __future__ import annotations

import os
import statistics
import threading
import time
from typing import Callable, Dict, List

import numpy as np

import squall
from conftest import Daemon
from test_ewave import config, hull_inputs
from test_ocean import small_tile

CLIENTS = 8
SECONDS = float(os.environ.get("SQUALL_LOAD_SECONDS", "20"))
RSS_GROWTH = 64 << 20


def resident_bytes(pid: int) -> int:
    with open(f"/proc/{pid}/status") as status:
        line = next(l for l in status if l.startswith("VmRSS:"))
    return int(line.split()[1]) * 1024


def ewave_run(client: squall.Client, steps: int = 4) -> List[bytes]:
    with client.ewave.session(**config()) as session:
        return [session.step(**hull_inputs(n))["height"].tobytes() for n in range(steps)]


def calls(client: squall.Client, reference: List[bytes]) -> Dict[str, Callable[[], None]]:
    spec = small_tile()
    model = squall.clouds.model(spheres=[(0, 0, 0, 6)])
    camera = squall.clouds.camera(eye=(0, -30, 0), width=8, height=8)

    def ewave() -> None:
        assert ewave_run(client) == reference, "a session's frames changed under load"

    def sample() -> None:
        assert np.isfinite(client.ocean.sample(spec, [[1.0, 2.0]], time=1.0)["height"]).all()

    return {
        "tile": lambda: client.ocean.tile(spec, time=1.0),
        "sample": sample,
        "ewave": ewave,
        "render": lambda: client.clouds.render(model, camera=camera),
    }


def load(address: str, reference: List[bytes], seconds: float) -> Dict[str, List[float]]:
    """CLIENTS threads calling for `seconds`; the latencies by kind. Fails on any error."""
    latencies: Dict[str, List[float]] = {}
    errors: List[BaseException] = []
    lock = threading.Lock()
    deadline = time.monotonic() + seconds

    def worker(index: int) -> None:
        with squall.Client(address, timeout=120) as client:
            kinds = list(calls(client, reference).items())
            n = index
            while time.monotonic() < deadline and not errors:
                name, call = kinds[n % len(kinds)]
                start = time.monotonic()
                try:
                    call()
                except BaseException as error:  # noqa: B902 - reported below, the test fails
                    with lock:
                        errors.append(error)
                    return
                with lock:
                    latencies.setdefault(name, []).append(time.monotonic() - start)
                n += 1

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(CLIENTS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(seconds + 300)
    assert not errors, f"{len(errors)} calls failed, first: {errors[0]!r}"
    assert set(latencies) == {"tile", "sample", "ewave", "render"}, latencies.keys()
    return latencies


def test_eight_clients_mixed_calls(daemon: Daemon) -> None:
    with squall.Client(daemon.address, timeout=120) as first:
        reference = ewave_run(first)
    # Warm-up: the same load for a while, so that every thread's allocator arena, gRPC's thread pool
    # and the plan caches reach their working size before memory is compared.
    load(daemon.address, reference, min(5.0, SECONDS))
    before = resident_bytes(daemon.pid)
    latencies = load(daemon.address, reference, SECONDS)
    for name, values in sorted(latencies.items()):
        p99 = np.percentile(values, 99)
        print(
            f"{name}: {len(values)} calls, p50 {statistics.median(values):.4f} s, p99 {p99:.4f} s"
        )

    with squall.Client(daemon.address) as after:
        assert after.health() == "SERVING"
        assert ewave_run(after) == reference
    growth = resident_bytes(daemon.pid) - before
    print(
        f"resident memory: {before >> 20} MiB after warm-up, {growth / 2**20:+.1f} MiB after the load"
    )
    assert growth < RSS_GROWTH, f"squalld grew by {growth >> 20} MiB under load"
