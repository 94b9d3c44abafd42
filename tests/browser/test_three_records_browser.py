"""One student, three records in a row, in a real chromium against ``panel serve`` (``pytest -m browser``).

A session goes through a bundled record (lab_run_1), a phone export in g (Physics Toolbox's
``time,gFx,gFy,gFz,TgF``) and a record in m/s² whose time column is in milliseconds, each loaded,
calibrated and diagnosed in turn, at 1280 × 800. Checked all along by a watcher in the page (every
0.25 s, on the page's own state):

* each record's units are read right: the peak of the signal the page read is within 1 % of the
  file's own peak (in m/s²: the g column times g0), its duration within 1 % of the file's;
* every verdict on the Diagnosis tab names its record above its first line, and names the record
  its status says it is about;
* no verdict of an earlier record is shown as current: while the diagnosis shown is not of the
  beam view's record and model, every *Add* button is disabled;
* while anything runs, the session's status line is inside the window: never more than 5 s
  without it.

The two uploaded records are made here from the shared runs of the aluminium strip shipped in
``assets/real`` (Enes Demirkaya, MIT licence): 114759 resampled at a phone's 200 Hz and written in
g, 114655 at 500 Hz with its time in ms.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from harness import BEAM_FINAL, DEEP_JS, read_status, wait_for_status
from playwright.sync_api import expect

pytestmark = [pytest.mark.browser, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
REAL = REPO / "assets" / "real"
G0 = 9.80665
#: The strip of the shared runs (assets/real/README.md).
STRIP = {"record-length-m": 0.5, "record-width-m": 0.05, "record-thickness-m": 0.002, "record-sensor-position-m": 0.44}
#: Seconds of each uploaded record (from the release).
SECONDS = 4.0

#: JS: the first line of the Diagnosis tab's verdict (its Markdown model's first paragraph; the
#: model's text is escaped HTML).
FIRST_LINE_JS = """() => {
  for (const m of Bokeh.documents[0].all_models) {
    if (m.css_classes && m.css_classes.includes && m.css_classes.includes('diag-verdict') && typeof m.text === 'string') {
      const raw = document.createElement('textarea');
      raw.innerHTML = m.text;
      const div = document.createElement('div');
      div.innerHTML = raw.value;
      const p = div.querySelector('p');
      return ((p || div).textContent || '').trim();
    }
  }
  return '';
}"""

#: Installs ``window.__watch``: every 250 ms, whether a run is working (the session's status line
#: says how many), whether that line is inside the window, the longest time (ms) something ran
#: without it in view, and every moment an Add button was enabled under a diagnosis that is not the
#: current record's and model's, or a verdict did not name its record first.
WATCH_JS = "() => {" + DEEP_JS + """
const w = window.__watch = {gap: 0, worst: 0, polls: 0, busy: 0, stale: [], unnamed: [], last: performance.now()};
const attr = (text, k) => { const r = new RegExp('data-' + k + '="([^"]*)"').exec(text); return r ? r[1] : null; };
const textOf = (css) => {
  for (const m of Bokeh.documents[0].all_models) {
    const text = typeof m.text === 'string' ? m.text.replace(/&quot;/g, '"') : null;  // HTML panes send escaped text
    if (text !== null && text.includes('class="' + css + '"')) return text;
  }
  return null;
};
const FIRST_LINE = FIRST_LINE_JS;
let line = null;
const tick = () => {
  w.polls += 1;
  const now = performance.now();
  const status = textOf('session-status');
  const busy = status === null ? 0 : Number(attr(status, 'busy'));
  if (!line || !line.isConnected) line = window.__deepAll('.session-status')[0] || null;
  const r = line ? line.getBoundingClientRect() : null;
  const inView = r !== null && r.height > 0 && r.top >= 0 && r.bottom <= window.innerHeight;
  if (busy > 0) {
    w.busy += 1;
    if (!inView) { w.gap += now - w.last; w.worst = Math.max(w.worst, w.gap); } else { w.gap = 0; }
  } else { w.gap = 0; }
  w.last = now;
  const diag = textOf('diag-status');
  if (diag !== null && attr(diag, 'shown') !== '0') {
    const current = attr(diag, 'current') === '1';
    const enabled = window.__deepAll('.diag-candidates button').filter((b) => !b.disabled).length;
    if (!current && enabled > 0) w.stale.push(attr(diag, 'record'));
    const first = FIRST_LINE();
    if (first && !first.includes(attr(diag, 'record'))) w.unnamed.push(first.slice(0, 80));
  }
  setTimeout(tick, 250);
};
setTimeout(tick, 250);
}""".replace("FIRST_LINE_JS", "(" + FIRST_LINE_JS + ")")


def _resampled(name: str, rate_Hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The first :data:`SECONDS` of a shared run (time from 0, s; acceleration, m/s²) on a uniform grid."""
    table = np.loadtxt(REAL / f"{name}.csv", delimiter=",", skiprows=1)
    t = np.arange(0.0, SECONDS, 1.0 / rate_Hz)
    return t, np.interp(t, table[:, 0] - table[0, 0], table[:, 1])


def phone_export_in_g(folder: Path) -> tuple[Path, float, float]:
    """A Physics Toolbox export (``time,gFx,gFy,gFz,TgF``, g) of 114759 at 200 Hz; (file, peak of
    gFz in m/s², duration in s)."""
    t, a = _resampled("adxl_50cm_114759", 200.0)
    rng = np.random.default_rng(39)
    gz = a / G0
    gx, gy = (0.002 * rng.standard_normal(t.size) for _ in range(2))
    path = folder / "sensor.csv"
    with path.open("w") as out:
        out.write("time,gFx,gFy,gFz,TgF\n")
        for row in zip(t, gx, gy, gz, np.sqrt(gx**2 + gy**2 + gz**2)):
            out.write(",".join(f"{v:.6f}" for v in row) + "\n")
    return path, float(np.max(np.abs(np.round(gz, 6)))) * G0, float(t[-1] - t[0])


def record_in_ms(folder: Path) -> tuple[Path, float, float]:
    """114655 at 500 Hz, ``Time (ms),Acceleration (m/s^2)``; (file, peak in m/s², duration in s)."""
    t, a = _resampled("adxl_50cm_114655", 500.0)
    path = folder / "logger_ms.csv"
    with path.open("w") as out:
        out.write("Time (ms),Acceleration (m/s^2)\n")
        for ti, ai in zip(t, a):
            out.write(f"{1000 * ti:.3f},{ai:.6f}\n")
    return path, float(np.max(np.abs(np.round(a, 6)))), float(t[-1] - t[0])


def open_tab(page, title: str) -> None:
    page.locator(".bk-tab", has_text=title).first.click()


def diagnose_current(page, record: str) -> dict:
    """Open the Diagnosis tab (a diagnosis of the beam view's record starts when it is not the one
    shown) and wait for its final verdict; returns the diagnosis's status."""
    open_tab(page, "Diagnosis")
    status = wait_for_status(page, f"s.stage === 'final' && s.current === 1 && s.record === {record!r} "
                                   "&& s.shown === s.requested && s.ladder_n >= 1", css="diag-status",
                             timeout_ms=600000)
    expect(page.locator(".diag-verdict").first).to_contain_text(record)
    first = page.evaluate(FIRST_LINE_JS)
    assert first.startswith(f"Diagnosis of {record}"), first
    expect(page.locator(".diag-candidates button:not([disabled])").first).to_be_visible(timeout=30000)
    return status


def load_record(page, path: Path, peak: float, duration: float) -> None:
    """Drop ``path`` on the Your record tab, check what was read, describe the strip, load it."""
    open_tab(page, "Your record")
    page.locator(".record-upload input[type=file]").set_input_files(path)
    status = wait_for_status(page, f"s.stage === 'read' && s.file === {path.name!r}", css="record-status",
                             timeout_ms=120000)
    assert status["peak"] == pytest.approx(peak, rel=0.01), status  # the units read right
    assert status["duration"] == pytest.approx(duration, rel=0.01), status
    for css, value in STRIP.items():
        box = page.locator(f".{css} input")
        box.fill(repr(value))
        box.press("Enter")
    page.locator(".record-material select").select_option("aluminium")
    wait_for_status(page, "s.described === 1", css="record-status", timeout_ms=60000)
    load = page.get_by_role("button", name="Load and calibrate")
    expect(load).to_be_enabled(timeout=30000)
    load.click()
    # the page takes the student to the calibration, which shows the new record's first result
    wait_for_status(page, f"s.record === {path.name!r} && s.shown === s.requested && s.shown > 0 && s.band_n > 0",
                    timeout_ms=300000)


def test_three_records_in_a_row_each_read_diagnosed_and_named(page, tmp_path):
    page.set_viewport_size({"width": 1280, "height": 800})
    phone, phone_peak, phone_s = phone_export_in_g(tmp_path)
    logger, logger_peak, logger_s = record_in_ms(tmp_path)
    page.evaluate(WATCH_JS)

    open_tab(page, "Beam calibration")
    wait_for_status(page, BEAM_FINAL, timeout_ms=300000)
    diagnose_current(page, "lab_run_1")

    for path, peak, seconds in ((phone, phone_peak, phone_s), (logger, logger_peak, logger_s)):
        load_record(page, path, peak, seconds)
        assert read_status(page)["dataset"].startswith("upload-")
        diagnose_current(page, path.name)

    watch = page.evaluate("() => window.__watch")
    print(f"watcher: {watch['polls']} polls, {watch['busy']} with a run going, the status line out of view at most "
          f"{watch['worst'] / 1000:.1f} s")
    assert watch["busy"] > 20, watch  # the watcher saw the runs
    assert watch["stale"] == [], f"Add enabled under another record's diagnosis: {watch['stale'][:5]}"
    assert watch["unnamed"] == [], f"verdicts that do not name their record first: {watch['unnamed'][:5]}"
    assert watch["worst"] <= 5000, f"{watch['worst'] / 1000:.1f} s with a run going and no status line in view"
    assert page.errors == []
