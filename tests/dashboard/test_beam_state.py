"""Beam calibration and diagnosis states against the real ``beam`` library (no browser, no server)."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from beam.calibration import CalibrationSpec, suggest_modes
from dashboard.jobs import beam as beam_jobs
from dashboard.jobs.beam import CalibrationKey, calibration_run, load_upload, record_key
from dashboard.outputs.beam import (
    bands_csv,
    compare_table,
    filename,
    parameter_table,
    posterior_netcdf,
    summary_json,
)
from dashboard.state.beam import BeamState
from dashboard.state.session import SessionState

FAST = 200.0  # target ESS for the tests (the app uses 1000)
ASSETS = Path(__file__).resolve().parents[2] / "assets" / "measurements"


@pytest.fixture
def session(pool):
    s = SessionState(pool=pool, debounce_s=0.05, beam_inputs={"target_ess": FAST})
    yield s
    s.close()
    s.wait(30)


def settle(session, timeout=60.0):
    assert session.wait(timeout), "runs did not finish"


def test_defaults_are_lab_run_1_with_its_window_and_default_effects(session):
    beam = session.beam
    assert beam.dataset == "lab_run_1" and beam.measurement.name == "lab_run_1"
    assert beam.window_s == (0.0, 1.05) and beam.param.window_s.bounds == (0.0, pytest.approx(3.499))
    assert beam.effects == ["air_damping", "kelvin_voigt"] and beam.likelihood == "iid"
    # the modes chosen from the record, as the library's "auto" (7: a 4-mode model truncates its chirp)
    assert beam.modes == suggest_modes(beam.measurement, (0.0, 1.05)).modes == 7
    assert "lab_run_2 — Aluminium strip" in beam.dataset_label("lab_run_2")
    assert "(N s/m²)" in next(iter(beam.effect_options())) or any("kg" in k for k in beam.effect_options())


def test_each_dataset_starts_with_the_modes_of_its_record_and_keeps_an_override():
    for name in ("lab_run_2", "lab_run_3", "lab_run_4", "lab_run_5"):
        state = BeamState(dataset=name)
        assert state.modes == suggest_modes(state.measurement, tuple(state.window_s)).modes
    assert BeamState(dataset="lab_run_1", modes=3).modes == 3


def test_request_publishes_preview_then_final(session):
    beam = session.beam
    seen, seen_results = [], []
    beam.param.watch(lambda e: (seen.append(e.new.is_preview), seen_results.append(e.new)), "result")
    rid = beam.request(debounce=False)
    settle(session)
    times = beam.timings(rid)
    assert times["preview"] < times["final"]
    assert seen[0] is True and seen[-1] is False
    assert beam.stage == "final" and beam.error == "" and beam.shown == rid and beam.progress == 1.0
    assert beam.result is beam.final and beam.final.posterior is not None
    assert beam.final_key == beam.key()
    report = json.loads(summary_json(beam.result).getvalue())
    assert report["measurement"] == "lab_run_1" and report["converged"] and report["preview"] is False
    assert bands_csv(beam.result).getvalue().decode().count("\n") == beam.measurement.time_s.size + 1
    assert posterior_netcdf(beam.result).getvalue()[:4] == b"\x89HDF"
    assert posterior_netcdf(seen_results[0]) is None  # a preview has no posterior
    assert filename(beam.result, "json") == "lab_run_1_w0-1.05_m7_air_damping+kelvin_voigt_iid.json"
    # the final's MAP is kept for a later diagnosis of the same record, window and modes, whose
    # candidate of these effects then recalls it (the same MAP as a cold search)
    known = dict(beam.known_maps())
    assert known[tuple(beam.final.setup.effects)] is beam.final.laplace.map
    from beam.calibration import calibration_preview, remember_maps
    from beam.calibration.engine import forget_maps

    forget_maps()
    remember_maps(beam.measurement, window=beam.key().spec.window, modes=beam.modes, maps=beam.known_maps())
    recalled = calibration_preview(beam.measurement, window=beam.key().spec.window, effects=beam.effects, modes=beam.modes)
    forget_maps()
    cold = calibration_preview(beam.measurement, window=beam.key().spec.window, effects=beam.effects, modes=beam.modes)
    assert recalled.laplace.map.log_posterior == pytest.approx(cold.laplace.map.log_posterior, abs=1e-6)


def test_newer_request_cancels_the_older_and_wins(session):
    beam = session.beam
    shown = []
    beam.param.watch(lambda e: shown.append(e.new.setup.window), "result")
    for end in (0.8, 0.9, 1.0, 1.1, 1.2):
        beam.window_s = (0.0, end)
        time.sleep(0.02)
    settle(session)
    assert beam.result.setup.window == (0.0, 1.2) and beam.shown == beam.requested and beam.stage == "final"
    assert all(w == (0.0, 1.2) for w in shown[-2:])
    assert len(shown) <= 4, "superseded runs must not keep publishing"


def test_leaving_the_job_early_stops_the_sampler():
    m = beam_jobs.load_bundled("lab_run_2")
    key = CalibrationKey(record_key(m), CalibrationSpec(window=(0.0, 1.2), effects=("air_damping", "kelvin_voigt"), modes=2,
                                                   likelihood="iid", seed=0, target_ess=FAST))
    job = calibration_run(key, m, use_cache=False)
    first = next(job)
    assert first.kind == "preview" and first.value.is_preview
    assert next(job).kind == "progress"
    job.close()  # what the scheduler does on cancellation
    with pytest.raises(StopIteration):
        next(job)


def test_bad_window_shows_an_error_and_keeps_the_result(session):
    beam = session.beam
    beam.request(debounce=False)
    settle(session)
    previous = beam.result
    beam.window_s = (1.0, 1.002)  # too few samples
    settle(session)
    assert beam.stage == "error" and "calibration window" in beam.error
    assert beam.result is previous and "previous result" in beam.status
    beam.window_s = (0.0, 1.0)
    settle(session)
    assert beam.error == "" and beam.stage == "final"


def test_invalid_upload_keeps_the_dataset_and_result(session):
    beam = session.beam
    beam.request(debounce=False)
    settle(session)
    previous, requested = beam.result, beam.requested
    assert not beam.upload("bad.csv", b"time_s,voltage_V\nnot,numbers\n", "bad.toml", b"title = 'x'\n")
    assert beam.error.startswith("upload rejected:") and "bad" in beam.error and "/tmp" not in beam.error
    assert beam.dataset == "lab_run_1" and beam.result is previous and beam.requested == requested
    assert not beam.upload("only.csv", b"1,2,3", None, None)
    assert "TOML sidecar is missing" in beam.error


def test_too_large_upload_is_refused_before_parsing(monkeypatch):
    monkeypatch.setattr(beam_jobs, "MAX_UPLOAD_BYTES", 1_000_000)
    with pytest.raises(ValueError, match=r"^big.csv: 1.5 MB \(1,500,000 bytes\) is more than the 1.0 MB \(1,000,000 bytes\) an upload may have$"):
        load_upload("big.csv", b"x" * 1_500_000, "big.toml", b"t")
    monkeypatch.setattr(beam_jobs, "MAX_SIDECAR_UPLOAD_BYTES", 100_000)
    with pytest.raises(ValueError, match=r"^big.toml: 0.1 MB \(150,000 bytes\) is more than the 0.1 MB \(100,000 bytes\)"):
        load_upload("ok.csv", b"x", "big.toml", "t" * 150_000)


def test_upload_limits_are_the_library_limits():
    from beam.io.limits import MAX_MEASUREMENT_BYTES, MAX_TOML_BYTES

    assert beam_jobs.MAX_UPLOAD_BYTES == MAX_MEASUREMENT_BYTES == 64 * 2**20
    assert beam_jobs.MAX_SIDECAR_UPLOAD_BYTES == MAX_TOML_BYTES
    assert beam_jobs.upload_size_text(MAX_MEASUREMENT_BYTES) == "67.1 MB"  # as the upload widget writes it


def test_upload_as_text_reads_as_the_file(tmp_path):
    """The upload widget hands over text/* files decoded: the same measurement as from the bytes."""
    csv, toml = (ASSETS / "lab_run_5.csv").read_bytes(), (ASSETS / "lab_run_5.toml").read_bytes()
    from_bytes = load_upload("a.csv", csv, "a.toml", toml)
    from_text = load_upload("a.csv", csv.decode("utf-8"), "a.toml", toml.decode("utf-8"))
    assert from_text.time_s.size == from_bytes.time_s.size == 2400
    assert (from_text.displacement_m == from_bytes.displacement_m).all()
    assert from_text.geometry == from_bytes.geometry


def test_valid_upload_becomes_the_dataset(session):
    beam = session.beam
    ok = beam.upload("mine.csv", (ASSETS / "lab_run_5.csv").read_bytes(), "mine.toml", (ASSETS / "lab_run_5.toml").read_bytes())
    assert ok and beam.error == ""
    assert beam.dataset.startswith("upload-1-mine") and beam.measurement.name == "mine"
    assert beam.dataset_label(beam.dataset).startswith("upload: mine")
    settle(session)
    assert beam.stage == "final" and beam.result.setup.measurement.name == "mine"


def test_pin_and_compare_table(session):
    beam = session.beam
    beam.request(debounce=False)
    settle(session)
    beam.pin()
    beam.modes = 2
    settle(session)
    table = compare_table(beam.result, beam.pinned)
    assert list(table.columns) == ["Pinned", "Current"]
    assert "Held-out RMSE (µm)" in table.index and "EI — bending stiffness of the bare beam (N m²)" in table.index
    assert "(N m²)" in parameter_table(beam.result).index[0]


def test_add_appends_a_ladder_rung_and_the_error_falls(pool):
    s = SessionState(pool=pool, debounce_s=0.0, beam_inputs={"target_ess": FAST, "dataset": "lab_run_2"})
    try:
        beam, diag = s.beam, s.diagnosis
        beam.request(debounce=False)
        settle(s)
        diag.request()
        settle(s)
        assert diag.stage == "final" and diag.diagnosis.missing == "tip_mass"
        assert diag.diagnosis.candidates[0].effect == "tip_mass" and diag.diagnosis.candidates[0].explanation
        assert len(diag.ladder) == 1 and diag.ladder[0]["mcmc"]
        diag.add("tip_mass")
        assert diag.adding == "tip_mass" and "tip_mass" in beam.effects
        settle(s)
        assert diag.adding == "" and len(diag.ladder) == 2
        rung = diag.ladder[1]
        assert rung["added"] == "tip_mass" and rung["mcmc"]
        assert diag.ladder[0]["rmse_prediction"] > 3 * rung["rmse_prediction"]
        answer = diag.reveal()
        assert answer["effects"] == ["air_damping", "kelvin_voigt", "tip_mass"]
        assert answer["noise_m"] == pytest.approx(2e-5)  # the truth file of lab_run_2
        # after Add the whole diagnosis re-runs for the new model, and the ladder is kept
        assert diag.is_current() and "tip_mass" in diag.diagnosis.key.spec.effects
        assert len(diag.ladder) == 2 and diag.ladder[1]["added"] == "tip_mass"
        assert "tip_mass" not in [c.effect for c in diag.diagnosis.candidates]
    finally:
        s.close()
        s.wait(30)


def test_a_diagnosis_in_progress_stops_when_the_beam_model_changes(pool):
    """Its fits would hold the worker processes for a model no longer shown: it is cancelled, says
    so, and publishes nothing more; a diagnosis of the new model can be asked for at once."""
    s = SessionState(pool=pool, debounce_s=0.0, beam_inputs={"target_ess": FAST, "dataset": "lab_run_1", "modes": 4})
    try:
        beam, diag = s.beam, s.diagnosis
        beam.request(debounce=False)
        settle(s)
        diag.request()
        deadline = time.monotonic() + 120
        while diag.stage not in ("preview", "sampling") and time.monotonic() < deadline:
            time.sleep(0.02)
        assert diag.stage in ("preview", "sampling")  # the diagnosis is running
        beam.window_s = (beam.window_s[0], beam.window_s[1] + 0.05)  # the teacher moves the window
        assert diag.stage == "idle" and "changed" in diag.status
        settle(s)
        assert diag.stage == "idle" and (diag.diagnosis is None or diag.diagnosis.pending)  # no final published
        diag.request()
        settle(s)
        assert diag.stage == "final" and diag.is_current()
    finally:
        s.close()
        s.wait(30)
