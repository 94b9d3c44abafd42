"""Settings shared by the whole test run.

On pytest-xdist workers (``pytest -n 2``, as CI runs the unit tests) the test modules that hold
a test marked ``slow`` are collected first, each module whole and in its own order, the others
after them in their usual order. xdist hands tests out in collection order, so the long tests
start while the other worker still has short ones to take, instead of one of them running alone
at the end of the run. Without xdist nothing is reordered. Which tests are slow is shown by the
``--durations`` report of every run (``pyproject.toml``); a test that takes more than a few
seconds should carry ``@pytest.mark.slow``.
"""

from __future__ import annotations

import pytest


def _module_of(item: pytest.Item) -> str:
    return item.nodeid.split("::", 1)[0]


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Modules with a ``slow`` test first (stable: every worker collects the same order)."""
    if not hasattr(config, "workerinput"):  # not an xdist worker: keep the usual order
        return
    slow_modules = {_module_of(item) for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: _module_of(item) not in slow_modules)
