"""A free decay's diagnosis ranks every applicable candidate on the averaged forms first (#40 item 3):
the stream yields that ranking and its verdict before any full fit, each candidate says where its
figures come from, and the full fits replace the averaged figures when they end."""

from __future__ import annotations

import pytest
from record_families import make_record

from beam.calibration import CalibrationSpec, Engine
from beam.discovery.findings import DiagnosisReport, indistinguishable
from beam.discovery.stream import (WAIT, BaseRequest, CurveRequest, FitRequest, Step, diagnosis_stream, drive,
                                   run_request)
from beam.physics.effects import EFFECTS

BASE = ("modal_damping",)
#: Every effect with an averaged form is ranked on a free decay, whatever the record's spectrum says.
NONLINEAR = ("quadratic_drag", "clamp_friction", "tip_cubic_spring")


def _spec(measurement) -> CalibrationSpec:
    """0-5 s of the 12 s record, from its first stamp (a phone's jittered stamps start after 0)."""
    return CalibrationSpec(window=(float(measurement.time_s[0]), 5.0), effects=BASE)


def _averaged_step(measurement):
    """Drive the stream to its averaged Step: (events before it, the Step, the next request after it)."""
    engine = Engine()
    stream = diagnosis_stream(engine, measurement, _spec(measurement))
    seen, pending, step, after = [], [], None, None
    try:
        event = next(stream)
        while after is None:
            if event is WAIT:
                event = stream.send(run_request(pending.pop(0), measurement, engine))
                continue
            if step is not None and isinstance(event, FitRequest):
                after = event
                break
            if isinstance(event, (BaseRequest, CurveRequest, FitRequest)):
                pending.append(event)
            if isinstance(event, Step) and event.report is not None and event.report.source == "averaged":
                step = event
            if step is None:
                seen.append(event)
            event = next(stream)
    finally:
        stream.close()
    return seen, step, after


def test_the_stream_yields_the_averaged_ranking_before_any_full_fit():
    """A phone on an aluminium strip of 0.37 m (jittered stamps about 170 Hz) with air drag
    (C_d drawn 5-20): before any full fit is asked for, the stream yields a complete ranking of
    every applicable candidate — the linear ones and all three nonlinear ones, clamp_friction
    included though the record's spectrum does not call for it — every figure marked averaged,
    its verdict naming the hidden drag; the first full fit asked for after it is the drag's."""
    record = make_record("phone", "quadratic_drag", 0)
    seen, step, after = _averaged_step(record.measurement)
    assert step is not None
    assert not any(isinstance(e, FitRequest) for e in seen)  # no full fit before the averaged ranking
    report = step.report
    effects = {c.effect for c in report.candidates}
    assert set(NONLINEAR) <= effects and "sensor_mass" in effects and "tip_mass" in effects
    assert all(c.source == "averaged" for c in report.candidates)
    assert not report.pending and report.missing == "quadratic_drag"
    assert report.verdict.startswith("missing (averaged forms): quadratic_drag")
    summary = report.to_json()
    assert summary["source"] == "averaged" and {c["source"] for c in summary["candidates"]} == {"averaged"}
    assert summary["missing"] == "quadratic_drag"
    # the averaged figures are the curves': no time-domain RMSE claimed for them
    assert all(c["rmse_prediction"] is None for c in summary["candidates"])
    assert after is not None and "quadratic_drag" in after.effects
    _check_dashboard_words(report)


def _check_dashboard_words(report) -> None:
    """The Diagnosis tab's row of every averaged candidate says so and quotes the curves' figures
    and the curves' parameter values (no NaN error, no "% in the band" of a fit that did not run)."""
    pytest.importorskip("panel")
    from dashboard.outputs.beam import output_units
    from dashboard.views.diagnosis import DiagnosisView

    for c in report.candidates:
        text = DiagnosisView._candidate_text(c, report, output_units(report.base))
        j = c.judgement
        assert "(averaged form)" in text and "nan" not in text.lower() and "in the band" not in text, text
        assert f"{j.judged_after:.2g}" in text and f"{j.judged_before:.2g}" in text, text
        for name, summary in c.parameters.items():
            assert summary["q025"] <= summary["mean"] <= summary["q975"], (c.effect, name, summary)
            assert f"{summary['mean']:.3g}" in text, (name, text)


@pytest.mark.slow
def test_the_full_fits_replace_the_averaged_figures_when_they_end():
    """A sensor at mode 2's node of a 0.26 m steel strip, no hidden effect: the averaged ranking
    names nothing missing; the complete report's linear candidates carry their full fits'
    figures (time-domain RMSE), the nonlinear ones the curves do not call for keep their
    averaged figures and say so, and the complete report also names nothing missing."""
    record = make_record("node", "none", 1)
    m = record.measurement
    engine = Engine()
    steps = []
    report = drive(diagnosis_stream(engine, m, _spec(m)), lambda requests: [run_request(r, m, engine) for r in requests],
                   on_step=steps.append)
    averaged = next(s.report for s in steps if s.report is not None and s.report.source == "averaged")
    assert averaged.missing is None and averaged.verdict.startswith("nothing in the catalogue is missing on the")
    assert isinstance(report, DiagnosisReport) and report.complete and report.source == "full"
    assert report.missing is None
    by = {c.effect: c for c in report.candidates}
    for effect in NONLINEAR:
        assert by[effect].source == "averaged"
    linear = [c for c in report.candidates if not EFFECTS[c.effect].nonlinear]
    assert linear and all(c.source == "full" and c.rmse_calibration > 0 for c in linear)
    text = report.to_json()
    assert {c["effect"]: c["source"] for c in text["candidates"]} == {c.effect: c.source for c in report.candidates}


#: The families and seeds of the agreement test: a phone (100-500 Hz, jittered stamps, at the tip or
#: mid-span) and an accelerometer at mode 2's node, strips of 0.25-0.7 m, every hidden effect.
AGREEMENT_FAMILIES = ("phone", "node")
AGREEMENT_SEEDS = range(5)


def _averaged_names(record) -> set[str]:
    _, step, _ = _averaged_step(record.measurement)
    ranking = step.report.ranking
    return {"none"} if ranking.missing is None else {ranking.missing, *indistinguishable(ranking)}


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="#40 item 3 target not reached: measured 44/50 (88 %); the six misses name "
                                       "nothing (a weak drag or slipping clamp the curves do not see), never a "
                                       "wrong effect (docs/decisions.md)")
def test_the_averaged_ranking_names_the_hidden_effect_on_the_families():
    """On 50 free decays (phone and node families × none, drag, slipping clamp, spring, sensor
    mass × seeds 0-4; 0-5 s of 12 s), the averaged ranking's leader — or a candidate the curves
    cannot tell from it (within 3 nats) — is the hidden effect ("none": nothing named) in at
    least 90 % of cases (the issue's target)."""
    hits, misses = 0, []
    for family in AGREEMENT_FAMILIES:
        for effect in ("none", "quadratic_drag", "clamp_friction", "tip_cubic_spring", "sensor_mass"):
            for seed in AGREEMENT_SEEDS:
                record = make_record(family, effect, seed)
                names = _averaged_names(record)
                if effect in names:
                    hits += 1
                else:
                    misses.append((record.name, sorted(names)))
    total = len(AGREEMENT_FAMILIES) * 5 * len(AGREEMENT_SEEDS)
    assert hits >= 0.9 * total, (hits, total, misses)
