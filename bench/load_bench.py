"""Concurrent clients against one squalld on loopback: 1, 2, 4, 8 and 16 clients, each with its own
connection, calling in turn GetTile (256 x 256, height and normals), an eWave Step (256 x 256, its own
session) and a cloud Render (64 x 64, a stored volume) for --seconds per level. The levels run in turn
--rounds times, so that a slow spell of a shared machine does not fall on one level alone. Prints per
level the median over rounds of the calls per second of all clients together and its ratio to one
client's, p50 / p99 latency per method over all rounds' calls and the errors; then the goals: throughput
never falls as clients are added (no collapse), p99 at 8 clients at most 10x the p50 at 1 client, zero
errors. Run with the Python of the client's venv, nothing else on the cores:

    build/tests/python/venv/bin/python bench/load_bench.py [--seconds 10] [--rounds 3]
        [--clients 1,2,4,8,16] [--client cpp|python] [--squalld build/squalld] [--device-queues N]
        [--squalld-flags "--fft-threads 1"]

The clients are C++ threads (build/bench/load_client, the default) or Python threads of the squall
package (--client python): both send the same requests, built here by the Python client. On a machine
whose few cores the clients share with squalld, the Python clients take a third of them, so the C++
clients measure the server and the Python ones what a Python caller sees.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable, Dict, List

import numpy as np
from google.protobuf.message import Message

import squall
from python_client_bench import ROOT, Daemon
from squall._pb import ewave_pb2

METHODS = ("GetTile", "Step", "Render")


def quantile(values: List[float], q: float) -> float:
    return float(np.quantile(values, q)) if values else float("nan")


class Level:
    """One level's calls: latencies (s) per method, errors, wall time; over several rounds, the calls
    per second of each round."""

    def __init__(self) -> None:
        self.latencies: Dict[str, List[float]] = {m: [] for m in METHODS}
        self.errors: List[str] = []
        self.lock = threading.Lock()
        self.seconds = 0.0
        self.rates: List[float] = []

    def calls(self) -> int:
        return sum(len(v) for v in self.latencies.values())

    def add_round(self, other: "Level") -> None:
        for m in METHODS:
            self.latencies[m] += other.latencies[m]
        self.errors += other.errors
        self.rates.append(other.calls() / other.seconds)

    def rate(self) -> float:
        """The median over rounds of the calls per second."""
        return statistics.median(self.rates)


def requests(volume: str) -> Dict[str, Message]:
    """Every client's calls, as the Python client builds them: a GetTile, the creation of an eWave
    session and a Step in it (its session id left to each client), a Render of the stored volume.
    """
    tile = squall.ocean.tile_spec([squall.ocean.layer(extent=500, n=256, wind_speed=12, seed=3)])
    camera = squall.clouds.camera(eye=(0, -30, 0), width=64, height=64)
    hull = squall.ewave.ellipse(5.0, 5.0, 0.6, 0.2)
    inputs = squall.ewave.as_inputs(None, 0.02, shapes=[hull], outputs=("height",))
    return {
        "tile": squall.ocean.tile_request(tile, time=1.0, outputs=("height", "normal_z")),
        "session": ewave_pb2.EWaveCreateSessionRequest(
            config=squall.ewave.as_config(nx=256, ny=256, dx=0.05)
        ),
        "step": ewave_pb2.EWaveStepRequest(inputs=inputs),
        "render": squall.clouds.render_request(volume, None, {"camera": camera}, None),
    }


def python_client(address: str, calls: Dict[str, Message], seconds: float, level: Level) -> None:
    """One client: its own connection (as load_client's), its own eWave session. A failure outside
    the timed calls (the connection, the session) is counted as an error too."""
    try:
        with squall.Client(address, timeout=600, own_connection=True) as client:
            with client.ewave.session(calls["session"].config) as session:
                methods: Dict[str, Callable[[], object]] = {
                    "GetTile": lambda: client.ocean.tile(request=calls["tile"]),
                    "Step": lambda: session.step(inputs=calls["step"].inputs),
                    "Render": lambda: client.clouds.render(request=calls["render"]),
                }
                deadline = time.monotonic() + seconds
                n = 0
                while time.monotonic() < deadline:
                    method = METHODS[n % len(METHODS)]
                    n += 1
                    start = time.perf_counter()
                    try:
                        methods[method]()
                    except squall.SquallError as error:
                        with level.lock:
                            level.errors.append(f"{method}: {error}")
                        continue
                    with level.lock:
                        level.latencies[method].append(time.perf_counter() - start)
    except Exception as error:  # the thread would end silently, its calls missing
        with level.lock:
            level.errors.append(f"client: {error!r}")


def python_level(address: str, calls: Dict[str, Message], clients: int, seconds: float) -> Level:
    """`clients` threads of this process, each with its own squall.Client and connection."""
    level = Level()
    threads = [
        threading.Thread(target=python_client, args=(address, calls, seconds, level))
        for _ in range(clients)
    ]
    start = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    level.seconds = time.perf_counter() - start
    return level


def cpp_level(
    load_client: Path, address: str, directory: Path, clients: int, seconds: float
) -> Level:
    """`clients` threads of build/bench/load_client, which replays the requests in `directory`."""
    argv = [str(load_client), "--address", address, "--requests", str(directory)]
    argv += ["--clients", str(clients), "--seconds", str(seconds)]
    out = subprocess.run(argv, check=True, capture_output=True, text=True).stdout
    level = Level()
    level.seconds = seconds
    for line in out.splitlines():
        word, _, rest = line.partition(" ")
        if word == "error":
            level.errors.append(rest)
        elif word in level.latencies:
            level.latencies[word] = [1e-6 * float(us) for us in rest.split()]
    return level


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10, help="per level and round")
    parser.add_argument(
        "--rounds",
        type=int,
        default=3,
        help="levels run in turn this many times; medians of calls/s",
    )
    parser.add_argument("--clients", default="1,2,4,8,16")
    parser.add_argument("--client", choices=("cpp", "python"), default="cpp")
    parser.add_argument("--squalld", type=Path, default=ROOT / "build" / "squalld")
    parser.add_argument(
        "--load-client", type=Path, default=ROOT / "build" / "bench" / "load_client"
    )
    parser.add_argument(
        "--device-queues", type=int, default=0, help="squalld --device-queues (0: its default)"
    )
    parser.add_argument(
        "--squalld-flags", default="", help='more squalld flags, e.g. "--fft-threads 1"'
    )
    args = parser.parse_args()
    flags = ["--device-queues", str(args.device_queues)] if args.device_queues > 0 else []
    flags += args.squalld_flags.split()
    counts = [int(c) for c in args.clients.split(",")]
    with tempfile.TemporaryDirectory() as directory:
        daemon = Daemon(args.squalld, Path(directory), flags)
        try:
            with squall.Client(daemon.address, timeout=600) as client:
                client.wait_until_serving(300)
                info = client.info()
                device = next(d.name for d in info.devices if d.selected)
                volume = client.clouds.build(
                    squall.clouds.model(spheres=[(0, 0, 0, 6)]), keep=True
                ).id
            print(
                f"squalld {daemon.address}: {device}, FFT {info.fft_backend}, "
                f"{info.device_queues} device queue(s); {args.client} clients"
            )
            calls = requests(volume)
            for name, message in calls.items():
                (Path(directory) / f"{name}.pb").write_bytes(message.SerializeToString())

            def run_level(clients: int, seconds: float) -> Level:
                if args.client == "python":
                    return python_level(daemon.address, calls, clients, seconds)
                return cpp_level(
                    args.load_client, daemon.address, Path(directory), clients, seconds
                )

            run_level(1, min(2.0, args.seconds))  # warm-up
            header = f"{'clients':>7} {'calls/s':>8} {'x 1 client':>10} {'errors':>6}"
            for m in METHODS:
                header += f" {m + ' p50/p99 ms':>22}"
            levels: Dict[int, Level] = {c: Level() for c in counts}
            # the levels in turn, so that a slow spell of the machine hits every level
            for r in range(args.rounds):
                for clients in counts:
                    levels[clients].add_round(run_level(clients, args.seconds))
                rates = ", ".join(f"{levels[c].rates[-1]:.0f}" for c in counts)
                print(f"round {r + 1}: calls/s {rates}", flush=True)
            print(header)
            for clients in counts:
                print(level_line(levels[clients], clients, levels[counts[0]]))
            report_goals(levels, counts)
        finally:
            daemon.stop()


def level_line(level: Level, clients: int, first: Level) -> str:
    """Median calls per second over the rounds, its ratio to the first level's, errors, p50 / p99 per
    method (ms) over all rounds' calls."""
    rate, base = level.rate(), first.rate()
    line = f"{clients:>7} {rate:>8.1f} {rate / base:>10.2f} {len(level.errors):>6}"
    for m in METHODS:
        lat = level.latencies[m]
        line += f" {1e3 * quantile(lat, 0.5):>10.1f} / {1e3 * quantile(lat, 0.99):>9.1f}"
    return line


def report_goals(levels: Dict[int, Level], counts: List[int]) -> None:
    rates = [levels[c].rate() for c in counts]
    never_falls = all(b >= 0.95 * a for a, b in zip(rates, rates[1:]))  # 5%: the machine's noise
    print(f"throughput never falls as clients are added (within 5%): {never_falls}")
    measured = [levels[c] for c in (1, 8) if c in levels]
    if len(measured) == 2 and all(
        level.latencies[m] for level in measured for m in METHODS
    ):  # calls
        for m in METHODS:
            p50_1 = statistics.median(levels[1].latencies[m])
            p99_8 = quantile(levels[8].latencies[m], 0.99)
            print(f"{m}: p99 at 8 clients / p50 at 1 client = {p99_8 / p50_1:.1f} (goal <= 10)")
        # A client calls the methods in turn, so their mean latencies add up to its cycle. If
        # every method's mean grew less than the cycle did from 1 to 8 clients, so would their sum:
        # some method's mean grows at least as much, however the device's line orders them.
        cycle = {c: sum(statistics.mean(levels[c].latencies[m]) for m in METHODS) for c in (1, 8)}
        print(
            f"a client's cycle of the {len(METHODS)} calls, mean at 8 clients / at 1 = {cycle[8] / cycle[1]:.1f}"
            " (some method's mean grows at least as much, whatever the order of the device's line)"
        )
    print("errors:", sum(len(levels[c].errors) for c in counts))
    for c in counts:
        for e in levels[c].errors[:3]:
            print("  ", e)


if __name__ == "__main__":
    main()
