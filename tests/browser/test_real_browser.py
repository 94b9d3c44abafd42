"""The bundled real record (an accelerometer on a plucked aluminium strip, a free decay with irregular
time stamps) in a real chromium against ``panel serve`` (``pytest -m browser``): it calibrates, its
plots and read-outs are in the output's quantity and unit (m/s², not the simulated records' µm), the
diagnosis offers the accelerometer's own mass and Reveal says there is no known answer."""

from __future__ import annotations

import pytest
from harness import BEAM_FINAL, wait_for_status
from playwright.sync_api import expect

pytestmark = pytest.mark.browser

REAL = "adxl_50cm_114655"

#: Axis labels of every Bokeh axis in the page.
AXIS_LABELS_JS = """() => {
  const out = [];
  for (const m of Bokeh.documents[0].all_models)
    if (typeof m.axis_label === 'string' && m.axis_label) out.push(m.axis_label);
  return out;
}"""


def open_tab(page, title):
    page.locator(".bk-tab", has_text=title).first.click()


def test_real_record_calibrates_in_its_unit_and_has_no_answer(page, tmp_path):
    page.set_viewport_size({"width": 1280, "height": 800})
    open_tab(page, "Beam calibration")
    wait_for_status(page, BEAM_FINAL)
    select = page.locator(".beam-dataset select")
    options = select.evaluate("s => Array.from(s.options).map(o => o.text)")
    label = next((o for o in options if o.startswith(REAL)), None)
    assert label is not None, options
    assert "Real aluminium strip" in label
    select.select_option(label=label)
    state = wait_for_status(page, BEAM_FINAL + f" && s.dataset === '{REAL}'", timeout_ms=240000)
    assert state["band_n"] > 100
    labels = page.evaluate(AXIS_LABELS_JS)
    assert "Acceleration (m/s²)" in labels, labels
    assert not any("µm" in s or "mm" in s for s in labels if s.startswith(("Acceleration", "Displacement"))), labels
    readouts = page.locator(".beam-cal-readouts").first
    expect(readouts.get_by_text("m/s²").first).to_be_visible(timeout=10000)
    expect(readouts.get_by_text("µm")).to_have_count(0)
    page.screenshot(path=str(tmp_path / "real-record-beam.png"), full_page=True)

    open_tab(page, "Diagnosis")
    wait_for_status(page, "s.stage === 'final' && s.ladder_n === 1", css="diag-status", timeout_ms=240000)
    # an accelerometer record is offered the sensor's own mass (effect titles on the buttons)
    candidates = page.locator(".diag-candidates")
    expect(candidates.get_by_text("Sensor mass").first).to_be_visible(timeout=10000)
    # a decay's candidates are judged on the calibration window's error, and say so in m/s²
    expect(candidates.get_by_text("calibration-window error").first).to_be_visible()
    expect(candidates.get_by_text("m/s²").first).to_be_visible()
    expect(candidates.get_by_text("µm")).to_have_count(0)
    reveal = page.locator(".diag-reveal button")
    assert reveal.is_disabled(), "a real record has no known answer to reveal"
    expect(page.locator(".diag-answer").get_by_text("No known answer").first).to_be_visible(timeout=10000)
    page.screenshot(path=str(tmp_path / "real-record-diagnosis.png"), full_page=True)
    assert page.errors == []
