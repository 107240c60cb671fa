"""The package's type hints: the imported squall (installed, or a built source tree) passes
`mypy --strict` with the settings of client/python/pyproject.toml ([tool.mypy]: the generated
squall.v1 modules are left out). Needs the package's "typecheck" extra (mypy, types-grpcio,
types-protobuf) in this interpreter; skipped without it. No daemon."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from typing import List

import pytest

import squall
from conftest import SOURCE_DIR

PYPROJECT = SOURCE_DIR / "client" / "python" / "pyproject.toml"
STUBS = ("types-grpcio", "types-protobuf")
INSTALL = "pip install 'squall[typecheck]' (or mypy types-grpcio types-protobuf)"


def missing_tools() -> List[str]:
    missing = [] if importlib.util.find_spec("mypy") is not None else ["mypy"]
    for name in STUBS:
        try:
            metadata.version(name)
        except metadata.PackageNotFoundError:
            missing.append(name)
    return missing


def test_package_passes_mypy_strict(tmp_path: Path) -> None:
    missing = missing_tools()
    if missing:
        pytest.skip(f"{', '.join(missing)} not installed in {sys.executable}: {INSTALL}")
    root = Path(squall.__file__).resolve().parent.parent
    # A source tree (client/python, built with `setup.py build_protos`) is found in the working
    # directory; an installed package through the interpreter's site-packages (never run mypy
    # in site-packages itself: every module there would shadow a library).
    cwd = root if (root / "pyproject.toml").is_file() else tmp_path
    command = [
        sys.executable,
        "-m",
        "mypy",
        "--strict",
        "--config-file",
        str(PYPROJECT),
        "--cache-dir",
        str(tmp_path / "mypy-cache"),
        "-p",
        "squall",
    ]
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=300)
    output = result.stdout + result.stderr
    print(f"$ (cd {cwd} && {' '.join(command)})\n{output}")
    assert result.returncode == 0, f"mypy --strict on {root / 'squall'}:\n{output}"
    assert "no issues found" in result.stdout
