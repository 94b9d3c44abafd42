"""The app is fully offline and quiet: over ordinary use of the three tabs no request leaves the
machine, the console shows no warning and no error, and the document's patches reach the browser
in the order the server made them (``pytest -m browser``)."""

from __future__ import annotations

import json
from itertools import pairwise
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


def _message_id(frame) -> int | None:
    """The server's id of a bokeh message from its header frame (bokeh's ids count up, ``p1234``), else None."""
    if not isinstance(frame, str) or not frame.startswith("{") or '"msgid"' not in frame[:40]:
        return None
    try:
        header = json.loads(frame)
    except ValueError:
        return None
    msgid = header.get("msgid", "") if isinstance(header, dict) else ""
    return int(msgid[1:]) if header.get("msgtype") == "PATCH-DOC" and msgid[1:].isdigit() else None


def test_ordinary_use_requests_nothing_remote_and_logs_no_warning(browser_context, app_url):
    page = browser_context.new_page()
    requests: list[str] = []
    console: list[str] = []
    # A model is defined in the first message that contains it: a message overtaken by a later one
    # can leave a reference the browser does not know yet ("reference p... isn't known"), so the
    # server's patches must arrive in the order it made them (see dashboard.runtime.staging.held).
    patches: list[int] = []
    page.on("websocket", lambda ws: ws.on("framereceived", lambda f: patches.append(n)
                                          if (n := _message_id(f)) is not None else None))
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
    assert patches, "no patch of the document was seen"
    late = [(earlier, later) for earlier, later in pairwise(patches) if later < earlier]
    assert late == [], f"{len(late)} of {len(patches)} patches arrived after a later one (message ids): {late[:5]}"
