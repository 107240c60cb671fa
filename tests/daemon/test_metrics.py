"""squalld --metrics-listen against the real Prometheus tools: the exposition counts exactly the calls
the test made (by method and status code), names the replica, passes `promtool check metrics`, and a
real Prometheus server scraping it answers a PromQL query for the same count.

Processes are started detached with their PIDs recorded, talk only to 127.0.0.1, and are stopped by PID.
Paths come from ctest's environment (tests/CMakeLists.txt).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path
from typing import Iterator, List

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "support"))
from exposition import http_get, samples, value  # noqa: E402  (tests/support)
from processes import Process, free_port, wait_for  # noqa: E402

SQUALLD = os.environ.get("SQUALL_SQUALLD", "build/squalld")
SQUALL = os.environ.get("SQUALL_CLI", "build/squall")


class Squalld:
    def __init__(self, directory: Path) -> None:
        self.grpc = f"127.0.0.1:{free_port()}"
        self.log = directory / "squalld.log"
        self.process = Process(
            [
                SQUALLD,
                "--listen",
                self.grpc,
                "--metrics-listen",
                "127.0.0.1:0",
                "--replica-id",
                "metrics-r1",
                "--fft",
                "vkfft",
            ],
            self.log,
        )
        port = wait_for(
            lambda: re.search(r"/metrics \(port (\d+)\)", self.log.read_text()),
            120,
            "metrics port",
        )
        self.metrics = f"127.0.0.1:{port.group(1)}"
        wait_for(lambda: self.cli("health").returncode == 0, 300, "SERVING")

    def cli(self, *args: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [SQUALL, "--address", self.grpc, *args], capture_output=True, text=True
        )


@pytest.fixture(scope="module")
def daemon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Squalld]:
    d = Squalld(tmp_path_factory.mktemp("metrics"))
    yield d
    d.process.stop()


def test_the_exposition_counts_the_calls_made(daemon: Squalld) -> None:
    for _ in range(3):
        assert daemon.cli("info").returncode == 0
    unknown = daemon.cli("health", "no.such.Service")
    assert unknown.returncode == 4, unknown.stderr  # refused by the server: NOT_FOUND
    text = http_get(f"http://{daemon.metrics}/metrics")
    ok = dict(service="squall.v1.Server", method="GetInfo")
    assert value(text, "squall_requests_total", code="OK", **ok) == 3
    assert value(text, "squall_messages_sent_total", **ok) == 3
    assert (
        value(text, "squall_sent_bytes_total", **ok) > 3 * 100
    )  # devices and kernels: a kilobyte
    assert value(text, "squall_request_duration_seconds_count", **ok) == 3
    assert value(text, "squall_request_duration_seconds_bucket", le="+Inf", **ok) == 3
    health = dict(service="grpc.health.v1.Health", method="Check")
    assert value(text, "squall_requests_total", code="NOT_FOUND", **health) == 1
    assert value(text, "squall_build_info", replica="metrics-r1", fft_backend="vkfft") == 1
    assert value(text, "squall_ready") == 1
    assert value(text, "squall_sessions_active") == 0
    assert value(text, "squall_streams_limit") == 16
    assert value(text, "process_resident_memory_bytes") > 10e6
    assert value(text, "squall_memory_bytes") == 0  # nothing held between calls
    assert value(text, "squall_memory_cached_bytes") == 0
    assert value(text, "squall_memory_budget_bytes") > 100e6  # 3/4 of the machine's memory


def test_idle_connections_do_not_starve_a_scrape(daemon: Squalld) -> None:
    """Connections that send nothing, or half a request, each hold one of the endpoint's threads
    until its read times out; a scrape beside five of them answers within Prometheus's 10 s."""
    host, port = daemon.metrics.split(":")
    idle = [socket.create_connection((host, int(port)), timeout=10) for _ in range(5)]
    try:
        idle[0].sendall(b"GET /metrics HTTP/1.1\r\n")  # a request that never ends
        started = time.monotonic()
        text = http_get(f"http://{daemon.metrics}/metrics")
        assert time.monotonic() - started < 8
        assert value(text, "squall_ready") == 1
    finally:
        for connection in idle:
            connection.close()


def test_device_work_and_its_queueing_are_counted(daemon: Squalld) -> None:
    def scrape() -> str:
        return http_get(f"http://{daemon.metrics}/metrics")

    def unnamed(text: str, name: str) -> float:
        """The sample of work of no kind, as an ocean sample's; 0 before there is any."""
        return sum(samples(text, name, site="other"))

    text = scrape()
    before = value(text, "squall_device_lock_acquisitions_total")
    leases_before = unnamed(text, "squall_device_queue_leases_total")
    assert daemon.cli("ocean", "sample", "--grid", "32", "--point", "1,2").returncode == 0
    text = scrape()
    assert value(text, "squall_device_lock_acquisitions_total") > before
    assert (
        0 <= value(text, "squall_device_lock_wait_seconds_total") < 60
    )  # one client: little waiting
    assert value(text, "squall_device_lock_waiting") == 0  # and nothing waits once it is answered
    # The same by call site: the sample's lease has ended, and its queue was held for some time.
    assert unnamed(text, "squall_device_queue_leases_total") > leases_before
    assert unnamed(text, "squall_device_queue_hold_seconds_total") > 0
    assert 0 <= unnamed(text, "squall_device_queue_wait_seconds_total") < 60


def test_what_caches_keep_is_counted_as_cached_memory(daemon: Squalld) -> None:
    """Between calls the memory budget holds only what the caches keep (here an ocean layer's
    spectrum), and all of it is counted as cached: a call that needs the room takes it back."""
    assert daemon.cli("ocean", "sample", "--grid", "48", "--point", "3,4").returncode == 0
    text = http_get(f"http://{daemon.metrics}/metrics")
    assert value(text, "squall_memory_cached_bytes") > 0
    assert value(text, "squall_memory_bytes") == value(text, "squall_memory_cached_bytes")
    # and the sample's FFT plan is kept: baked once (the start-up's FFT choice bakes outside the cache)
    assert value(text, "squall_fft_plans") >= 1
    assert value(text, "squall_fft_plans_baked_total") == value(text, "squall_fft_plans")


def test_a_client_killed_mid_stream_is_reclaimed_and_counted(
    daemon: Squalld, tmp_path: Path
) -> None:
    """SIGKILL a CLI in the middle of a StreamTiles: squalld notices the connection go, ends the
    stream, frees its slot and counts the call CANCELLED."""

    def scrape() -> str:
        return http_get(f"http://{daemon.metrics}/metrics")

    stream = dict(service="squall.v1.Ocean", method="StreamTiles", code="CANCELLED")
    argv = [SQUALL, "--address", daemon.grpc, "ocean", "stream", "--grid", "64", "--dt", "0.1"]
    client = Process(argv + ["--frames", "100000", "-o", str(tmp_path)], tmp_path / "cli.log")
    try:
        wait_for(lambda: value(scrape(), "squall_streams_active") == 1, 60, "the stream open")
    finally:
        os.kill(client.pid, signal.SIGKILL)
        client.stop()
    wait_for(lambda: value(scrape(), "squall_streams_active") == 0, 30, "its slot given back")
    wait_for(lambda: "CANCELLED" in scrape(), 30, "the call counted")
    assert value(scrape(), "squall_requests_total", **stream) == 1


def test_stored_volumes_are_gauged(daemon: Squalld, tmp_path: Path) -> None:
    """A capability's own gauges: a cloud volume kept on the server shows in squall_stored_volumes and
    its bytes in squall_stored_volume_bytes."""
    built = daemon.cli(
        "cloud",
        "build",
        "--voxel-size",
        "0.5",
        "--sphere",
        "0,0,0,4",
        "--keep",
        "-o",
        str(tmp_path / "c.vdb"),
    )
    assert built.returncode == 0, built.stderr
    text = http_get(f"http://{daemon.metrics}/metrics")
    assert value(text, "squall_stored_volumes") == 1
    assert value(text, "squall_stored_volume_bytes") > 10_000  # a sphere of 4 m in 0.5 m voxels


def test_promtool_accepts_the_exposition(daemon: Squalld) -> None:
    promtool = shutil.which("promtool")
    assert (
        promtool
    ), "promtool missing: deploy/install-deps.sh installs Debian's prometheus package"
    text = http_get(f"http://{daemon.metrics}/metrics")
    checked = subprocess.run(
        [promtool, "check", "metrics"], input=text, capture_output=True, text=True
    )
    assert checked.returncode == 0, checked.stdout + checked.stderr
    broken = text.replace(
        "# TYPE squall_requests_total counter", "# TYPE squall_requests_total gauge\n# TYPE x y"
    )
    refused = subprocess.run(
        [promtool, "check", "metrics"], input=broken, capture_output=True, text=True
    )
    assert (
        refused.returncode != 0
    ), "promtool must refuse a malformed exposition for this check to mean anything"


def test_a_real_prometheus_scrapes_it(daemon: Squalld, tmp_path: Path) -> None:
    prometheus = shutil.which("prometheus")
    assert (
        prometheus
    ), "prometheus missing: deploy/install-deps.sh installs Debian's prometheus package"
    samples = dict(service="squall.v1.Ocean", method="SampleSurface", code="OK")
    exposition = http_get(f"http://{daemon.metrics}/metrics")
    before = (
        value(exposition, "squall_requests_total", **samples)
        if "SampleSurface" in exposition
        else 0
    )
    for _ in range(2):
        assert daemon.cli("ocean", "sample", "--grid", "32", "--point", "1,2").returncode == 0
    config = tmp_path / "prometheus.yml"
    config.write_text(
        "global: {scrape_interval: 1s, evaluation_interval: 1s}\n"
        "scrape_configs:\n"
        f"  - job_name: squalld\n    static_configs: [{{targets: ['{daemon.metrics}']}}]\n"
    )
    web = f"127.0.0.1:{free_port()}"
    server = Process(
        [
            prometheus,
            f"--config.file={config}",
            f"--storage.tsdb.path={tmp_path / 'tsdb'}",
            f"--web.listen-address={web}",
        ],
        tmp_path / "prometheus.log",
    )
    try:
        query = urllib.parse.quote('squall_requests_total{method="SampleSurface",code="OK"}')

        def scraped() -> List[dict]:
            try:
                answer = json.loads(http_get(f"http://{web}/api/v1/query?query={query}"))
            except OSError:
                return []
            return answer["data"]["result"] if answer.get("status") == "success" else []

        result = wait_for(scraped, 60, "a scrape with the sample count")
        assert result[0]["metric"]["job"] == "squalld"
        assert float(result[0]["value"][1]) == before + 2  # the calls this test made
    finally:
        server.stop()


def usable_memory() -> int:
    """The control group's memory limit (v2 memory.max, else v1), else the RAM: read here on its own."""
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(path).read_text().strip()
        except OSError:
            continue
        if text != "max" and int(text) < 1 << 60:
            return int(text)
    return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def test_the_default_memory_budget_is_three_quarters_of_the_usable_memory(daemon: Squalld) -> None:
    text = http_get(f"http://{daemon.metrics}/metrics")
    assert value(text, "squall_memory_budget_bytes") == pytest.approx(
        usable_memory() // 4 * 3, rel=1e-9
    )


def cpu_quota() -> float:
    """The control group's CPU quota in CPUs (v2 cpu.max, else v1's cfs files), 0 for none: read here."""
    try:
        quota, period = Path("/sys/fs/cgroup/cpu.max").read_text().split()
        return 0.0 if quota == "max" else int(quota) / int(period)
    except OSError:
        pass
    try:
        quota = int(Path("/sys/fs/cgroup/cpu/cpu.cfs_quota_us").read_text())
        period = int(Path("/sys/fs/cgroup/cpu/cpu.cfs_period_us").read_text())
    except OSError:
        return 0.0
    return quota / period if quota > 0 else 0.0


def test_the_cpu_device_runs_as_many_threads_as_the_cpu_quota_allows(daemon: Squalld) -> None:
    info = daemon.cli("info")
    assert info.returncode == 0, info.stderr
    selected = re.search(r"^\* .*\(cpu, .*?(\d+) CUs", info.stdout, re.MULTILINE)
    if not selected:
        pytest.skip("the selected device is no CPU device")
    cores = len(os.sched_getaffinity(0))
    quota = cpu_quota()
    expected = min(cores, max(1, math.ceil(quota))) if quota > 0 else cores
    assert int(selected.group(1)) == expected, (info.stdout, quota, cores)
