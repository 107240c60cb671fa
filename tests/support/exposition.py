"""Reading squalld's /metrics (Prometheus text format) in tests: fetch it, pick samples by name and labels."""

from __future__ import annotations

import re
import urllib.request
from typing import List


def http_get(url: str) -> str:
    with urllib.request.urlopen(url, timeout=10) as response:
        return response.read().decode()


def samples(exposition: str, name: str, **labels: str) -> List[float]:
    """The values of the samples `name` whose labels include `labels`."""
    found = []
    for line in exposition.splitlines():
        m = re.match(r"^(\w+)(?:\{(.*)\})? (\S+)$", line)
        if not m or m.group(1) != name:
            continue
        have = dict(re.findall(r'(\w+)="((?:[^"\\]|\\.)*)"', m.group(2) or ""))
        if all(have.get(k) == v for k, v in labels.items()):
            found.append(float(m.group(3)))
    return found


def value(exposition: str, name: str, **labels: str) -> float:
    """The sample `name` whose labels include `labels` (exactly one must match)."""
    found = samples(exposition, name, **labels)
    assert len(found) == 1, f"{name}{labels}: {found}"
    return found[0]
