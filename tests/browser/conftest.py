"""Fixtures of the browser tests: the real ``panel serve dashboard/app.py`` and Debian's chromium.

The tests are marked ``browser``. They are never skipped: without ``/usr/bin/chromium`` they
fail and say how to install it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import harness

#: Console messages that are not errors of the app (software GL in a headless browser).
IGNORED = ("GPU stall due to ReadPixels",)


@pytest.fixture(scope="session")
def chromium_path() -> str:
    """Debian's chromium, or a failure that says how to install it."""
    if not Path(harness.CHROMIUM).exists():
        pytest.fail(harness.MISSING_CHROMIUM, pytrace=False)
    return harness.CHROMIUM


@pytest.fixture(scope="session")
def app_url(chromium_path, tmp_path_factory):
    """URL of the app served by a real ``panel serve`` subprocess (its process group is killed at the end)."""
    log = tmp_path_factory.mktemp("serve") / "panel.log"
    with harness.serve_app(log_path=log) as url:
        yield url


@pytest.fixture(scope="module")
def browser_context(chromium_path, tmp_path_factory):
    """A headless chromium with an empty profile, one per test module: what one module's pages
    left in the browser (memory, closed pages' workers, downloads) does not reach the next; the
    server stays shared, as a class's is. (One browser for the whole phase: the upload widget's
    label stayed at "Uploading 95%" after its last piece was sent, late in the phase, in two runs
    of three; never in a fresh browser.)"""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        context = harness.launch(p, str(tmp_path_factory.mktemp("chromium-profile")))
        yield context
        context.close()


@pytest.fixture
def page(browser_context, app_url):
    """A fresh page on the app (its own session) that records console errors and page errors in ``page.errors``."""
    page = browser_context.new_page()
    errors: list[str] = []
    page.on("console", lambda m: errors.append(f"console.{m.type}: {m.text}")
            if m.type == "error" and not any(s in m.text for s in IGNORED) else None)
    page.on("pageerror", lambda e: errors.append(f"pageerror: {e}"))
    page.on("requestfailed", lambda r: errors.append(f"request failed: {r.url} ({r.failure})"))
    page.errors = errors
    page.goto(app_url)
    yield page
    page.close()
