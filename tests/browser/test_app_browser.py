"""The app in a real headless chromium against a real ``panel serve`` (``pytest -m browser``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from harness import read_state, settle, wait_for_result, window_handle
from playwright.sync_api import expect

pytestmark = pytest.mark.browser


def test_app_loads_with_its_three_views(page):
    for title in ("Toy periodic model", "Beam calibration", "Diagnosis"):
        expect(page.locator(".bk-tab", has_text=title).first).to_be_visible(timeout=60000)
    state = wait_for_result(page, stage="final", timeout_ms=90000)
    assert state["requested"] == 1 and state["band_n"] > 0
    # the beam views are built, and start their jobs, when their tab is first opened (see test_beam_browser)
    assert page.errors == []


def test_moving_the_window_slider_changes_the_plotted_band(page):
    before = wait_for_result(page, timeout_ms=90000)
    handle = window_handle(page)
    handle.focus()
    for _ in range(4):  # 4 steps of 0.5 s: window 5 s -> 7 s
        page.keyboard.press("ArrowRight")
    after = settle(page, after_request=before["requested"])
    assert after["window"] == pytest.approx(7.0)
    assert after["band_sum"] != pytest.approx(before["band_sum"])
    assert after["requested"] - before["requested"] <= 4
    expect(page.locator(".beam-window-slider").get_by_text("7.0").first).to_be_visible(timeout=10000)
    assert page.errors == []


def test_invalid_inputs_show_an_error_and_keep_the_result(page):
    before = wait_for_result(page, timeout_ms=90000)
    handle = window_handle(page)
    handle.focus()
    for _ in range(14):  # window 12 s
        page.keyboard.press("ArrowRight")
    # quiet_ms: the slider shows 12 s before the server has the last key press; on a loaded
    # machine (other sessions' jobs) the server can lag the browser by more than 0.6 s
    shown = settle(page, after_request=before["requested"], quiet_ms=2000)
    assert shown["window"] == pytest.approx(12.0)
    page.locator("select").nth(2).select_option(label="10.0")  # horizon 10 s < window 12 s
    alert = page.locator(".beam-error")
    alert.get_by_text("horizon").first.wait_for(timeout=30000)
    state = read_state(page)
    assert state["stage"] == "error"
    assert state["band_sum"] == pytest.approx(shown["band_sum"]), "the previous result must stay on screen"
    assert page.errors == []


def test_pin_posterior_tab_and_download_without_console_errors(page):
    wait_for_result(page, timeout_ms=90000)
    page.get_by_role("button", name="Pin this result").click()
    page.locator(".bk-tab", has_text="Posterior: marginals and pairs").first.click()
    page.wait_for_function("() => Bokeh.documents[0].get_model_by_name('corner-frequency_Hz-current') !== null",
                           timeout=30000)
    page.locator(".bk-tab", has_text="Compare table").first.click()
    page.get_by_text("Pinned").first.wait_for(timeout=30000)
    with page.expect_download(timeout=30000) as download:
        page.get_by_role("button", name="Summary (JSON)").click()
    report = json.loads(Path(download.value.path()).read_text())
    assert report["scenario"]["window_s"] == 5.0 and "posterior" in report
    page.locator(".bk-tab", has_text="Beam calibration").first.click()
    page.locator(".bk-tab", has_text="Toy periodic model").first.click()
    page.wait_for_timeout(500)
    assert page.errors == []
