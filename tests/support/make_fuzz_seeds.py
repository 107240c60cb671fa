"""Writes the libFuzzer harnesses' seed corpora (tests/<capability>/fuzz_seeds/): one valid request per
check of each harness (tests/<capability>/<capability>_fuzz.cpp), its first byte the check's index, the
rest the request's protobuf bytes. The requests are the bad-input sweep's valid bases
(tests/python/test_bad_input.py). Run from the Python tests' venv:

    build/tests/python/venv/bin/python tests/support/make_fuzz_seeds.py
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Dict, List

TESTS = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(TESTS / "python"))

import test_bad_input as base  # noqa: E402
from squall._pb import clouds_pb2, ewave_pb2  # noqa: E402

# In the order of each harness's checks.
SEEDS: Dict[str, List[Any]] = {
    "ocean": [base.get_tile_request(), base.stream_tiles_request(), base.sample_surface_request()],
    "ewave": [
        base.create_session_request(),
        base.step_request("0123456789abcdef0123456789abcdef"),
        ewave_pb2.EWaveRestoreRequest(),
    ],
    "clouds": [
        clouds_pb2.BuildVolumeRequest(model=base.cloud_model()),
        clouds_pb2.RenderRequest(model=base.cloud_model(), settings=base.render_settings()),
        base.stream_evolution_request(),
    ],
    "textures": [base.advect_request(), base.bake_request(), base.deform_request()],
}


def main() -> None:
    for capability, requests in SEEDS.items():
        directory = TESTS / capability / "fuzz_seeds"
        directory.mkdir(exist_ok=True)
        for index, request in enumerate(requests):
            name = f"{index}-{type(request).__name__}"
            (directory / name).write_bytes(bytes([index]) + request.SerializeToString())


if __name__ == "__main__":
    main()
