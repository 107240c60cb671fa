"""How long squalld holds a StreamTiles call past its client's deadline: per squalld, one warm n x n
layer (seven float32 fields a frame), then streams of three frames under deadlines that end them while a
frame is computed, encoded or written. Prints each call's time on the server (its request log's
duration_ms) and that time past the deadline, for each squalld given, alternating them round by round.
Run with the Python of the client's venv, nothing else on the cores:

    build/tests/python/venv/bin/python bench/cancel_bench.py [--n 4096] [--rounds 2]
        [--deadlines 0.3,0.6,1.0,1.3,1.5] [--squalld OLD --squalld NEW] [--squalld-flags "--fft fftw"]
"""

from __future__ import annotations

import argparse
import re
import statistics
import tempfile
import time
from pathlib import Path
from typing import Dict, List

import squall
from python_client_bench import ROOT, Daemon

FIELDS = (
    "height",
    "displacement_x",
    "displacement_y",
    "normal_x",
    "normal_y",
    "normal_z",
    "jacobian",
)


def stream(client: squall.Client, n: int, frames: int, timeout: float) -> None:
    """One StreamTiles call of `frames` frames of an n x n layer, read to its end or its deadline."""
    layer = squall.ocean.layer(extent=2000, n=n, wind_speed=12, seed=1)
    spec = squall.ocean.tile_spec([layer])
    try:
        for _ in client.ocean.stream(spec, dt=0.1, frames=frames, outputs=FIELDS, timeout=timeout):
            pass
    except squall.SquallError as error:
        if error.code.name != "DEADLINE_EXCEEDED":
            raise


def server_seconds(log: Path, calls: int) -> List[float]:
    """The duration_ms of the last `calls` StreamTiles calls in a squalld log, in seconds."""
    text = log.read_text(errors="replace")
    found = re.findall(r"method=/squall\.v1\.Ocean/StreamTiles status=\S+ duration_ms=([0-9.]+)", text)
    return [float(ms) / 1e3 for ms in found[-calls:]]


def one_round(squalld: Path, flags: List[str], n: int, deadlines: List[float]) -> List[float]:
    """A fresh daemon: one warm-up frame, then one call per deadline; the server's times, s."""
    with tempfile.TemporaryDirectory() as directory:
        daemon = Daemon(squalld, Path(directory), flags)
        try:
            with squall.Client(daemon.address, timeout=600) as client:
                client.wait_until_serving(300)
                stream(client, n, 1, 600)  # the spectrum and the plans
                for deadline in deadlines:
                    stream(client, n, 3, deadline)
                    time.sleep(2)  # the call ends on the server, its log line is written
        finally:
            daemon.stop()
        return server_seconds(Path(directory) / "squalld.log", len(deadlines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=4096)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--deadlines", default="0.3,0.6,1.0,1.3,1.5")
    parser.add_argument("--squalld", type=Path, action="append")
    parser.add_argument("--squalld-flags", default="--fft fftw")
    args = parser.parse_args()
    binaries: List[Path] = args.squalld or [ROOT / "build" / "squalld"]
    deadlines = [float(d) for d in args.deadlines.split(",")]
    flags = args.squalld_flags.split()
    seconds: Dict[int, List[List[float]]] = {b: [] for b in range(len(binaries))}
    for _ in range(args.rounds):
        for b, squalld in enumerate(binaries):
            seconds[b].append(one_round(squalld, flags, args.n, deadlines))
    print(f"StreamTiles {args.n}x{args.n}, {len(FIELDS)} float32 fields, 3 frames a call")
    for b, squalld in enumerate(binaries):
        print(f"squalld {b + 1}: {squalld}")
    print("server time past the deadline, s (median of the rounds; each round's in brackets)")
    print(f"{'deadline':>9} " + " ".join(f"{'squalld ' + str(b + 1):>28}" for b in range(len(binaries))))
    for d, deadline in enumerate(deadlines):
        cells = []
        for b in range(len(binaries)):
            past = [round(r[d] - deadline, 2) for r in seconds[b]]
            cells.append(f"{statistics.median(past):6.2f} {past}".rjust(28))
        print(f"{deadline:9.2f} " + " ".join(cells))


if __name__ == "__main__":
    main()
