"""The beam calibration and diagnosis views in a real chromium against ``panel serve`` (``pytest -m browser``)."""

from __future__ import annotations

import pytest
from harness import BEAM_FINAL, read_status, wait_for_status
from playwright.sync_api import expect

pytestmark = pytest.mark.browser


def open_tab(page, title):
    page.locator(".bk-tab", has_text=title).first.click()


def test_beam_view_shows_the_calibration(page):
    open_tab(page, "Beam calibration")
    state = wait_for_status(page, BEAM_FINAL)
    assert state["dataset"] == "lab_run_1" and state["effects"] == "air_damping+kelvin_voigt"
    assert state["rmse_prediction"] > 0 and state["band_n"] > 1000
    expect(page.get_by_text("Error on held-out data").first).to_be_visible()
    expect(page.locator(".beam-convergence").get_by_text("Converged").first).to_be_visible(timeout=10000)
    assert page.errors == []


def test_adding_the_missing_effect_lowers_the_prediction_error(page):
    open_tab(page, "Beam calibration")
    wait_for_status(page, BEAM_FINAL)
    page.locator(".beam-dataset select").select_option(label="lab_run_2 — Aluminium strip, sensor near the tip, chirp test")
    before = wait_for_status(page, BEAM_FINAL + " && s.dataset === 'lab_run_2'")
    open_tab(page, "Diagnosis")
    first = wait_for_status(page, "s.stage === 'final' && s.ladder_n === 1", css="diag-status", timeout_ms=120000)
    expect(page.locator(".diag-verdict").get_by_text("Missing: Tip mass").first).to_be_visible(timeout=10000)
    page.get_by_role("button", name="Add Tip mass").click()  # effect titles on the buttons, not ids
    ladder = wait_for_status(page, "s.ladder_n === 2", css="diag-status", timeout_ms=120000)
    # the whole diagnosis re-runs for the new model (the ladder is kept)
    wait_for_status(page, f"s.stage === 'final' && s.ladder_n === 2 && s.requested > {first['requested']}",
                    css="diag-status", timeout_ms=180000)
    expect(page.locator(".diag-add-tip_mass")).to_have_count(0)
    after = read_status(page)
    assert after["effects"] == "air_damping+kelvin_voigt+tip_mass" and after["preview"] == 0
    assert before["rmse_prediction"] > 3 * after["rmse_prediction"]
    assert ladder["ladder_rmse"] == pytest.approx(after["rmse_prediction"], rel=1e-4)
    open_tab(page, "Beam calibration")
    expect(page.locator(".beam-cal-rmse-prediction").first).to_be_visible()
    assert page.errors == []


def test_invalid_upload_shows_an_error_and_keeps_the_result(page):
    open_tab(page, "Beam calibration")
    shown = wait_for_status(page, BEAM_FINAL)
    page.locator(".beam-upload-csv input[type=file]").set_input_files(
        files=[{"name": "broken.csv", "mimeType": "text/csv", "buffer": b"time_s,voltage_V,displacement_m\n0,zero,1\n"}])
    page.locator(".beam-upload-toml input[type=file]").set_input_files(
        files=[{"name": "broken.toml", "mimeType": "application/toml", "buffer": b"title = 'no geometry'\n"}])
    load = page.get_by_role("button", name="Load the uploaded measurement")
    expect(load).to_be_enabled(timeout=30000)  # both files reached the server
    load.click()
    page.locator(".beam-cal-error").get_by_text("upload rejected").first.wait_for(timeout=30000)
    state = read_status(page)
    assert state["dataset"] == "lab_run_1" and state["requested"] == shown["requested"]
    assert state["band_sum"] == pytest.approx(shown["band_sum"]), "the previous result must stay on screen"
    assert page.errors == []
