"""Uploads of large records in a real chromium against ``panel serve`` (``pytest -m browser``).

The upload widget sends a file in pieces (``dashboard.views.beam.UPLOAD_CHUNK_BYTES``), so a
record larger than Bokeh's 20 MB websocket message limit loads with the plain serve command; a
file over the library's limit is refused in the browser with a readable message.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from harness import BEAM_FINAL, read_status, upload_state, wait_for_status
from playwright.sync_api import expect

from beam.io.config import load_config
from beam.io.limits import MAX_MEASUREMENT_BYTES
from beam.io.simulation import simulate, write_simulation

pytestmark = pytest.mark.browser

CONFIG = Path(__file__).resolve().parents[2] / "assets" / "answers" / "lab_run_1.config.toml"
#: lab_run_1's beam and chirp sampled at 180 kHz instead of 1 kHz: 630,000 rows, ~31 MB of CSV.
RATE_HZ = 180_000.0


@pytest.fixture(scope="module")
def long_record(tmp_path_factory) -> tuple[Path, Path]:
    """A ~31 MB simulated record (CSV) and its sidecar, written by the library's own simulation."""
    text = CONFIG.read_text().replace("rate_Hz = 1000.0", f"rate_Hz = {RATE_HZ}")
    assert f"rate_Hz = {RATE_HZ}" in text
    folder = tmp_path_factory.mktemp("long-record")
    (folder / "long.config.toml").write_text(text)
    csv, toml, _ = write_simulation(folder / "long_lab_run", simulate(load_config(folder / "long.config.toml")))
    assert 25e6 < csv.stat().st_size < MAX_MEASUREMENT_BYTES
    return csv, toml


def open_beam(page) -> dict:
    page.locator(".bk-tab", has_text="Beam calibration").first.click()
    return wait_for_status(page, BEAM_FINAL)


def test_a_record_larger_than_a_websocket_message_loads(page, long_record):
    csv, toml = long_record
    open_beam(page)
    load = page.get_by_role("button", name="Load the uploaded measurement")
    expect(load).to_be_disabled()
    page.locator(".beam-upload-csv input[type=file]").set_input_files(csv)
    page.locator(".beam-upload-toml input[type=file]").set_input_files(toml)
    # both files arrived on the server (piece by piece for the CSV): the button is enabled
    expect(load).to_be_enabled(timeout=60000)
    try:
        expect(page.locator(".beam-upload-csv .filepond--file-status-main")).to_have_text("Upload complete",
                                                                                     timeout=30000)
    except AssertionError as failure:  # say what the widget holds and what the page logged
        raise AssertionError(f"{failure}\n{upload_state(page, 'beam-upload-csv')}") from None
    load.click()
    state = wait_for_status(page, "s.dataset.startsWith('upload-1-long_lab_run') && s.shown === s.requested "
                                  "&& s.band_n > 0", timeout_ms=180000)
    assert state["stage"] in ("preview", "sampling", "final")  # the preview (or later) of the upload is drawn
    selected = page.locator(".beam-dataset select")
    expect(selected.locator("option:checked")).to_have_text(re.compile(r"^upload: long_lab_run — "))
    expect(page.locator(".beam-cal-error").get_by_text("upload rejected")).to_have_count(0)
    assert page.errors == []


def test_a_file_over_the_limit_is_refused_in_the_browser_and_keeps_the_result(page, tmp_path):
    shown = open_beam(page)
    big = tmp_path / "huge.csv"
    with big.open("wb") as out:  # sparse: one byte over the library's limit, never read
        out.truncate(MAX_MEASUREMENT_BYTES + 1)
    page.locator(".beam-upload-csv input[type=file]").set_input_files(big)
    expect(page.locator(".beam-upload-csv .filepond--file-status-main")).to_have_text("File is too large",
                                                                                 timeout=30000)
    expect(page.locator(".beam-upload-csv .filepond--file-status-sub")).to_have_text("Maximum file size is 67.1 MB")
    expect(page.get_by_role("button", name="Load the uploaded measurement")).to_be_disabled()
    page.wait_for_timeout(1000)
    state = read_status(page)
    assert state["dataset"] == "lab_run_1" and state["requested"] == shown["requested"]
    assert state["band_sum"] == pytest.approx(shown["band_sum"]), "the previous result must stay on screen"
    assert page.errors == []
