"""The "Several records" view in a real chromium against ``panel serve`` (``pytest -m browser``).

Two real runs of the shipped 50 cm aluminium strip are chosen (the defaults, checked here, after
one is unticked and ticked again), calibrated jointly (Laplace: the joint MAP and its
approximation): a panel per record appears with the record, the model and its band, and the
shared parameters' table puts the joint intervals beside each record's own. The tab is then
checked as every tab is for a projector (nothing clipped at 1024 x 768, 1280 x 800 and
1920 x 1080, no text under 14 px at 1280 x 800) and screenshots are written to ``$BEAM_SHOTS_DIR``
(default: the test's temporary folder).
"""

from __future__ import annotations

import time

import pytest
from harness import read_status, wait_for_status
from test_projector_browser import CANVAS_TEXT_JS, CLIPPED_JS, HELPERS_JS, MIN_PX, SIZES, SMALL_TEXT_JS, shots_dir

pytestmark = pytest.mark.browser

RUNS = ("adxl_50cm_114655", "adxl_50cm_114759")

#: Length of a data source's first column (-1: no such source).
SOURCE_N_JS = """(name) => {
  const src = Bokeh.documents[0].get_model_by_name(name);
  if (!src) return -1;
  const first = Object.keys(src.data)[0];
  return src.data[first].length;
}"""



def checked(page) -> list[str]:
    """The dataset ids of the records ticked (the first word of each checked box's label)."""
    boxes = page.locator(".joint-records-choice input[type=checkbox]")
    labels = boxes.evaluate_all("(all) => all.filter((e) => e.checked).map((e) => e.parentElement.textContent.trim())")
    return [label.split(" ")[0] for label in labels]


def test_two_records_calibrated_jointly_show_a_panel_each_and_the_shared_table(page, tmp_path):
    t0 = time.monotonic()
    page.set_viewport_size({"width": 1280, "height": 800})
    page.locator(".bk-tab", has_text="Several records").first.click()
    button = page.locator(".joint-calibrate button")
    button.wait_for(timeout=120000)
    print(f"tab built after {time.monotonic() - t0:.1f} s")
    assert checked(page) == list(RUNS)
    second = page.locator(".joint-records-choice label", has_text=RUNS[1]).first
    second.click()  # untick, then tick again: the state follows the boxes
    page.wait_for_timeout(400)
    assert checked(page) == [RUNS[0]]
    second.click()
    page.wait_for_timeout(400)
    assert checked(page) == list(RUNS)

    button.click()
    status = wait_for_status(page, "s.stage === 'final' && s.records === 2", css="joint-status", timeout_ms=240000)
    print(f"joint calibration final after {time.monotonic() - t0:.1f} s")
    assert status["requested"] >= 1 and status["shown"] == status["requested"], status
    for k in range(2):  # one panel per record: its samples, the joint model and the 95 % band
        page.wait_for_function(f"() => ({SOURCE_N_JS})('joint-band-{k}') > 100", timeout=30000)
        assert page.evaluate(SOURCE_N_JS, f"joint-data-{k}") > 100
        assert page.evaluate(SOURCE_N_JS, f"joint-mean-{k}") > 100
    assert page.evaluate(SOURCE_N_JS, "joint-band-2") == -1, "no third panel for two records"
    assert page.locator(".joint-record-plot").count() >= 2 or page.locator(".joint-panels").count() == 1

    table = page.locator("table.joint-shared-table")
    table.wait_for(timeout=30000)
    headers = table.locator("th").all_inner_texts()
    assert headers == ["Shared parameter (unit)", "Jointly, all 2", "Record 1 alone", "Record 2 alone",
                       "Joint ÷ narrowest width"], headers
    for name in ("bending_stiffness_Nm2", "sensor_mass_kg"):
        cells = table.locator(f"tr[data-name='{name}'] td").all_inner_texts()
        assert "(kg)" in cells[0] or "(N m²)" in cells[0], cells  # units in the label
        assert len(cells) == 5, cells  # joint, two records alone, the width ratio
        assert "±" in cells[1] or ("−" in cells[1] and "+" in cells[1]), cells  # the mean over its reach
        tooltip = table.locator(f"tr[data-name='{name}'] td span[title]").first.get_attribute("title")
        assert "(" in tooltip and "–" in tooltip, tooltip  # the 95 % interval itself on hover
    records = page.locator("table.joint-records-table th").all_inner_texts()
    assert records == ["Record", f"1. {RUNS[0]}", f"2. {RUNS[1]}"], records  # a column per record

    print(f"tables checked after {time.monotonic() - t0:.1f} s")
    directory = shots_dir(tmp_path)
    for w, h in SIZES:  # the projector test's checks on this tab (one screenshot of the top, one of the panels)
        page.set_viewport_size({"width": w, "height": h})
        page.wait_for_timeout(1000)
        page.evaluate(HELPERS_JS)
        page.screenshot(path=str(directory / f"several-records_{w}x{h}_top.png"))
        clipped = page.evaluate(CLIPPED_JS)
        assert clipped == [], f"at {w} x {h}: {clipped} (screenshots in {directory})"
        if (w, h) == (1280, 800):
            assert page.evaluate(SMALL_TEXT_JS, MIN_PX) == []
            assert page.evaluate(CANVAS_TEXT_JS, MIN_PX) == []
        page.locator(".joint-panels").first.scroll_into_view_if_needed()
        page.wait_for_timeout(400)
        page.screenshot(path=str(directory / f"several-records_{w}x{h}_panels.png"))
        page.evaluate("() => { document.getElementById('main').scrollTop = 0; }")
    print(f"projector checks done after {time.monotonic() - t0:.1f} s")
    assert read_status(page, "joint-status")["stage"] == "final"
    assert page.errors == []
