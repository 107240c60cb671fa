"""What one call costs squalld: the CPU time (all its threads, from /proc) and the context switches of
squalld's threads per call, and the wall time per call, for each of load_bench.py's three calls
(GetTile 256 x 256 height and normal_z, an eWave Step 256 x 256, a Render 64 x 64), made one at a time
by one Python client. Each squalld given runs in turn, --runs times, alternating; medians are printed.
Run with the Python of the client's venv, nothing else on the cores:

    build/tests/python/venv/bin/python bench/call_cost.py [--calls 600] [--runs 3]
        [--squalld build/squalld [--squalld OTHER ...]]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Callable, Dict, List, NamedTuple, Tuple

import squall
from load_bench import METHODS, requests
from python_client_bench import ROOT, Daemon

CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


class Cost(NamedTuple):
    cpu_ms: float  # squalld's CPU time per call
    switches: float  # context switches of squalld's threads per call
    wall_ms: float  # wall time per call, at the client


def usage(pid: int) -> Tuple[float, int]:
    """CPU seconds (user + system) of process `pid` so far, its ended threads' included, and the
    context switches of its threads alive now (an ended thread's are lost: squalld's threads are
    pooled and live on between calls)."""
    stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    seconds = (int(stat[11]) + int(stat[12])) / CLOCK_TICKS
    switches = 0
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            status = Path(f"/proc/{pid}/task/{tid}/status").read_text().splitlines()
        except FileNotFoundError:  # a thread that ended meanwhile
            continue
        # voluntary_ctxt_switches and nonvoluntary_ctxt_switches, both counted
        switches += sum(int(line.split()[1]) for line in status if "ctxt_switches:" in line)
    return seconds, switches


def measure(squalld: Path, calls: int) -> Dict[str, Cost]:
    """The cost of each method's call on a fresh squalld."""
    result: Dict[str, Cost] = {}
    with tempfile.TemporaryDirectory() as directory:
        daemon = Daemon(squalld, Path(directory))
        try:
            with squall.Client(daemon.address, timeout=600) as client:
                client.wait_until_serving(300)
                model = squall.clouds.model(spheres=[(0, 0, 0, 6)])
                made = requests(client.clouds.build(model, keep=True).id)
                with client.ewave.session(made["session"].config) as session:
                    methods: Dict[str, Callable[[], object]] = {
                        "GetTile": lambda: client.ocean.tile(request=made["tile"]),
                        "Step": lambda: session.step(inputs=made["step"].inputs),
                        "Render": lambda: client.clouds.render(request=made["render"]),
                    }
                    for name in METHODS:
                        # warm: FFT plans, kernels for the launch sizes, learned holds
                        for _ in range(max(20, calls // 10)):
                            methods[name]()
                        cpu0, switches0 = usage(daemon.process.pid)
                        start = time.perf_counter()
                        for _ in range(calls):
                            methods[name]()
                        wall = time.perf_counter() - start
                        cpu1, switches1 = usage(daemon.process.pid)
                        result[name] = Cost(
                            1e3 * (cpu1 - cpu0) / calls,
                            (switches1 - switches0) / calls,
                            1e3 * wall / calls,
                        )
        finally:
            daemon.stop()
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=600, help="per method and run")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--squalld", type=Path, action="append")
    args = parser.parse_args()
    binaries: List[Path] = args.squalld or [ROOT / "build" / "squalld"]
    runs: Dict[Path, List[Dict[str, Cost]]] = {b: [] for b in binaries}
    for _ in range(args.runs):
        for binary in binaries:
            runs[binary].append(measure(binary, args.calls))
    print(
        f"{'squalld':40s} {'method':8s} {'CPU ms/call':>12s} {'switches/call':>14s} {'wall ms/call':>13s}"
    )
    for binary in binaries:
        for name in METHODS:
            median = Cost(
                *(statistics.median(c) for c in zip(*(run[name] for run in runs[binary])))
            )
            print(
                f"{str(binary):40s} {name:8s} {median.cpu_ms:12.3f} {median.switches:14.1f} "
                f"{median.wall_ms:13.3f}"
            )
    print(f"medians of {args.runs} runs of {args.calls} calls per method, one client")


if __name__ == "__main__":
    main()
