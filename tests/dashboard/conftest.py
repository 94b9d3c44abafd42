"""Fixtures of the dashboard unit tests (no browser, no server)."""

import sys
from pathlib import Path

import pytest

ROOT = str(Path(__file__).resolve().parents[2])
if ROOT not in sys.path:  # `dashboard` is not an installed package (pyproject packages only beam*)
    sys.path.insert(0, ROOT)

from dashboard.runtime.scheduler import RunPool


@pytest.fixture
def pool():
    """A private two-worker pool whose idle workers exit quickly; shut down after the test."""
    p = RunPool(max_workers=2, idle_timeout_s=0.2, name="test-run")
    yield p
    p.shutdown(wait=True)


@pytest.fixture
def session(pool):
    """A browser session's state on the private pool, closed after the test (a module may define its own)."""
    from dashboard.state.session import SessionState

    s = SessionState(pool=pool, debounce_s=0.0)
    yield s
    s.close()
    s.wait(10)
