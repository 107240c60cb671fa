"""The Python client's fixtures (tests/python/conftest.py: a real squalld on a free localhost port,
started detached and stopped by PID), loaded under another module name."""

import importlib.util
from pathlib import Path

_path = Path(__file__).resolve().parents[1] / "python" / "conftest.py"
_spec = importlib.util.spec_from_file_location("squall_python_fixtures", _path)
assert _spec is not None and _spec.loader is not None
_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_fixtures)

daemon = _fixtures.daemon
client = _fixtures.client
BINARY_DIR = _fixtures.BINARY_DIR
SOURCE_DIR = _fixtures.SOURCE_DIR
