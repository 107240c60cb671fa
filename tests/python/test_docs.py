"""The examples of docs/python.md run as written, against the test daemon."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from conftest import SOURCE_DIR

DOCS = [SOURCE_DIR / "docs" / "python.md", SOURCE_DIR / "README.md"]
EXAMPLES = re.findall(r"```python\n(.*?)```", DOCS[0].read_text(), flags=re.S)
README_EXAMPLES = re.findall(r"```python\n(.*?)```", DOCS[1].read_text(), flags=re.S)


@pytest.mark.parametrize(
    "code",
    EXAMPLES + README_EXAMPLES,
    ids=[f"python.md-{i}" for i in range(len(EXAMPLES))]
    + [f"README.md-{i}" for i in range(len(README_EXAMPLES))],
)
def test_example_runs(
    code: str, daemon, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    monkeypatch.chdir(tmp_path)  # examples may write files (cloud.vdb)
    exec(
        compile(code.replace("127.0.0.1:50051", daemon.address), "example", "exec"),
        {"__name__": "__main__"},
    )


def test_every_capability_has_an_example() -> None:
    assert len(EXAMPLES) >= 6 and README_EXAMPLES
    for name in ("client.ocean", "client.ewave", "client.clouds", "client.textures", "squall.aio"):
        assert any(name in code for code in EXAMPLES), name
