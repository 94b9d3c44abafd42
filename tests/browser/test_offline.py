"""The app is fully offline and quiet: over ordinary use of the three tabs no request leaves the
machine and the console shows no warning and no error (``pytest -m browser``)."""

from __future__ import annotations

from urllib.parse import urlparse

import pytest
from harness import BEAM_FINAL, settle, wait_for_result, wait_for_status, window_handle

pytestmark = pytest.mark.browser

LOCAL_HOSTS = {"127.0.0.1", "localhost", "::1", "[::1]"}


def _remote(url: str) -> bool:
    parsed = urlparse(url)
    if parsed.scheme in ("data", "blob", "about", "chrome", "chrome-extension"):
        return False
    return parsed.hostname not in LOCAL_HOSTS


def test_ordinary_use_requests_nothing_remote_and_logs_no_warning(browser_context, app_url):
    page = browser_context.new_page()
    requests: list[str] = []
    console: list[str] = []
    page.on("request", lambda r: requests.append(r.url))
    page.on("console", lambda m: console.append(f"console.{m.type}: {m.text}")
            if m.type in ("warning", "error") and "GPU stall due to ReadPixels" not in m.text else None)
    page.on("pageerror", lambda e: console.append(f"pageerror: {e}"))
    try:
        page.goto(app_url)
        before = wait_for_result(page, timeout_ms=90000)
        handle = window_handle(page)
        handle.focus()
        for _ in range(2):  # two toy updates (window 5 s -> 6 s), each with preview, partial and final results
            page.keyboard.press("ArrowRight")
        settle(page, after_request=before["requested"])
        page.get_by_role("button", name="Pin this result").click()
        page.locator(".beam-preset").first.click()  # a "Try this" preset
        settle(page, after_request=before["requested"] + 1)
        for tab in ("Posterior: marginals and pairs", "Compare table", "Window sweep"):
            page.locator(".bk-tab", has_text=tab).first.click()
            page.wait_for_timeout(1500)
        page.locator(".bk-tab", has_text="Beam calibration").first.click()
        wait_for_status(page, BEAM_FINAL, timeout_ms=120000)
        page.locator(".bk-tab", has_text="Diagnosis").first.click()
        wait_for_status(page, "s.stage === 'final'", css="diag-status", timeout_ms=120000)
        page.locator(".bk-tab", has_text="Toy periodic model").first.click()
        page.wait_for_timeout(1000)
    finally:
        page.close()
    remote = sorted({url for url in requests if _remote(url)})
    assert remote == [], f"requests that leave the machine: {remote}"
    assert requests, "no request was recorded at all"
    assert console == [], console
