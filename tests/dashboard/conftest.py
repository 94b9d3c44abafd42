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
