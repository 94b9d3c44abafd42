"""Read-outs, comparison table and downloads of toy results (no browser)."""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest

from beam.toy import ToyScenario
from dashboard.jobs import toy as toy_jobs
from dashboard.outputs import exports
from dashboard.outputs.toy import (
    PARAMETER_LABELS,
    change_words,
    compare_table,
    judge,
    readouts,
    result_label,
    user_message,
)


@pytest.fixture(scope="module")
def results():
    """(preview, final) of a small scenario with discrepancy."""
    stages = list(toy_jobs.toy_run(ToyScenario(discrepancy=0.3, kind="tone", target_ess=200, seed=2), use_cache=False))
    return stages[0].value, stages[-1].value


def test_readouts_have_units_and_sane_values(results):
    _, final = results
    r = readouts(final)
    # percentages of the held-out samples, counted here from the bands
    held, bands, data = final.data.held_out, final.bands, final.data
    inside = (data.data >= bands.prediction_lower) & (data.data <= bands.prediction_upper)
    assert r["coverage_pct"] == pytest.approx(100.0 * np.count_nonzero(inside & held) / np.count_nonzero(held))
    truth_inside = (data.truth >= bands.credible_lower) & (data.truth <= bands.credible_upper)
    assert r["credible_truth_pct"] == pytest.approx(100.0 * np.count_nonzero(truth_inside & held) / np.count_nonzero(held))
    assert r["rmse_du"] > 0 and r["frequency_sd_mHz"] > 0 and r["noise_sd_du"] > 0
    assert math.isclose(r["coverage_pct"], 100 * final.coverage95_prediction)
    assert all(math.isnan(v) for v in readouts(None).values())


def test_compare_table_side_by_side(results):
    preview, final = results
    table = compare_table(final, preview)
    assert list(table.columns) == ["Pinned", "Current", "Truth"]
    for label in PARAMETER_LABELS.values():
        if "AR(1)" not in label:
            assert label in table.index
    assert table.loc["Stage", "Pinned"] == "preview (MAP + Laplace)"
    assert table.loc["Stage", "Current"] == "posterior (MCMC)"
    assert "±" in table.loc["Frequency f (Hz)", "Current"]
    assert list(compare_table(final).columns) == ["Current", "Truth"]
    assert compare_table(None).empty
    assert "window 5 s" in result_label(final) and "tone" in result_label(final)


def test_json_summary_is_valid_json(results):
    preview, final = results
    report = json.loads(exports.summary_json(final).getvalue())
    assert report["stage"] == "final" and report["scenario"]["kind"] == "tone"
    assert set(report["posterior"]) >= {"amplitude", "frequency_Hz", "phase_rad", "noise_sd"}
    assert json.loads(exports.summary_json(preview).getvalue())["stage"] == "preview"
    assert exports.summary_json(None) is None


def test_band_csv_has_one_row_per_sample(results):
    _, final = results
    rows = list(csv.reader(io.StringIO(exports.bands_csv(final).getvalue().decode())))
    assert tuple(rows[0]) == exports.CSV_COLUMNS
    assert len(rows) - 1 == final.data.time_s.size
    first = dict(zip(rows[0], rows[1]))
    assert first["in_calibration_window"] == "1" and float(first["time_s"]) == 0.0
    lo, hi = float(first["prediction95_lower_du"]), float(first["prediction95_upper_du"])
    assert lo < float(first["posterior_mean_du"]) < hi


def test_netcdf_only_for_a_posterior(results, tmp_path):
    preview, final = results
    assert exports.posterior_netcdf(preview) is None
    data = exports.posterior_netcdf(final).getvalue()
    assert data[:4] == b"\x89HDF"  # netCDF-4 is HDF5
    path = tmp_path / "post.nc"
    path.write_bytes(data)
    from beam.inference import load_inference_data

    idata = load_inference_data(path)
    assert "frequency_Hz" in idata.posterior


def test_filenames_describe_the_scenario(results):
    _, final = results
    assert exports.filename(final, "csv") == "toy_w5_d0.3_tone_iid_seed2.csv"


def test_user_messages_drop_command_line_options():
    assert user_message("window (--window 12 s) must be shorter than the horizon (--horizon 10 s)") == (
        "window (12 s) must be shorter than the horizon (10 s)")
    assert user_message("noise sd (--noise) must not be negative, got -1") == "noise sd must not be negative, got -1"
    assert user_message("frequency must lie in the prior range [0.2, 5] Hz") == "frequency must lie in the prior range [0.2, 5] Hz"


# -- the beam views' words and judgements -------------------------------------------------------------
@pytest.mark.parametrize("name", ["lab_run_1", "lab_run_2", "lab_run_3", "lab_run_4", "lab_run_5"])
def test_noise_floor_reads_the_true_sensor_noise_of_each_bundled_record(name):
    from beam.io.simulation import read_truth
    from dashboard.jobs.beam import ASSETS, load_bundled
    from dashboard.outputs.beam import noise_floor_m

    true = read_truth(ASSETS / "answers" / f"{name}.truth.toml").noise_m  # what the record was simulated with
    assert noise_floor_m(load_bundled(name)) == pytest.approx(true, rel=0.15)


def test_readouts_judge_a_missing_effect_by_its_noise_not_by_its_coverage():
    """lab_run_1 without patch stiffening: ~99 % coverage from a noise sd ~90x the sensor's is not good news."""
    from beam.calibration import calibration_preview
    from dashboard.jobs.beam import load_bundled
    from dashboard.outputs.beam import judged_readouts

    m = load_bundled("lab_run_1")
    wrong = calibration_preview(m, window=(0.0, 1.05), effects=("air_damping", "kelvin_voigt"), modes=4)
    items = {i["key"]: i for i in judged_readouts(wrong)}
    assert float(items["coverage_pct"]["value"]) > 95.0
    assert items["coverage_pct"]["kind"] != "good" and "too wide" in items["coverage_pct"]["words"]
    assert items["noise_sd"]["kind"] == "bad" and "noise floor" in items["noise_sd"]["words"]
    assert items["rmse_prediction"]["kind"] == "bad"
    right = calibration_preview(m, window=(0.0, 1.05), effects=("air_damping", "kelvin_voigt", "patch_stiffening"),
                                modes=4)
    items = {i["key"]: i for i in judged_readouts(right)}
    assert items["noise_sd"]["kind"] == "good"  # the noise the model needs is the sensor's


def test_student_words():
    from dashboard.outputs.beam import (
        change_words,
        effect_title,
        evidence_words,
        fmt_um,
    )

    assert effect_title("tip_cubic_spring") == "Hardening tip spring"
    assert change_words(96.7, 100.0) == "3.3 % lower" and change_words(112.0, 100.0) == "12 % higher"
    assert evidence_words(5.0).startswith("+5.0 nats: odds about 150 : 1")  # e^5 = 148.4
    assert "10¹⁰⁰" in evidence_words(4106.5) and "against" in evidence_words(-3.0)
    assert fmt_um(1379.2) == "1\u2009379" and fmt_um(57.34) == "57.3" and fmt_um(4.213) == "4.21"
def test_changes_are_worded_with_the_sign_said_once():
    assert change_words(96.7, 100.0) == "3.3 % lower"
    assert change_words(1.1, 1.0) == "10.0 % higher"
    assert change_words(-1.1, -1.0) == "10.0 % lower"  # relative to |old|: a more negative value is lower
    assert change_words(1.0, 1.0) == "unchanged"
    assert change_words(1.0, 0.0) == "" and change_words(math.nan, 1.0) == ""


def test_verdict_judges_the_model_not_the_coverage_alone():
    from beam.toy import run_toy

    def verdict(**kw):
        return judge(run_toy(ToyScenario(seed=7, **kw), mcmc=False))

    kind, lines = verdict()  # the model is right
    assert kind == "success", lines
    assert "matches the true noise" in lines[0]
    # a harmonic distortion: noise sd ~2.3x the truth, coverage still high because the bands are wide
    kind, lines = verdict(discrepancy=0.3, kind="harmonic")
    text = " ".join(lines)
    assert kind != "success" and "absorbs a discrepancy as noise" in text
    assert "high only because the bands are wide" in text
    # the tone on a short window: noise absorbed, band too narrow, frequency biased
    kind, lines = verdict(discrepancy=0.3, kind="tone", window_s=3.0)
    assert kind == "danger" and "over-confident" in " ".join(lines)
    assert judge(None)[0] == "secondary"


def test_verdict_words_the_change_against_a_pinned_result():
    from beam.toy import run_toy

    old = run_toy(ToyScenario(seed=7), mcmc=False)
    new = run_toy(ToyScenario(seed=7, window_s=8.0), mcmc=False)
    _, lines = judge(new, old)
    expected = change_words(readouts(new)["rmse_du"], readouts(old)["rmse_du"])
    assert lines[-1].startswith("Against the pinned result: RMSE " + expected)
    assert "-" not in lines[-1] and "+" not in lines[-1]


def test_printable_summary_is_self_contained_and_carries_the_numbers(results):
    import re

    _, final = results
    text = exports.summary_html(final).getvalue().decode("utf-8")
    assert re.findall(r"(?i)(\b[a-z][a-z0-9+.-]*://|[\"'(]//|\bsrc\s*=|\bhref\s*=|@import|url\((?!#)|<script|<link)",
                      text) == []
    r = readouts(final)
    assert f"{r['rmse_du']:.3g} du" in text and f"{r['coverage_pct']:.0f} %" in text
    assert f"{r['frequency_sd_mHz']:.3g} mHz" in text
    assert text.count("<svg") == 1
    for line in judge(final)[1]:  # the verdict in words
        assert line.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;").replace(
            "'", "&#x27;") in text
    assert exports.summary_html(None) is None
