"""The diagnosis's words against its numbers: the modes table's one sign convention."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from beam.residuals import DIFFERENCE_CONVENTION, compare_modes, difference_words

ROOT = str(Path(__file__).resolve().parents[1])
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)


def _direction(words: str) -> int:
    """+1 for "… higher", -1 for "… lower", 0 for "matches"."""
    return 1 if words.endswith("higher") else -1 if words.endswith("lower") else 0


def test_difference_words_read_as_the_measured_value_against_the_model():
    # measured 5.513 Hz, model 4.693 Hz: the measured mode is 17.5 % higher than the model's
    (row,) = compare_modes(([5.513], [0.002]), [4.693], [0.004])
    assert row.frequency_error_pct == pytest.approx(100 * (5.513 / 4.693 - 1))
    assert difference_words(row.frequency_error_pct) == "17.5 % higher"
    assert difference_words(row.damping_error_pct, 0) == "50 % lower"  # 0.002 measured against 0.004
    assert difference_words(0.04) == "matches" and difference_words(math.nan) == "–"
    assert "positive when the measured value is higher" in DIFFERENCE_CONVENTION


def test_the_dashboard_modes_table_says_what_it_computes():
    """Every row's words agree with the table's own measured and model columns (the same
    convention as the JSON's ``frequency_error_pct``)."""
    pytest.importorskip("panel")
    from dashboard.views.diagnosis import modes_table

    rng = np.random.default_rng(4)
    model = np.array([4.693, 29.41, 82.35, 161.4])
    measured = model * (1 + rng.uniform(-0.3, 0.3, model.size))
    comparison = compare_modes((measured[:3], [0.0017, 0.0015, 0.004]), model, [0.036, 0.0061, 0.0029, 0.0028])
    table = modes_table(SimpleNamespace(residuals=SimpleNamespace(comparison=comparison)))
    assert "measured f vs model" in table.columns and "measured ζ vs model" in table.columns
    for row, match in zip(table.itertuples(), comparison):
        words = table.loc[row.Index, "measured f vs model"]
        if not match.matched:
            assert words == "–"
            continue
        shown_data, shown_model = float(table.loc[row.Index, "measured f (Hz)"]), float(table.loc[row.Index, "model f (Hz)"])
        assert _direction(words) == np.sign(round(shown_data - shown_model, 2))
        assert float(words.split(" %")[0]) == pytest.approx(abs(100 * (shown_data / shown_model - 1)), abs=0.1)
        zeta = table.loc[row.Index, "measured ζ vs model"]
        assert _direction(zeta) == np.sign(match.damping_data - match.damping_model)


# -- the verdict and the ranking: words against numbers -----------------------------------------
import re  # noqa: E402

from beam.discovery.ranking import MATERIAL_LOG_EVIDENCE, contradicted, held_out_change, window_only  # noqa: E402
from beam.discovery.report import AT_NOISE_RATIO, Remaining, remaining_words, verdict_sentence  # noqa: E402
from beam.residuals import NoiseFloor  # noqa: E402

FLOOR = NoiseFloor(1.5e-5, (350.0, 400.0), (1.5e-5,))
#: Words that present an evidence gain as support for the effect.
SUPPORT = re.compile(r"odds[^.;]*for the effect|(?<!no )support for the effect|data favour it", re.IGNORECASE)


def test_at_the_noise_a_small_pattern_is_a_note_on_the_noise_model():
    """The default class flow's case: 1.1× the noise, Ljung–Box p = 0.00026."""
    at_noise = Remaining(FLOOR, 1.1, white=False, ljung_box_p=2.6e-4)
    words = verdict_sentence(None, 0.0, 1.6e-5, 1.6e-5, at_noise)
    assert "predicts to the noise" in words and "AR(1)" in words and "noise model" in words
    assert "outside the catalogue" not in words and "1 in 3,800" in words
    above = Remaining(FLOOR, 12.0, white=False, ljung_box_p=1e-9)
    words = verdict_sentence(None, 0.0, 1.8e-4, 1.8e-4, above)
    assert "outside the catalogue" in words and "predicts to the noise" not in words
    assert "below one in a million" not in words  # the tail quotes the ratio; no p-value there
    for ratio in (0.9, AT_NOISE_RATIO):
        assert "predicts to the noise" in remaining_words(Remaining(FLOOR, ratio, white=False, ljung_box_p=1e-12))


def _fake_candidate(gain: float, held_out: float, material: bool = False):
    from beam.discovery.ranking import Candidate

    return Candidate("tip_cubic_spring", gain, held_out, held_out, 0.9, material, "", {})


def _fake_base(held_out: float, free: bool = False):
    return SimpleNamespace(rmse_prediction_map=held_out, rmse_calibration_map=held_out,
                           setup=SimpleNamespace(is_free=free, measurement=SimpleNamespace(output_kind="displacement")))


def test_a_window_only_gain_is_never_worded_as_support():
    """+592 nats with a held-out error 15 % higher (lab_run_1's spring on the default model)."""
    pytest.importorskip("panel")
    from dashboard.views.diagnosis import DiagnosisView

    base = _fake_base(1.15e-3)
    c = _fake_candidate(591.9, 1.32e-3)
    assert window_only(c, base) and held_out_change(c, base) == pytest.approx(0.148, abs=1e-3)
    diagnosis = SimpleNamespace(base=base)
    from dashboard.outputs.beam import output_units

    text = DiagnosisView._candidate_text(c, diagnosis, output_units(None))
    assert not SUPPORT.search(text), text
    assert "not borne out on held-out data" in text
    supported = _fake_candidate(12.0, 0.5e-3, material=True)
    assert not window_only(supported, base)
    assert "odds" in DiagnosisView._candidate_text(supported, diagnosis, output_units(None))


def check_ranking_words(ranking, texts: dict[str, str]) -> None:
    """The ranking's words against its numbers (issue: no support wording for a candidate whose
    held-out error rises; no "no sign of" beside a large evidence without the explanation)."""
    base = ranking.base
    for c in ranking.candidates:
        text = texts[c.effect]
        if contradicted(c, base):  # a gain while the held-out error rises (beyond the optimiser's noise)
            assert not SUPPORT.search(text), (c.effect, text)
        if c.delta_log_evidence >= MATERIAL_LOG_EVIDENCE and "no sign of" in c.explanation:
            # beside a large evidence, the explanation quotes it and the error that judges it
            assert f"+{c.delta_log_evidence:.0f} nats" in c.explanation and "error" in c.explanation, c.explanation
        if window_only(c, base):  # the rise is quoted
            rise = 100 * held_out_change(c, base)
            assert any(f"{rise:.{d}f} % higher" in c.explanation for d in (0, 1)), c.explanation
    # contradicted candidates never rank above one whose evidence its held-out error does not contradict
    flags = [window_only(c, base) for c in ranking.candidates if not c.material and np.isfinite(c.delta_log_evidence)]
    assert flags == sorted(flags)


DATASETS = [f"assets/measurements/lab_run_{i}.csv" for i in range(1, 6)] + sorted(
    str(p) for p in Path("assets/real").glob("*.csv"))


@pytest.mark.slow
@pytest.mark.parametrize("path", DATASETS)
def test_the_ranking_words_match_their_numbers_on_the_bundled_datasets(path):
    pytest.importorskip("panel")
    from beam.calibration import calibration_preview
    from beam.discovery.ranking import rank_candidates
    from beam.discovery.report import explainer, residual_report
    from beam.io.measurement import read_measurement
    from dashboard.outputs.beam import output_units
    from dashboard.views.diagnosis import DiagnosisView

    m = read_measurement(path)
    base = calibration_preview(m, modes="auto")
    ranking = rank_candidates(m, base=base.setup.effects, modes=base.setup.modes, base_result=base,
                              explain=explainer(residual_report(base)))
    diagnosis = SimpleNamespace(base=base)
    u = output_units(base)
    texts = {c.effect: DiagnosisView._candidate_text(c, diagnosis, u) + " " + c.explanation for c in ranking.candidates}
    check_ranking_words(ranking, texts)


@pytest.mark.slow
def test_the_default_class_flow_ends_at_the_noise_without_contradiction():
    """lab_run_1 (0-1.05 s, 7 modes) with its two true effects added, as the class does with Add: the
    command line's verdict and the dashboard's say the model predicts to the noise, and nothing
    calls the rest outside the catalogue."""
    pytest.importorskip("panel")
    import tomllib

    from beam.calibration import CalibrationSpec
    from beam.discovery.report import diagnose
    from beam.io.measurement import read_measurement
    from dashboard.jobs.beam import CalibrationKey
    from dashboard.jobs.diagnosis import Diagnosis
    from dashboard.outputs.beam import verdict_text
    from dashboard.views.diagnosis import _whiteness_text

    with open("assets/answers/lab_run_1.truth.toml", "rb") as f:
        effects = tuple(tomllib.load(f)["effects"])
    report = diagnose(read_measurement("assets/measurements/lab_run_1.csv"), window=(0.0, 1.05), modes=7, base=effects)
    assert report.missing is None and report.remaining.at_noise, report.verdict
    assert "predicts to the noise" in report.verdict and "outside the catalogue" not in report.verdict
    d = Diagnosis.of(report, CalibrationKey("lab_run_1", CalibrationSpec(window=(0.0, 1.05), effects=effects, modes=7,
                                                                       likelihood="iid")))  # the dashboard's
    words = verdict_text(d) + " " + _whiteness_text(d)
    assert "predicts to the noise" in words and "outside the catalogue" not in words, words
    assert "not missing physics" in words or report.remaining.white
    check_ranking_words(report.ranking, {c.effect: c.explanation for c in report.ranking.candidates})
