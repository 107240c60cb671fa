"""Concurrent clients against one squalld on loopback: 1, 2, 4, 8 and 16 clients, each with its own
channel, calling in turn GetTile (256 x 256, height and normals), an eWave Step (256 x 256, its own
session) and a cloud Render (64 x 64, a stored volume) for --seconds per level. Prints per level the
calls per second of all clients together and its ratio to one client's, p50 / p99 latency per method and
the errors; then the goals: throughput never falls as clients are added (no collapse), p99 at 8 clients
at most 10x the p50 at 1 client, zero errors. Run with the Python of the client's venv, nothing else
on the cores:

    build/tests/python/venv/bin/python bench/load_bench.py [--seconds 10] [--clients 1,2,4,8,16]
        [--squalld build/squalld] [--device-queues N] [--squalld-flags "--fft-threads 1"]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable, Dict, List

import numpy as np

import squall
from python_client_bench import ROOT, Daemon

METHODS = ("GetTile", "Step", "Render")


def quantile(values: List[float], q: float) -> float:
    return float(np.quantile(values, q)) if values else float("nan")


class Level:
    """One level's calls: latencies (s) per method, errors, wall time."""

    def __init__(self) -> None:
        self.latencies: Dict[str, List[float]] = {m: [] for m in METHODS}
        self.errors: List[str] = []
        self.lock = threading.Lock()
        self.seconds = 0.0

    def calls(self) -> int:
        return sum(len(v) for v in self.latencies.values())


def client_loop(address: str, volume: str, seconds: float, level: Level) -> None:
    tile = squall.ocean.tile_spec([squall.ocean.layer(extent=500, n=256, wind_speed=12, seed=3)])
    camera = squall.clouds.camera(eye=(0, -30, 0), width=64, height=64)
    hull = squall.ewave.ellipse(5.0, 5.0, 0.6, 0.2)
    with squall.Client(address, timeout=600) as client:
        with client.ewave.session(nx=256, ny=256, dx=0.05) as session:
            calls: Dict[str, Callable[[], object]] = {
                "GetTile": lambda: client.ocean.tile(
                    tile, time=1.0, outputs=("height", "normal_z")
                ),
                "Step": lambda: session.step(dt=0.02, shapes=[hull], outputs=("height",)),
                "Render": lambda: client.clouds.render(volume, camera=camera),
            }
            deadline = time.monotonic() + seconds
            n = 0
            while time.monotonic() < deadline:
                method = METHODS[n % len(METHODS)]
                n += 1
                start = time.perf_counter()
                try:
                    calls[method]()
                except squall.SquallError as error:
                    with level.lock:
                        level.errors.append(f"{method}: {error}")
                    continue
                with level.lock:
                    level.latencies[method].append(time.perf_counter() - start)


def run_level(address: str, volume: str, clients: int, seconds: float) -> Level:
    level = Level()
    threads = [
        threading.Thread(target=client_loop, args=(address, volume, seconds, level))
        for _ in range(clients)
    ]
    start = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    level.seconds = time.perf_counter() - start
    return level


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10)
    parser.add_argument("--clients", default="1,2,4,8,16")
    parser.add_argument("--squalld", type=Path, default=ROOT / "build" / "squalld")
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
                    f"{info.device_queues} device queue(s)"
                )
                run_level(daemon.address, volume, 1, min(2.0, args.seconds))  # warm-up
                header = f"{'clients':>7} {'calls/s':>8} {'x 1 client':>10} {'errors':>6}"
                for m in METHODS:
                    header += f" {m + ' p50/p99 ms':>22}"
                print(header)
                levels: Dict[int, Level] = {}
                for clients in counts:
                    level = levels[clients] = run_level(
                        daemon.address, volume, clients, args.seconds
                    )
                    rate = level.calls() / level.seconds
                    base = levels[counts[0]].calls() / levels[counts[0]].seconds
                    line = f"{clients:>7} {rate:>8.1f} {rate / base:>10.2f} {len(level.errors):>6}"
                    for m in METHODS:
                        lat = level.latencies[m]
                        p50, p99 = 1e3 * quantile(lat, 0.5), 1e3 * quantile(lat, 0.99)
                        line += f" {p50:>10.1f} / {p99:>9.1f}"
                    print(line, flush=True)
                report_goals(levels, counts)
        finally:
            daemon.stop()


def report_goals(levels: Dict[int, Level], counts: List[int]) -> None:
    rates = [levels[c].calls() / levels[c].seconds for c in counts]
    never_falls = all(b >= 0.95 * a for a, b in zip(rates, rates[1:]))  # 5%: the machine's noise
    print(f"throughput never falls as clients are added (within 5%): {never_falls}")
    if 1 in levels and 8 in levels:
        for m in METHODS:
            p50_1 = statistics.median(levels[1].latencies[m])
            p99_8 = quantile(levels[8].latencies[m], 0.99)
            print(f"{m}: p99 at 8 clients / p50 at 1 client = {p99_8 / p50_1:.1f} (goal <= 10)")
    print("errors:", sum(len(levels[c].errors) for c in counts))
    for c in counts:
        for e in levels[c].errors[:3]:
            print("  ", e)


if __name__ == "__main__":
    main()
