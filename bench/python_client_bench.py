"""StreamTiles frames per second: the Python client (client/python) beside the C++ client
(bench/stream_client_bench), against one squalld on loopback, alternating C++ and Python in each round;
prints the medians and their ratio (goal: Python / C++ >= 0.8).

Both time one StreamTiles call of --frames frames from the call to the last frame reassembled and
decoded (C++: FrameAssembler + float decode; Python: client.ocean.stream, numpy arrays), after a
one-frame warm-up call. Run with the Python of the client's venv, nothing else on the cores:

    build/tests/python/venv/bin/python bench/python_client_bench.py [--n 512] [--frames 40]
        [--rounds 5] [--squalld build/squalld] [--cpp build/bench/stream_client_bench]
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import tempfile
import time
from pathlib import Path
from typing import List, Sequence

import squall

ROOT = Path(__file__).resolve().parents[1]
FIELDS = (
    "height", "displacement_x", "displacement_y", "normal_x", "normal_y", "normal_z",
    "jacobian", "jacobian_minus", "jacobian_plus",
)  # fmt: skip


def tile(n: int):
    """One JONSWAP layer of 1 km with n x n cells, choppy (as stream_client_bench.cpp)."""
    layer = squall.ocean.layer(
        extent=1000.0, n=n, spectrum="jonswap", spreading="mitsuyasu", wind_speed=12.0, seed=1
    )
    return squall.ocean.tile_spec([layer], choppiness=1.0)


def python_rate(client: squall.Client, n: int, frames: int, fields: int) -> float:
    spec, outputs = tile(n), FIELDS[:fields]
    for _ in client.ocean.stream(spec, dt=1 / 30, frames=1, outputs=outputs):
        pass  # warm-up
    start = time.perf_counter()
    got = sum(1 for _ in client.ocean.stream(spec, dt=1 / 30, frames=frames, outputs=outputs))
    elapsed = time.perf_counter() - start
    assert got == frames
    return frames / elapsed


def cpp_rate(cpp: Path, address: str, n: int, frames: int, fields: int) -> float:
    argv = [str(cpp), "--address", address, "--n", str(n), "--frames", str(frames)]
    out = subprocess.run(
        argv + ["--fields", str(fields)], check=True, capture_output=True, text=True
    )
    return float(out.stdout.split()[-1])


class Daemon:
    """squalld on a free loopback port, detached, stopped by PID."""

    def __init__(self, squalld: Path, directory: Path, flags: Sequence[str] = ()) -> None:
        port_file = directory / "port"
        env = dict(os.environ)
        env.setdefault("POCL_CACHE_DIR", str(ROOT / "build" / "pocl-cache"))
        argv = [str(squalld), "--listen", "127.0.0.1:0", "--port-file", str(port_file), *flags]
        with open(directory / "squalld.log", "wb") as log:
            self.process = subprocess.Popen(
                argv, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True
            )
        while not (port_file.exists() and port_file.read_text().strip()):
            if self.process.poll() is not None:
                raise RuntimeError(f"squalld exited; see {directory / 'squalld.log'}")
            time.sleep(0.05)
        self.address = f"127.0.0.1:{port_file.read_text().strip()}"

    def stop(self) -> None:
        os.kill(self.process.pid, signal.SIGTERM)
        self.process.wait(30)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=512)
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--squalld", type=Path, default=ROOT / "build" / "squalld")
    parser.add_argument(
        "--cpp", type=Path, default=ROOT / "build" / "bench" / "stream_client_bench"
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as directory:
        daemon = Daemon(args.squalld, Path(directory))
        try:
            with squall.Client(daemon.address, timeout=600) as client:
                client.wait_until_serving(300)
                info = client.info()
                device = next(d.name for d in info.devices if d.selected)
                print(f"squalld {daemon.address}: {device}, FFT {info.fft_backend}")
                print(f"StreamTiles {args.n}x{args.n}, {args.frames} frames per call, float32")
                print(
                    f"{'fields':>7} {'C++ frames/s':>14} {'Python frames/s':>16} {'Python/C++':>11}"
                )
                for fields in (9, 1):
                    cpp: List[float] = []
                    python: List[float] = []
                    for _ in range(args.rounds):
                        cpp.append(cpp_rate(args.cpp, daemon.address, args.n, args.frames, fields))
                        python.append(python_rate(client, args.n, args.frames, fields))
                    c, p = statistics.median(cpp), statistics.median(python)
                    print(f"{fields:>7} {c:>14.2f} {p:>16.2f} {p / c:>11.2f}", flush=True)
        finally:
            daemon.stop()
    print("medians of", args.rounds, "alternating rounds; goal: Python/C++ >= 0.8")


if __name__ == "__main__":
    main()
