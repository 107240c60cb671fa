"""What the first ocean tile of a grid size costs a client, against the same tile once warm: per size, on
a daemon started with an empty FFTW wisdom directory (--fft-wisdom), the first GetTile (its FFT plans
measured and its spectrum built), the same call again (warm: the reference), a new seed (the spectrum
alone), and after a restart on the same wisdom directory a first call again (the spectrum, plans from
the wisdom). Prints milliseconds (medians over --rounds fresh daemons) and each one's ratio to the warm
call. Run with the Python of the client's venv, nothing else on the cores:

    build/tests/python/venv/bin/python bench/first_tile_bench.py [--sizes 512,1024,2048] [--rounds 3]
        [--squalld build/squalld] [--squalld-flags "--fft fftw"] [--wisdom kept|none|absent]

--wisdom none runs every daemon with --fft-wisdom none (each start measures again); absent passes no
--fft-wisdom, for a squalld that predates the flag.
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

CALLS = ("first", "warm", "new seed", "restarted")


def tile_ms(client: squall.Client, n: int, seed: int) -> float:
    """One GetTile of the height of an n x n JONSWAP layer with Mitsuyasu spreading (the defaults), ms."""
    spec = squall.ocean.tile_spec([squall.ocean.layer(extent=2000, n=n, wind_speed=12, seed=seed)])
    request = squall.ocean.tile_request(spec, time=1.0, outputs=("height",))
    start = time.perf_counter()
    client.ocean.tile(request=request)
    return 1e3 * (time.perf_counter() - start)


def serving(daemon: Daemon) -> squall.Client:
    client = squall.Client(daemon.address, timeout=600)
    client.wait_until_serving(300)
    return client


def one_round(
    squalld: Path, flags: List[str], sizes: List[int], wisdom: str
) -> Dict[int, Dict[str, float]]:
    """A fresh wisdom directory, one daemon for the first three calls of every size, then a second."""
    times: Dict[int, Dict[str, float]] = {n: {} for n in sizes}
    with tempfile.TemporaryDirectory() as directory:
        kept = Path(directory) / "wisdom"
        kept.mkdir()
        flag = {
            "kept": ["--fft-wisdom", str(kept)],
            "none": ["--fft-wisdom", "none"],
            "absent": [],
        }
        for restarted in (False, True):
            run = Path(directory) / ("restarted" if restarted else "first")  # its own port file
            run.mkdir()
            daemon = Daemon(squalld, run, flags + flag[wisdom])
            try:
                with serving(daemon) as client:
                    for n in sizes:
                        if restarted:
                            times[n]["restarted"] = tile_ms(client, n, 3)
                            continue
                        times[n]["first"] = tile_ms(client, n, 1)
                        times[n]["warm"] = tile_ms(client, n, 1)
                        times[n]["new seed"] = tile_ms(client, n, 2)
            finally:
                daemon.stop()
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="512,1024,2048")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--squalld", type=Path, default=ROOT / "build" / "squalld")
    parser.add_argument("--squalld-flags", default="--fft fftw", help="more squalld flags")
    parser.add_argument("--wisdom", choices=("kept", "none", "absent"), default="kept")
    args = parser.parse_args()
    sizes = [int(n) for n in args.sizes.split(",")]
    flags = args.squalld_flags.split()
    rounds = [one_round(args.squalld, flags, sizes, args.wisdom) for _ in range(args.rounds)]
    print(
        f"{args.squalld} {args.squalld_flags}, wisdom {args.wisdom}: ms, median of {args.rounds} "
        "rounds (x the warm call)"
    )
    print(f"{'size':>6}" + "".join(f"{c:>22}" for c in CALLS))
    for n in sizes:
        median = {c: statistics.median(r[n][c] for r in rounds) for c in CALLS}
        cells = "".join(f"{median[c]:>12.1f} ({median[c] / median['warm']:>6.1f})" for c in CALLS)
        print(f"{n:>6}{cells}")


if __name__ == "__main__":
    main()
