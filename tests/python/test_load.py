"""A bounded load on one squalld with four device queues (four requests' device work at once) from eight
clients at once: ocean tiles and samples, eWave sessions stepping, cloud renders, mixed, for
SQUALL_LOAD_SECONDS (default 20 s; a longer soak: set it). Asserts no unexpected error, every eWave
session's frames identical to the same steps run alone (concurrent calls do not mix their state), every
tile, sample and render bit-identical to the same request made alone before the load (concurrent
requests do not mix their kernel arguments or buffers), the daemon SERVING afterwards, its resident
memory after the run at most 64 MiB above what it was after a 15 s warm-up with the same load, not
counting what its caches took meanwhile (no leak per call), and hardly any thread started during
the run (the threads of the warm-up serve its calls).
Runs once with each of two FFT backends: fftw on the CPU device (what --fft auto picks there on the
machines measured) and vkfft on the default device; the soak with fftw.
Prints the calls made and the p50 / p99 latency per kind."""

from __future__ import annotations

import os
import re
import statistics
import threading
import time
from typing import Any, Callable, Dict, Iterator, List, Mapping, Set, Tuple

import numpy as np
import pytest

import squall
from conftest import Daemon, _start
from exposition import http_get, value
from test_ewave import config, hull_inputs
from test_ocean import small_tile

CLIENTS = 8
SECONDS = float(os.environ.get("SQUALL_LOAD_SECONDS", "20"))
RSS_GROWTH = 64 << 20


def resident_bytes(pid: int) -> int:
    with open(f"/proc/{pid}/status") as status:
        line = next(l for l in status if l.startswith("VmRSS:"))
    return int(line.split()[1]) * 1024


def scrape(daemon: Daemon) -> str:
    """The daemon's /metrics (its port from its log)."""
    port = re.search(r"/metrics \(port (\d+)\)", daemon.log_path.read_text())
    assert port, "squalld logs its metrics port"
    return http_get(f"http://127.0.0.1:{port.group(1)}/metrics")


def cached_bytes(daemon: Daemon) -> int:
    """What the daemon's caches keep for the next calls (squall_memory_cached_bytes): idle buffers,
    spectra, propagators, plans, within the memory budget."""
    return int(value(scrape(daemon), "squall_memory_cached_bytes"))


def ewave_run(client: squall.Client, steps: int = 4) -> List[bytes]:
    with client.ewave.session(**config()) as session:
        return [session.step(**hull_inputs(n))["height"].tobytes() for n in range(steps)]


def fields(result: Mapping[str, Any]) -> Dict[str, bytes]:
    """A tile's or samples' fields as bytes, for bit-for-bit comparison."""
    return {name: np.asarray(values).tobytes() for name, values in result.items()}


def requests(client: squall.Client) -> Dict[str, Callable[[], Any]]:
    """The load's calls, each returning its result as comparable bytes."""
    spec = small_tile()
    model = squall.clouds.model(spheres=[(0, 0, 0, 6)])
    camera = squall.clouds.camera(eye=(0, -30, 0), width=8, height=8)
    return {
        "tile": lambda: fields(client.ocean.tile(spec, time=1.0)),
        "sample": lambda: fields(client.ocean.sample(spec, [[1.0, 2.0]], time=1.0)),
        "ewave": lambda: ewave_run(client),
        "render": lambda: client.clouds.render(model, camera=camera).pixels.tobytes(),
    }


def references(address: str) -> Dict[str, Any]:
    """Every call's result made alone, one at a time."""
    with squall.Client(address, timeout=120) as client:
        return {name: call() for name, call in requests(client).items()}


class ThreadWatch:
    """The thread ids of process `pid` seen by reading /proc every 20 ms while the `with` block runs:
    the trace of threads that squalld starts for a call and ends after it."""

    def __init__(self, pid: int) -> None:
        self.pid = pid
        self.seen: Set[str] = set()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch)

    def _watch(self) -> None:
        while not self._stop.wait(0.02):
            self.seen |= set(os.listdir(f"/proc/{self.pid}/task"))

    def __enter__(self) -> "ThreadWatch":
        self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self._stop.set()
        self._thread.join()


def load(address: str, reference: Dict[str, Any], seconds: float) -> Dict[str, List[float]]:
    """CLIENTS threads, each a client with its own connection, calling for `seconds`; the latencies
    by kind. Fails on any error (a call's, or a client's outside its calls) or any result that
    differs from its reference."""
    latencies: Dict[str, List[float]] = {}
    errors: List[BaseException] = []
    lock = threading.Lock()
    deadline = time.monotonic() + seconds

    def worker(index: int) -> None:
        try:  # the client's own connection, as a remote client's
            with squall.Client(address, timeout=120, own_connection=True) as client:
                kinds = list(requests(client).items())
                n = index
                while time.monotonic() < deadline and not errors:
                    name, call = kinds[n % len(kinds)]
                    start = time.monotonic()
                    assert call() == reference[name], f"a {name} changed under load"
                    with lock:
                        latencies.setdefault(name, []).append(time.monotonic() - start)
                    n += 1
        except BaseException as error:  # noqa: B902 - a call's or the client's; the test fails
            with lock:
                errors.append(error)

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(CLIENTS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(seconds + 300)
    assert not errors, f"{len(errors)} calls failed, first: {errors[0]!r}"
    assert set(latencies) == set(reference), latencies.keys()
    return latencies


@pytest.fixture(scope="module", params=["vkfft", "fftw"])
def concurrent_daemon(request: pytest.FixtureRequest) -> Iterator[Tuple[Daemon, str]]:
    """A squalld whose device runs up to four requests at once, each on its own queue: fftw on the CPU
    device (which it threads and whose plans its queues share) or vkfft (device kernels) on the
    default device."""
    fft = request.param
    device = ["--device", "cpu"] if fft == "fftw" else []  # fftw runs on CPU devices only
    flags = ["--device-queues", "4", "--fft", fft, "--metrics-listen", "127.0.0.1:0", *device]
    for daemon in _start(flags, f"queues-{fft}"):
        yield daemon, fft


def test_eight_clients_mixed_calls(concurrent_daemon: Tuple[Daemon, str]) -> None:
    daemon, fft = concurrent_daemon
    with squall.Client(daemon.address) as probe:
        info = probe.info()
        assert (info.device_queues, info.fft_backend) == (4, fft)
    reference = references(daemon.address)
    # Warm-up: the same load for a while, so that every thread's allocator arena, gRPC's thread
    # pool and the plan caches reach their working size before memory is compared. With vkfft the
    # resident memory climbs for about 2000 calls (13 s here), then moves within about 20 MiB of
    # its level: 5 s left it 26-88 MiB below.
    load(daemon.address, reference, min(15.0, SECONDS))
    before, cached_before = resident_bytes(daemon.pid), cached_bytes(daemon)
    threads = set(os.listdir(f"/proc/{daemon.pid}/task"))
    with ThreadWatch(daemon.pid) as watch:
        latencies = load(daemon.address, reference, SECONDS)
    started = watch.seen - threads
    print(f"threads: {len(threads)} after warm-up, {len(started)} started during the load")
    for name, values in sorted(latencies.items()):
        p99 = np.percentile(values, 99)
        print(
            f"{name}: {len(values)} calls, p50 {statistics.median(values):.4f} s, p99 {p99:.4f} s"
        )

    with squall.Client(daemon.address) as after:
        assert after.health() == "SERVING"
        assert ewave_run(after) == reference["ewave"]
    growth, cached = resident_bytes(daemon.pid) - before, cached_bytes(daemon) - cached_before
    print(
        f"resident memory: {before >> 20} MiB after warm-up, {growth / 2**20:+.1f} MiB after the"
        f" load, of which the caches {cached / 2**20:+.1f} MiB"
    )
    assert (
        growth - cached < RSS_GROWTH
    ), f"squalld grew by {growth >> 20} MiB under load, {cached >> 20} MiB in its caches"
    # gRPC's threads wait for the next call (--rpc-threads) rather than end after each, and NanoVDB's
    # conversions run on TBB's pool: without either, 27 to 290 threads started a second. A few helper
    # threads of gRPC's own may come and go.
    assert (
        len(started) <= 8 + SECONDS / 4
    ), f"squalld started {len(started)} threads during the load"
