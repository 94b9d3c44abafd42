"""The "Your record" tab in a real chromium against ``panel serve`` (``pytest -m browser``).

A phyphox export with no sidecar is dropped in, the beam described in the form, the spectrum
drawn with the ideal beam's modes, the record calibrated in the beam view; a bad file is refused
with the record kept; a 50 MB three-axis phone record uploads (in pieces) and is read.

The phyphox file is ``assets/real/formats/adxl_50cm_114655.phyphox.csv``: the first 1.5 s of a
real record of an aluminium strip (500 x 50 x 2 mm, sensor 0.44 m from the clamp) by Enes
Demirkaya, MIT licence, re-saved by this project as a phyphox export (``assets/real/README.md``).
"""

from __future__ import annotations

import math
import re
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from harness import read_status, upload_state, wait_for_status, wait_while_moving
from playwright.sync_api import expect

from beam.io.anchor import closed_form_mode1_Hz
from beam.io.materials import MATERIALS

pytestmark = pytest.mark.browser

REPO = Path(__file__).resolve().parents[2]
PHYPHOX = REPO / "assets" / "real" / "formats" / "adxl_50cm_114655.phyphox.csv"
#: The strip of the shared runs (assets/real/README.md).
LENGTH_M, WIDTH_M, THICKNESS_M, SENSOR_M = 0.5, 0.05, 0.002, 0.44


def open_record(page) -> None:
    page.locator(".bk-tab", has_text="Your record").first.click()
    expect(page.locator(".record-upload input[type=file]")).to_have_count(1, timeout=30000)


def sources(page, *names: str) -> dict:
    """The data of the named Bokeh data sources."""
    return page.evaluate("""(names) => { const doc = Bokeh.documents[0]; const out = {};
        for (const n of names) { const m = doc.get_model_by_name(n); if (!m) { out[n] = null; continue; }
          const d = {}; for (const [k, v] of m.data.entries ? m.data.entries() : Object.entries(m.data)) d[k] = Array.from(v);
          out[n] = d; } return out; }""", list(names))


def fill(page, css: str, value: float) -> None:
    box = page.locator(f".{css} input")
    box.fill(repr(value))
    box.press("Enter")


def record_peak_Hz(path: Path) -> float:
    """The record's strongest spectral peak between 2 and 20 Hz, by a zero-padded periodogram of
    the z column on a uniform grid (independent of the app's Welch estimate)."""
    rows = [line.split(";") for line in path.read_text().splitlines()[1:]]
    t = np.array([float(r[0].replace(",", ".")) for r in rows])
    z = np.array([float(r[1].replace(",", ".")) for r in rows])
    grid = np.arange(t[0], t[-1], np.median(np.diff(t)))
    z = np.interp(grid, t, z) - z.mean()
    n = 32 * grid.size
    power = np.abs(np.fft.rfft(z * np.hanning(z.size), n)) ** 2
    f = np.fft.rfftfreq(n, grid[1] - grid[0])
    band = (f > 2) & (f < 20)
    return float(f[band][np.argmax(power[band])])


def test_a_phyphox_file_without_sidecar_is_described_shown_and_calibrated(page, tmp_path):
    record = tmp_path / "Raw Data.csv"  # the name phyphox gives its export
    shutil.copyfile(PHYPHOX, record)
    open_record(page)
    page.locator(".record-upload input[type=file]").set_input_files(record)
    wait_for_status(page, "s.stage === 'read' && s.file === 'Raw Data.csv'", css="record-status", timeout_ms=60000)
    what = page.locator(".record-what")
    expect(what).to_contain_text("phyphox")
    expect(what).to_contain_text("Acceleration z (m/s^2)")
    expect(page.locator(".record-missing")).to_contain_text("Still to fill")
    expect(page.get_by_role("button", name="Load and calibrate")).to_be_disabled()

    fill(page, "record-length-m", LENGTH_M)
    fill(page, "record-width-m", WIDTH_M)
    fill(page, "record-thickness-m", THICKNESS_M)
    page.locator(".record-material select").select_option("aluminium")
    fill(page, "record-sensor-position-m", SENSOR_M)
    status = wait_for_status(page, "s.described === 1 && s.modes >= 2", css="record-status", timeout_ms=30000)
    data = sources(page, "record-modes", "record-peaks", "record-spectrum", "record-sensor")
    modes = data["record-modes"]["frequency_Hz"]
    assert len(modes) == status["modes"]
    # mode 1 of the bare beam (no sensor mass given): the closed form of the uniform cantilever
    aluminium = MATERIALS["aluminium"]
    expected = closed_form_mode1_Hz(LENGTH_M, aluminium.density_kg_m3 * WIDTH_M * THICKNESS_M,
                                    aluminium.youngs_modulus_Pa * WIDTH_M * THICKNESS_M**3 / 12)
    assert modes[0] == pytest.approx(expected, rel=2e-3)
    assert modes[1] / modes[0] == pytest.approx((4.694091 / 1.875104) ** 2, rel=5e-3)  # beta_2 L / beta_1 L squared
    # the record's own lowest peak is marked where an independent periodogram puts it (1.5 s: 0.67 Hz bins)
    assert data["record-peaks"]["frequency_Hz"][0] == pytest.approx(record_peak_Hz(record), abs=0.25)
    assert len(data["record-spectrum"]["frequency_Hz"]) > 100
    assert data["record-sensor"]["x"] == [SENSOR_M]
    expect(page.locator(".record-spectrum")).to_be_visible()
    for width, height in ((1024, 768), (1280, 800), (1920, 1080)):  # a class's screens: nothing runs out of the page
        page.set_viewport_size({"width": width, "height": height})
        page.wait_for_timeout(600)
        assert page.evaluate("() => document.documentElement.scrollWidth") <= width + 1
        assert page.locator(".record-spectrum").bounding_box()["width"] >= 480
    page.set_viewport_size({"width": 1500, "height": 1000})

    with page.expect_download() as download:
        page.locator(".record-sidecar button, .record-sidecar a").first.click()
    assert download.value.suggested_filename == "Raw Data.toml"
    sidecar = tomllib.loads(Path(download.value.path()).read_text())
    assert sidecar["beam"] == {"length_m": LENGTH_M, "width_m": WIDTH_M, "thickness_m": THICKNESS_M,
                               "material": "aluminium"}
    assert sidecar["sensor"] == {"position_m": SENSOR_M}

    # a file that is no record: a readable message, the record kept
    bad = tmp_path / "notes.txt"
    bad.write_text("my beam was plucked twice\n")
    page.locator(".record-upload input[type=file]").set_input_files(bad)
    wait_for_status(page, "s.stage === 'error'", css="record-status", timeout_ms=30000)
    expect(page.locator(".record-error")).to_contain_text("notes.txt")
    assert read_status(page, "record-status")["file"] == "Raw Data.csv"
    expect(what).to_contain_text("Raw Data.csv")

    load = page.get_by_role("button", name="Load and calibrate")
    expect(load).to_be_enabled()
    load.click()
    expect(page.locator(".record-loaded")).to_contain_text("Beam calibration", timeout=30000)
    page.locator(".bk-tab", has_text="Beam calibration").first.click()
    state = wait_for_status(page, "s.dataset && s.dataset.startsWith('upload-1-Raw Data') && s.shown === s.requested "
                                  "&& s.shown > 0 && s.band_n > 0", timeout_ms=120000)
    assert state["stage"] in ("preview", "sampling", "final")
    expect(page.locator(".beam-dataset select")).to_have_value(re.compile(r"^upload: Raw Data — "), timeout=30000)
    assert page.errors == []


def test_a_50_MB_phone_record_uploads_and_is_read(page, tmp_path):
    """A three-axis phyphox-style export at 4 kHz, ~50 MB, made here: a strip shaken steadily at
    6.5 Hz (no pluck to split at, so the whole record is used)."""
    rate_Hz, seconds = 4000.0, 150.0
    t = np.arange(int(rate_Hz * seconds)) / rate_Hz
    rng = np.random.default_rng(30)
    z = 9.81 + 2.0 * np.sin(2 * math.pi * 6.5 * t) + 0.05 * rng.standard_normal(t.size)
    x, y = (0.05 * rng.standard_normal(t.size) for _ in range(2))
    big = tmp_path / "Long Raw Data.csv"
    with big.open("w") as out:
        out.write('"Time (s)","Linear Acceleration x (m/s^2)","Linear Acceleration y (m/s^2)",'
                  '"Linear Acceleration z (m/s^2)","Absolute acceleration (m/s^2)"\n')
        np.savetxt(out, np.column_stack([t, x, y, z, np.sqrt(x * x + y * y + z * z)]), fmt="%.9E", delimiter=",")
    assert 45e6 < big.stat().st_size < 60e6
    open_record(page)
    page.locator(".record-upload input[type=file]").set_input_files(big)
    # waits as long as the page shows progress (the upload's percentage, then the status line's
    # "reading"), not for a fixed time that a loaded machine overruns
    upload = page.locator(".record-upload .filepond--file-status-main").first

    def shown() -> str:
        status = read_status(page, "record-status")
        return f"{upload.inner_text() if upload.count() else ''} | {status.get('stage')} {status.get('status', '')}"

    def read() -> bool:
        status = read_status(page, "record-status")
        return status.get("stage") == "read" and status.get("file") == "Long Raw Data.csv"

    waited = wait_while_moving(page, read, shown, stall_ms=60000)
    print(f"50 MB record uploaded and read in {waited['seconds']:.1f} s ({waited['changes']} changes shown)")
    try:
        expect(upload).to_have_text("Upload complete")
    except AssertionError as failure:  # say what the widget holds and what the page logged
        raise AssertionError(f"{failure}\n{upload_state(page, 'record-upload')}") from None
    what = page.locator(".record-what")
    expect(what).to_contain_text(f"{t.size:,} samples")
    expect(what).to_contain_text("Linear Acceleration z (m/s^2)")
    expect(what).to_contain_text("4000 Hz")
    assert page.errors == []
