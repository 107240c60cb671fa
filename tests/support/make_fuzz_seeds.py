"""Writes the libFuzzer harnesses' seed corpora (tests/<capability>/fuzz_seeds/): one valid request per
check of each harness (tests/<capability>/<capability>_fuzz.cpp), its first byte the check's index, the
rest the request's protobuf bytes. The requests are the bad-input sweep's valid bases
(tests/python/test_bad_input.py); Restore's are the states of two real 16 x 16 sessions after three
steps, one without and one with an ambient ocean (state versions 1 and 2), taken from a squalld this
script starts (build/squalld). Run from the Python tests' venv:

    build/tests/python/venv/bin/python tests/support/make_fuzz_seeds.py
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Dict, List, Tuple

TESTS = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(TESTS / "python"))

import squall  # noqa: E402
import test_bad_input as base  # noqa: E402
from conftest import _start  # noqa: E402
from squall._pb import clouds_pb2, ewave_pb2  # noqa: E402


def ewave_state(ambient: bool = False) -> bytes:
    """GetState of a 16 x 16 session after three steps with a hull; with `ambient`, its config has
    an ambient ocean on its grid."""
    sea = squall.ocean.tile_spec([squall.ocean.layer(extent=1.6, n=16, wind_speed=3)])
    state = b""
    for daemon in _start([], "fuzz-seeds"):  # stopped when the loop ends
        with squall.Client(daemon.address, timeout=120) as client:
            config = dict(nx=16, ny=16, dx=0.1, ambient_ocean=sea if ambient else None)
            with client.ewave.session(**config) as session:
                for _ in range(3):
                    session.step(dt=0.02, shapes=[squall.ewave.ellipse(0.8, 0.8, 0.3, 0.1)])
                state = session.state()
    return state


def seeds() -> Dict[str, List[Any]]:
    """The requests of each harness, in the order of its checks."""
    return {
        "ocean": [
            base.get_tile_request(),
            base.stream_tiles_request(),
            base.sample_surface_request(),
        ],
        "ewave": [
            base.create_session_request(),
            base.step_request("0123456789abcdef0123456789abcdef"),
            ewave_pb2.EWaveRestoreRequest(state=ewave_state()),
        ],
        "clouds": [
            clouds_pb2.BuildVolumeRequest(model=base.cloud_model()),
            clouds_pb2.RenderRequest(model=base.cloud_model(), settings=base.render_settings()),
            base.stream_evolution_request(),
        ],
        "textures": [base.advect_request(), base.bake_request(), base.deform_request()],
    }


def more_seeds() -> Dict[str, List[Tuple[int, str, Any]]]:
    """Further requests for some checks: (the check's index, a name, the request)."""
    restore = ewave_pb2.EWaveRestoreRequest(state=ewave_state(ambient=True))
    return {"ewave": [(2, "ambient_ocean", restore)]}


def write(capability: str, index: int, name: str, request: Any) -> None:
    directory = TESTS / capability / "fuzz_seeds"
    directory.mkdir(exist_ok=True)
    (directory / name).write_bytes(bytes([index]) + request.SerializeToString())


def main() -> None:
    for capability, requests in seeds().items():
        for index, request in enumerate(requests):
            write(capability, index, f"{index}-{type(request).__name__}", request)
    for capability, extra in more_seeds().items():
        for index, suffix, request in extra:
            write(capability, index, f"{index}-{type(request).__name__}-{suffix}", request)


if __name__ == "__main__":
    main()
