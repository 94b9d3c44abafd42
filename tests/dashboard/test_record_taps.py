"""The "Your record" flow for a record of several taps and artifacts, without a browser: the view says
how many taps were found and what was removed; *Load and calibrate* hands every tap to the "Several
records" view and calibrates them together there, the strongest to the beam calibration.

The record: the simulated steel bar of tests/artifact_records.py tapped three times, with mains hum,
written as a lab's CSV export.
"""

from __future__ import annotations

import pytest

from dashboard.views.record import loaded_html, read_html
from tests.artifact_records import mains_hum, tapped_bar, write_table

BAR_FORM = {"length_m": 0.4, "width_m": 0.02, "thickness_m": 0.003, "material": "steel", "sensor_position_m": 0.03}


@pytest.fixture(scope="module")
def three_taps(tmp_path_factory):
    t, y, _ = tapped_bar((0.2, 6.2, 12.2), (0.02, 0.04, 0.01), duration_s=18.0, noise=2e-7)
    hum = mains_hum(60.0, (1, 3), (3e-7, 1.5e-7))
    path = write_table(tmp_path_factory.mktemp("taps") / "bar.csv", "time (s),strain (microstrain)", t,
                       y + hum.evaluate(t), scale=1e6, digits=7)
    return path.read_bytes()


@pytest.mark.slow
def test_the_view_says_the_taps_and_the_artifacts_and_loads_them_together(session, three_taps):
    r = session.record
    r.upload("bar.csv", three_taps)
    assert session.wait(60) and r.stage == "read"
    summary = r.read.summary()
    assert summary["taps"] == 3 and len(summary["segments"]) == 3 and summary["segment_used"] == 1
    assert any("mains hum (60 Hz) removed" in line for line in summary["artifacts"])
    shown = read_html(summary)
    assert "3 taps: one beam at 3 amplitudes, calibrated together" in shown and "mains hum (60 Hz) removed" in shown
    assert all(abs(p.frequency_Hz - 60.0) > 0.5 for p in r.read.peaks)  # the hum is no peak of the spectrum
    r.param.update(**BAR_FORM)
    assert session.wait(60) and r.described is not None and len(r.described.measurement.taps) == 3
    assert "3 taps found" in r.described.summary

    name = r.load()
    assert name == "upload-2-bar" and session.beam.dataset == name  # the strongest (tap 2) to the beam calibration
    assert r.loaded_taps == ["upload-1-bar_tap1", "upload-2-bar", "upload-3-bar_tap3"]
    joint = session.joint
    assert list(joint.records) == r.loaded_taps and joint.stage in ("queued", "preview", "sampling", "final")
    assert [m.name for m in joint.measurements()] == ["bar_tap1", "bar", "bar_tap3"]
    notice = loaded_html(r.loaded, r.loaded_taps)
    assert "3 taps" in notice and "calibrated together" in notice and "Several records" in notice
    joint.cancel()
    assert r.load() == name and len(session.beam.uploads) == 3  # loading twice adds nothing
