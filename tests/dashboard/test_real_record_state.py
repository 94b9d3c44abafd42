"""The bundled real record (aluminium strip, accelerometer, free decay, irregular stamps) in the
beam and diagnosis states: its defaults, its quantity and unit in read-outs, tables and plots,
the record-aware candidates (``sensor_mass``) and no known answer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dashboard.jobs.beam import bundled_datasets, load_upload, read_answer
from dashboard.outputs.beam import compare_table, judged_readouts, parameter_table, readouts, verdict_text
from dashboard.state.beam import NO_ANSWER
from dashboard.state.session import SessionState

REAL = "adxl_50cm_114655"
REAL_DIR = Path(__file__).resolve().parents[2] / "assets" / "real"


def settle(session, timeout=300.0):
    assert session.wait(timeout), "runs did not finish"


def test_real_record_is_listed_as_a_teaching_case_without_an_answer():
    label = bundled_datasets()[REAL]
    assert "Real aluminium strip (accelerometer)" in label and "misses something" in label
    assert read_answer(REAL) is None


def test_upload_of_an_acceleration_record():
    csv, toml = REAL_DIR / f"{REAL}.csv", REAL_DIR / f"{REAL}.toml"
    m = load_upload(csv.name, csv.read_bytes(), toml.name, toml.read_bytes())
    assert m.output_kind == "acceleration" and m.output_unit == "m/s²" and m.is_free


def test_real_record_calibrates_and_diagnoses_in_its_unit(pool):
    s = SessionState(pool=pool, debounce_s=0.0, beam_inputs={"target_ess": 200.0})
    try:
        beam, diag = s.beam, s.diagnosis
        beam.dataset = REAL
        # the library's `beam diagnose RECORD --window 0:2 --base modal_damping` ('auto': a free decay keeps 4 modes)
        assert beam.window_s == (0.0, 2.0) and beam.effects == ["modal_damping"] and beam.modes == 4
        assert beam.measurement.output_kind == "acceleration"
        previews = []
        # (a new record clears the previous record's result: None until its preview, issue #39)
        beam.param.watch(lambda e: previews.append(e.new.is_preview) if e.new is not None else None, "result")
        settle(s)
        assert beam.stage == "final", beam.error
        assert previews[0] is True and previews[-1] is False
        r = readouts(beam.result)
        assert r["unit"] == "m/s²"
        # read-outs in m/s² are the library's RMSE unscaled (the README measures ~1.1 m/s² in the window)
        assert r["rmse_calibration"] == pytest.approx(beam.result.rmse_calibration)
        assert 0.3 < r["rmse_calibration"] < 3.0
        items = {it["key"]: it for it in judged_readouts(beam.result)}
        assert {items[k]["unit"] for k in ("rmse_calibration", "rmse_prediction", "noise_sd")} == {"m/s²"}
        assert "µm" not in " ".join(it["words"] for it in items.values())
        assert "Noise sd σ (m/s²)" in parameter_table(beam.result).index
        assert "Held-out RMSE (m/s²)" in compare_table(beam.result).index

        from dashboard.plots.beam import MAX_POINTS, BeamTimeSeriesPlot
        from dashboard.plots.diagnosis import DiagnosisPlots

        plot = BeamTimeSeriesPlot()
        assert plot.figure.yaxis.axis_label == "Displacement (mm)"
        plot.update(beam.result)
        assert plot.figure.yaxis.axis_label == "Acceleration (m/s²)"
        data = plot.sources["data"].data["value"]  # drawn in m/s² (thinned), not scaled as a displacement
        y = beam.measurement.output
        stride = -(-y.size // MAX_POINTS)
        np.testing.assert_allclose(data, y[::stride], rtol=1e-12)

        diag.request()
        settle(s)
        assert diag.stage == "final", diag.error
        d = diag.diagnosis
        names = [c.effect for c in d.candidates]
        assert "sensor_mass" in names  # offered for an accelerometer record
        # the README's finding on this run: a mass near the tip comes first
        assert names[0] in ("sensor_mass", "tip_mass")
        text = verdict_text(d)
        assert "m/s²" in text and "µm" not in text
        # as the command line's verdict: a decay judged on its window, the look-alike repairs named
        assert "the error in the calibration window is" in text
        assert "only mode 3 tells them apart" in text or "The data cannot tell it from" in text, text
        assert "calibration-window RMSE" in d.verdict
        assert diag.ladder[0]["unit"] == "m/s²"
        assert diag.ladder[0]["rmse_prediction"] == pytest.approx(beam.final.rmse_prediction)
        plots = DiagnosisPlots()
        plots.update(d)
        assert plots.data["residual"]["unit"] == "m/s²" and plots.data["spectrum"]["psd_unit"] == "(m/s²)²/Hz"

        assert diag.reveal() is None and diag.status == NO_ANSWER and not diag.has_answer()
        # back to a simulated lab run: its own defaults again, and an answer to reveal
        beam.dataset = "lab_run_1"
        assert beam.effects == ["air_damping", "kelvin_voigt"] and beam.window_s == (0.0, 1.05)
        assert diag.has_answer()
    finally:
        s.close()
        s.wait(30)
