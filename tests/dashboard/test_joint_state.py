"""The "Several records" flow without a browser: joint calibration and diagnosis through the
session's run slots, the view's panels and tables, errors that keep the previous result.

The records are the two real runs of the 50 cm aluminium strip shipped in ``assets/real`` (Enes
Demirkaya, MIT licence): one strip, one length, one sensor position, so one beam explains both.
Laplace (preview-level) only, short windows.
"""

from __future__ import annotations

import html
import math

import numpy as np
import pytest
from bokeh.models import ColumnDataSource
from scipy import signal

from beam.discovery.joint import SEPARATING_NATS, joint_diagnose
from beam.discovery.ranking import MATERIAL_LOG_EVIDENCE
from beam.discovery.suggest import next_record
from dashboard.jobs.joint import load_record
from dashboard.views.joint import JointView, diagnosis_table_html, interval_html, interval_text, suggestion_html

RUNS = ["adxl_50cm_114655", "adxl_50cm_114759"]
INPUTS = {"window_s": (0.0, 1.0), "modes": 2, "effects": ["modal_damping", "sensor_mass"], "sampling": 0}


def _calibrated(session) -> object:
    joint = session.joint
    assert joint.records == RUNS, "the shipped real runs are chosen at first"
    joint.param.update(**INPUTS)
    rid = joint.calibrate()
    assert session.wait(600)
    assert joint.stage == "final", (joint.status, joint.error)
    assert joint.shown == rid
    return joint.result


def test_joint_calibration_of_two_records_narrows_the_shared_intervals_and_draws_a_panel_per_record(session):
    outcome = _calibrated(session)
    assert outcome.names == RUNS
    assert set(outcome.joint.shared_names) >= {"bending_stiffness_Nm2", "sensor_mass_kg"}
    # each record's own calibration (same model, window, modes) is the independent reference: one
    # record's data inform EI and the sensor mass less than both records' together. Compared on the
    # Laplace sd of the sampling coordinate (exact; the table's intervals come from random draws)
    rows = {r["name"]: r for r in outcome.shared_rows()}
    for name in ("bending_stiffness_Nm2", "sensor_mass_kg"):
        joint_sd = math.sqrt(outcome.joint.laplace.cov[outcome.joint.problem.index(name)][outcome.joint.problem.index(name)])
        alone_sd = [math.sqrt(s.laplace.cov[s.problem.names.index(name)][s.problem.names.index(name)])
                    for s in outcome.singles]
        assert joint_sd < min(alone_sd), (name, joint_sd, alone_sd)
        alone = rows[name]["alone"]
        assert len(alone) == 2 and all(a is not None for a in alone)
        # the joint estimate lies between the single records' (a weighted compromise of the two)
        joint = rows[name]["joint"]
        width = joint["q975"] - joint["q025"]
        lo, hi = sorted(a["mean"] for a in alone)
        assert lo - width < joint["mean"] < hi + width
    # a 50 cm aluminium strip with a ~4 g sensor: its mass in grams, not milligrams or kilograms
    assert 0.002 < rows["sensor_mass_kg"]["joint"]["mean"] < 0.008
    for k, record in enumerate(outcome.records):
        m = load_record(RUNS[k])
        assert record["record"] == RUNS[k] and record["window_s"] == [0.0, 1.0]
        # the joint model's f1 against the record's own period: upward zero crossings of its mode 1
        # (low-passed at 15 Hz, below mode 2 near 39 Hz) over 2-6 s of the free decay
        t, y = m.time_s, m.output
        b, a = signal.butter(4, 15.0, fs=1.0 / float(np.median(np.diff(t))))
        z = signal.filtfilt(b, a, y - y.mean())
        inside = (t >= 2.0) & (t <= 6.0)
        up = t[inside][np.flatnonzero(np.diff(np.sign(z[inside])) > 0)]
        f1 = (up.size - 1) / (up[-1] - up[0])
        assert record["frequencies_Hz"][0] == pytest.approx(f1, rel=0.01)
        assert record["rmse_calibration"] < record["rmse_prediction"] or math.isnan(record["rmse_prediction"])

    view = JointView(session=session)
    view.build()
    assert len(view.panels) == 2
    root = view.layout.get_root()
    for k in range(2):
        data = [s for s in root.select({"type": ColumnDataSource}) if s.name == f"joint-data-{k}"]
        band = [s for s in root.select({"type": ColumnDataSource}) if s.name == f"joint-band-{k}"]
        assert len(data) == 1 and len(band) == 1
        assert len(data[0].data["time_s"]) > 100 and len(band[0].data["upper"]) > 100
        upper, lower = np.asarray(band[0].data["upper"]), np.asarray(band[0].data["lower"])
        drawn = np.isfinite(upper) & np.isfinite(lower)  # the band is not drawn where the record is clipped
        assert drawn.mean() > 0.5 and np.all(upper[drawn] >= lower[drawn])
        panel = view.panels[k]
        assert (panel.window.left, panel.window.right) == (0.0, 1.0)
        assert panel.figure.yaxis[0].axis_label == "Acceleration (m/s²)"


def test_a_failed_request_keeps_the_result_and_says_why(session):
    outcome = _calibrated(session)
    joint = session.joint
    joint.per_record = "no_such_parameter"
    joint.calibrate()
    assert session.wait(300)
    assert joint.stage == "error"
    assert "no_such_parameter" in joint.error and "Traceback" not in joint.error
    assert joint.result is outcome and "previous result" in joint.status


def test_joint_diagnosis_merges_the_candidates_as_the_library_ranks_them(session):
    joint = session.joint
    joint.param.update(window_s=(0.0, 1.0), modes=2, effects=["modal_damping"])
    candidates = ("sensor_mass", "tip_mass")
    rid = joint.diagnose(candidates)  # one candidate per call on the worker processes, merged
    assert session.wait(600)
    assert joint.diag_run.stage == "final", (joint.diag_run.status, joint.diag_run.error)
    assert joint.diag_run.requested == rid
    merged = joint.diagnosis
    # the library's joint diagnosis of both candidates in one call: the reference
    reference = joint_diagnose(joint.measurements(), window=(0.0, 1.0), modes=2, base=("modal_damping",),
                               candidates=list(candidates))
    assert [c.effect for c in merged.candidates] == [c.effect for c in reference.candidates]
    for a, b in zip(merged.candidates, reference.candidates):
        assert a.delta_log_evidence == pytest.approx(b.delta_log_evidence, abs=0.5)
        assert np.allclose(a.records_delta_log_evidence, b.records_delta_log_evidence, atol=0.5)
    assert merged.missing == reference.missing
    assert merged.verdict().split(".")[0] == reference.verdict().split(".")[0]
    # the view's table: the candidates in the ranked order, a column per record
    table = diagnosis_table_html(merged)
    assert table.index('data-effect="sensor_mass"') > 0 and table.index('data-effect="tip_mass"') > 0
    order = sorted(candidates, key=lambda e: table.index(f'data-effect="{e}"'))
    assert order == [c.effect for c in reference.candidates]
    assert "Record 1 alone (nats)" in table and "Record 2 alone (nats)" in table and "Record 3" not in table
    # which record to take next: the library's answer for these fits, shown in the view's words
    ranked = [(c.effect, c.delta_log_evidence) for c in merged.candidates]
    assert merged.suggestion == next_record(ranked, lambda a, b: [merged.fits[a], merged.fits[b]])
    assert html.escape(merged.suggestion["words"]) in suggestion_html(merged)
    gap = ranked[0][1] - ranked[1][1]
    assert merged.suggestion["needed"] == (ranked[0][1] >= MATERIAL_LOG_EVIDENCE and gap < SEPARATING_NATS)


def test_interval_text_shows_the_width_of_the_interval():
    assert interval_text({"mean": 2.13654, "q025": 2.13633, "q975": 2.13676}) == "2.13654 (2.13633–2.13676)"
    assert interval_text({"mean": 0.004084, "q025": 0.004077, "q975": 0.004091}) == "0.004084 (0.004077–0.004091)"
    # the narrow cell: the mean over the interval's reach, the interval itself in the tooltip
    symmetric = interval_html({"mean": 2.13654, "q025": 2.13633, "q975": 2.13676})
    assert "2.13654</span><br>" in symmetric and "± 0.00022" in symmetric
    assert 'title="2.13654 (2.13633–2.13676)"' in symmetric
    skewed = interval_html({"mean": 1.0, "q025": 0.9, "q975": 1.3})
    assert "−0.1 +0.3" in skewed and "±" not in skewed
    assert interval_html(None) == "–"
    assert interval_text(None) == "–"


def test_cancel_stops_the_joint_calibration_and_publishes_nothing(session):
    joint = session.joint
    joint.param.update(**INPUTS)
    joint.calibrate()
    joint.cancel()
    assert session.wait(300)
    assert joint.stage == "idle" and joint.result is None and "cancelled" in joint.status


def test_joint_mcmc_publishes_the_preview_then_the_posterior(session):
    joint = session.joint
    joint.param.update(**{**INPUTS, "sampling": 0})
    joint.param.sampling.objects = {**joint.param.sampling.objects, "MCMC, 30 steps": 30}  # short: a test
    joint.sampling = 30
    shown = []
    joint.param.watch(lambda e: shown.append(e.new), "result")
    joint.calibrate()
    assert session.wait(600)
    assert joint.stage == "final", (joint.status, joint.error)
    # the joint preview first, then the MCMC posterior
    assert [(o.joint.is_preview, o.joint.posterior is not None) for o in shown] == [(True, False), (False, True)]
    laplace, mcmc = (o.joint.summary()["sensor_mass_kg"] for o in shown)
    assert shown[1].joint.posterior.diagnostics is not None
    # a short chain from the joint MAP: its mean within a few Laplace sds of the Laplace one
    assert abs(mcmc["mean"] - laplace["mean"]) < 5 * laplace["sd"], (mcmc, laplace)
