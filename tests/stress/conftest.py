"""The stress tests share one `irt run` worker process (tests/stress/_stress_util.py)."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _stress_util import Runner  # noqa: E402


@pytest.fixture(scope="session")
def runner():
    r = Runner()
    yield r
    r.stop()
