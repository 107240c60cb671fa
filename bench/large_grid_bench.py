"""What a client's frames cost on the largest grids, where a layer's spectrum (384 MiB at
4096^2) or an eWave grid's propagator table (128 MiB) must stay in squalld's caches from one frame
to the next: per squalld given (alternated over --rounds fresh daemons), seconds per StreamTiles
frame (the height of one JONSWAP layer) and per eWave Step (height as float16) after the first,
which builds the spectrum or table and the FFT plans. Run with the Python of the client's venv,
nothing else on the cores:

    build/tests/python/venv/bin/python bench/large_grid_bench.py [--n 4096] [--frames 4]
        [--rounds 2] [--squalld OLD --squalld NEW] [--squalld-flags "--fft fftw"]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Dict, List

import squall
from python_client_bench import ROOT, Daemon


def ocean_frames(client: squall.Client, n: int, frames: int) -> List[float]:
    """Seconds between the frames of one StreamTiles call (the first from the call)."""
    spec = squall.ocean.tile_spec([squall.ocean.layer(extent=float(n), n=n, wind_speed=12)])
    times, last = [], time.perf_counter()
    for _ in client.ocean.stream(spec, dt=0.1, frames=frames, outputs=("height",)):
        now = time.perf_counter()
        times.append(now - last)
        last = now
    return times


def ewave_steps(client: squall.Client, n: int, steps: int) -> List[float]:
    """Seconds of each Step of one session of n x n cells of 0.1 m."""
    times = []
    with client.ewave.session(nx=n, ny=n, dx=0.1) as session:
        for _ in range(steps):
            start = time.perf_counter()
            session.step(0.02, outputs=("height",), dtype="float16")
            times.append(time.perf_counter() - start)
    return times


def one_round(squalld: Path, flags: List[str], n: int, frames: int) -> Dict[str, List[float]]:
    with tempfile.TemporaryDirectory() as directory:
        daemon = Daemon(squalld, Path(directory), flags)
        try:
            with squall.Client(daemon.address, timeout=600) as client:
                client.wait_until_serving(300)
                ocean = ocean_frames(client, n, frames)
                return {"ocean": ocean, "ewave": ewave_steps(client, n, frames)}
        finally:
            daemon.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=4096)
    parser.add_argument("--frames", type=int, default=4, help="frames and steps per round, >= 2")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--squalld", type=Path, action="append")
    parser.add_argument("--squalld-flags", default="--fft fftw", help="more squalld flags")
    args = parser.parse_args()
    if args.frames < 2 or args.rounds < 1:
        parser.error("--frames must be at least 2 and --rounds at least 1")
    binaries = args.squalld or [ROOT / "build" / "squalld"]
    flags = args.squalld_flags.split()
    runs: Dict[Path, List[Dict[str, List[float]]]] = {b: [] for b in binaries}
    for _ in range(args.rounds):
        for binary in binaries:
            runs[binary].append(one_round(binary, flags, args.n, args.frames))
    print(f"{args.n}^2, {args.frames} frames and steps a round, {args.rounds} rounds: seconds")
    columns = ("first frame", "next frames", "first step", "next steps")
    print(f"{'squalld':<40}" + "".join(f"{c:>12}" for c in columns))
    for binary, rounds in runs.items():
        cells = []
        for what in ("ocean", "ewave"):
            cells.append(statistics.median(r[what][0] for r in rounds))
            cells.append(statistics.median(t for r in rounds for t in r[what][1:]))
        print(f"{str(binary):<40}" + "".join(f"{c:>12.2f}" for c in cells))


if __name__ == "__main__":
    main()
