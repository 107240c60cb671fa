"""Fixtures of the Python client's tests: real squalld processes on free localhost ports.

Each daemon is started detached (its own session) with `--listen 127.0.0.1:0 --port-file F`, its
PID recorded, waited for until health is SERVING, and stopped by PID (SIGTERM, then SIGKILL) at the
end. Paths come from the environment ctest sets (tests/python/CMakeLists.txt), else the checkout's
build/.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
from concurrent import futures
from pathlib import Path
from typing import Any, Callable, Iterator, List, Optional

import grpc
import pytest

import squall

# The Python helpers shared with the other test folders (wait_for, ...): tests/support.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))

SOURCE_DIR = Path(os.environ.get("SQUALL_SOURCE_DIR", Path(__file__).resolve().parents[2]))
BINARY_DIR = Path(os.environ.get("SQUALL_BINARY_DIR", SOURCE_DIR / "build"))
SQUALLD = Path(os.environ.get("SQUALL_SQUALLD", BINARY_DIR / "squalld"))
SQUALL_CLI = Path(os.environ.get("SQUALL_CLI", BINARY_DIR / "squall"))
START_SECONDS = 300.0  # a cold PoCL kernel cache compiles every kernel first


class Daemon:
    """squalld on 127.0.0.1 with a free port; SERVING once constructed."""

    def __init__(self, flags: List[str], directory: Path, **client: Any) -> None:
        self.directory = directory
        self.log_path = directory / "squalld.log"
        port_file = directory / "port"
        env = dict(os.environ)
        env.setdefault("POCL_CACHE_DIR", str(BINARY_DIR / "pocl-cache"))
        argv = [
            str(SQUALLD),
            "--listen",
            "127.0.0.1:0",
            "--port-file",
            str(port_file),
            "--fft",
            "vkfft",
            *flags,
        ]
        with open(self.log_path, "wb") as log:
            process = subprocess.Popen(
                argv,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                env=env,
                start_new_session=True,
            )
        self._process: Optional[subprocess.Popen] = process  # reaped in stop()
        self.pid = process.pid
        (directory / "squalld.pid").write_text(f"{self.pid}\n")
        deadline = time.monotonic() + START_SECONDS
        while not (port_file.exists() and port_file.read_text().strip()):
            self._fail_if_gone(deadline, "listened")
            time.sleep(0.02)
        self.port = int(port_file.read_text().strip())
        self.address = f"127.0.0.1:{self.port}"
        with squall.Client(self.address, **client) as probe:  # client: e.g. TLS credentials
            while not probe.wait_until_serving(1.0):
                self._fail_if_gone(deadline, "turned SERVING")

    def _fail_if_gone(self, deadline: float, waiting_for: str) -> None:
        if (
            self._process is not None
            and self._process.poll() is not None
            or time.monotonic() > deadline
        ):
            log = self.log_path.read_text(errors="replace")
            self.stop()
            raise RuntimeError(f"squalld never {waiting_for}:\n{log}")

    def running(self) -> bool:
        return self._process is not None and self._process.poll() is None

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def stop(self) -> None:
        """SIGTERM by PID, SIGKILL after 15 s."""
        if self._process is None:
            return
        if self._process.poll() is None:
            os.kill(self.pid, signal.SIGTERM)
            try:
                self._process.wait(15)
            except subprocess.TimeoutExpired:
                os.kill(self.pid, signal.SIGKILL)
                self._process.wait()
        self._process = None


def _start(flags: List[str], name: str, **client: Any) -> Iterator[Daemon]:
    if not SQUALLD.exists():
        pytest.fail(
            f"{SQUALLD} not found: build squall first (deploy/build.sh), or set SQUALL_SQUALLD"
        )
    # next to the C++ tests' daemons (tests/support/process.cpp), kept for their logs
    directory = BINARY_DIR / "test-tmp" / f"python-{name}-{os.getpid()}"
    shutil.rmtree(directory, ignore_errors=True)
    directory.mkdir(parents=True)
    daemon = Daemon(flags, directory, **client)
    try:
        yield daemon
    finally:
        daemon.stop()


class LostReply(grpc.RpcError):
    """The error a client sees whose deadline passed while squalld's reply was on its way."""

    def code(self) -> grpc.StatusCode:
        return grpc.StatusCode.DEADLINE_EXCEEDED

    def details(self) -> str:
        return "Deadline Exceeded"


@contextlib.contextmanager
def in_process_server(add: Callable[[Any, grpc.Server], None], servicer: Any) -> Iterator[str]:
    """A gRPC server in this process on a free 127.0.0.1 port, serving `servicer` (registered with
    `add`, a generated add_*Servicer_to_server): its address. For faults squalld shows only by
    chance (an answer lost after the work was done, two failures in a set order). Stopped at the
    end."""
    server = grpc.server(futures.ThreadPoolExecutor(max_workers=4))
    add(servicer, server)
    port = server.add_insecure_port("127.0.0.1:0")
    server.start()
    try:
        yield f"127.0.0.1:{port}"
    finally:
        server.stop(None)


@pytest.fixture(scope="session")
def daemon() -> Iterator[Daemon]:
    """The shared squalld with its default limits."""
    yield from _start([], "main")


@pytest.fixture(scope="session")
def tight_daemon() -> Iterator[Daemon]:
    """A squalld with one stream slot and 64 KiB messages: StreamTiles frames of a few 64 x 64
    fields are split into chunks while GetTile of the same tile still fits."""
    yield from _start(["--max-streams", "1", "--max-message-bytes", "65536"], "tight")


@pytest.fixture(scope="session")
def client(daemon: Daemon) -> Iterator[squall.Client]:
    with squall.Client(daemon.address, timeout=60) as c:
        yield c


@pytest.fixture(scope="session")
def tight_client(tight_daemon: Daemon) -> Iterator[squall.Client]:
    with squall.Client(tight_daemon.address, timeout=60) as c:
        yield c
