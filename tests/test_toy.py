"""Toy periodic model: scenario validation, simulation, spectral start, run and sweep outputs."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from beam.errors import BeamInputError
from beam.inference import preview
from beam.toy import (
    TONE_RATIO,
    ToyScenario,
    discrepancy_shape,
    phase_branch_centre,
    run_toy,
    simulate,
    spectral_initial_guesses,
    sweep_windows,
    toy_problem,
    wrap_phase,
)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"window_s": -1.0}, "must be positive"),
        ({"window_s": 0.0}, "must be positive"),
        ({"window_s": 20.0}, "shorter than the horizon"),
        ({"window_s": 25.0, "horizon_s": 20.0}, "shorter than the horizon"),
        ({"window_s": 0.5}, "shorter than one period"),
        ({"kind": "wobble"}, "unknown discrepancy kind"),
        ({"likelihood": "student"}, "unknown likelihood"),
        ({"noise_sd": -0.1}, "must not be negative"),
        ({"noise_sd": 0.0}, "prior range"),
        ({"discrepancy": float("nan")}, "finite"),
        ({"seed": -1}, "non-negative integer"),
        ({"horizon_s": 1e6}, "more than"),
    ],
)
def test_invalid_scenarios_raise_one_line_beam_input_errors(kwargs, message):
    with pytest.raises(BeamInputError, match=message) as info:
        ToyScenario(**kwargs).validate()
    assert "\n" not in str(info.value)


def test_simulation_defaults_and_discrepancy_shapes():
    sc = ToyScenario()
    data = simulate(sc)
    assert data.time_s[0] == 0.0 and data.time_s[-1] == pytest.approx(20.0)
    assert data.time_s.size == 401
    assert np.diff(data.time_s) == pytest.approx(np.full(400, 0.05))
    assert data.calibration.sum() == 101 and data.time_s[data.calibration][-1] == pytest.approx(5.0)
    np.testing.assert_allclose(data.truth, np.sin(2 * math.pi * data.time_s + 0.3))
    resid = data.data - data.truth
    assert resid.std() == pytest.approx(0.1, rel=0.15)
    np.testing.assert_array_equal(simulate(sc).data, data.data)  # deterministic for a seed
    assert not np.array_equal(simulate(ToyScenario(seed=1)).data, data.data)

    t = np.array([0.0, 2.5, 5.0, 10.0])
    np.testing.assert_allclose(discrepancy_shape("drift", t, sc), [0.0, 0.5, 1.0, 2.0])  # t / 5 s
    # the drift is in absolute time: moving the window changes the mask, never the truth
    np.testing.assert_allclose(discrepancy_shape("drift", t, ToyScenario(window_s=12.0)), [0.0, 0.5, 1.0, 2.0])
    np.testing.assert_array_equal(simulate(ToyScenario(kind="drift", discrepancy=0.3, window_s=3.0)).truth,
                                  simulate(ToyScenario(kind="drift", discrepancy=0.3, window_s=12.0)).truth)
    np.testing.assert_allclose(discrepancy_shape("harmonic", t, sc), np.sin(4 * math.pi * t + 0.3))
    np.testing.assert_allclose(discrepancy_shape("tone", t, sc), np.sin(2 * math.pi * TONE_RATIO * t))
    d = simulate(ToyScenario(discrepancy=0.4, kind="drift"))
    np.testing.assert_allclose(d.truth - d.signal, 0.4 * d.time_s / 5.0)


@pytest.mark.parametrize("window", [1.0, 2.0, 5.0, 15.0])
def test_spectral_start_is_near_the_truth(window):
    sc = ToyScenario(window_s=window, seed=2)
    data = simulate(sc)
    cal = data.calibration
    best = spectral_initial_guesses(data.time_s[cal], data.data[cal])[0]
    assert best["frequency_Hz"] == pytest.approx(1.0, abs=0.1 / window)  # within a tenth of a Fourier bin
    assert best["amplitude"] == pytest.approx(1.0, abs=0.15)
    assert abs(wrap_phase(best["phase_rad"] - 0.3)) < 0.3


def test_phase_branch_moves_away_from_the_cut():
    sc = ToyScenario(phase_rad=3.1)  # near +π: the posterior would straddle (-π, π]
    data = simulate(sc)
    cal = data.calibration
    centre = phase_branch_centre(data.time_s[cal], data.data[cal])
    assert centre == pytest.approx(math.pi)
    result = run_toy(sc, mcmc=False)
    s = result.summary["phase_rad"]
    assert 0.0 < s["q025"] < s["q975"] < 2 * math.pi  # far from the cut at 0 ≡ 2π
    assert abs(s["mean"] - 3.1) < 4 * s["sd"]
    assert result.truth["phase_rad"] == pytest.approx(3.1)
    problem = toy_problem(data.time_s[cal], data.data[cal], phase_centre_rad=0.0)
    assert problem.parameter("phase_rad").prior.lower == pytest.approx(-math.pi)


def test_phase_branch_is_a_representation_only():
    """Away from both cuts, the fits on the branches centred at 0 and at π agree (phase modulo 2π)."""
    data = simulate(ToyScenario(phase_rad=1.2, seed=3))
    cal = data.calibration
    fits = [preview(toy_problem(data.time_s[cal], data.data[cal], phase_centre_rad=c)) for c in (0.0, math.pi)]
    (a, b) = (f.map.values for f in fits)
    assert abs(wrap_phase(a["phase_rad"] - b["phase_rad"])) < 1e-6
    assert a["phase_rad"] == pytest.approx(b["phase_rad"] - 2 * math.pi if b["phase_rad"] > math.pi else b["phase_rad"], abs=1e-6)
    for name in ("amplitude", "frequency_Hz", "noise_sd"):
        assert a[name] == pytest.approx(b[name], rel=1e-6), name
    assert fits[0].log_evidence == pytest.approx(fits[1].log_evidence, abs=1e-6)


def test_fixed_parameters_make_a_smaller_problem():
    data = simulate(ToyScenario())
    cal = data.calibration
    problem = toy_problem(data.time_s[cal], data.data[cal], fixed={"frequency_Hz": 1.0, "phase_rad": 0.3})
    assert problem.names == ("amplitude", "noise_sd")
    assert problem.initial_guesses(problem) == [{}]


def test_run_toy_result_carries_plot_data_and_json():
    result = run_toy(ToyScenario(target_ess=400))
    n = result.data.time_s.size
    for arr in (result.data.data, result.data.truth, result.bands.mean, result.bands.prediction_lower, result.bands.credible_upper):
        assert arr.shape == (n,)
    assert set(result.draws) == {"amplitude", "frequency_Hz", "phase_rad", "noise_sd"}
    assert all(v.shape == (500,) for v in result.draws.values())
    report = result.to_json()
    json.dumps(report)  # plain Python types only
    for key in ("posterior", "truth", "rmse_prediction", "coverage95_prediction", "ess_min", "seconds", "converged", "rhat_max"):
        assert key in report
    assert report["truth"] == {"amplitude": 1.0, "frequency_Hz": 1.0, "phase_rad": 0.3, "noise_sd": 0.1}
    assert report["ess_min"] >= 400 and report["converged"]
    # the reported coverage is the share of held-out data inside the reported prediction band
    held = result.data.held_out
    inside = (result.data.data >= result.bands.prediction_lower) & (result.data.data <= result.bands.prediction_upper)
    assert report["coverage95_prediction"] == pytest.approx(np.count_nonzero(inside & held) / np.count_nonzero(held))


def test_ar1_run_reports_the_coefficient():
    result = run_toy(ToyScenario(likelihood="ar1", target_ess=300), mcmc=False)
    assert result.truth["ar1_coefficient"] == 0.0
    # white noise (no discrepancy): the coefficient's interval holds its true value 0 and is tight
    s = result.summary["ar1_coefficient"]
    assert s["q025"] < 0.0 < s["q975"]
    assert abs(s["mean"]) < 0.15 and s["sd"] < 0.1


def test_sweep_is_deterministic_and_has_the_documented_rows():
    sc = ToyScenario(kind="drift", discrepancy=0.5)
    rows = sweep_windows(sc, [2.0, 5.0, 10.0])
    again = sweep_windows(sc, [2.0, 5.0, 10.0])
    assert rows == again
    assert [r["window_s"] for r in rows] == [2.0, 5.0, 10.0]
    for r in rows:
        assert {"window_s", "rmse_prediction", "coverage95_prediction"} <= set(r)
    with pytest.raises(BeamInputError, match="sweep window 25"):
        sweep_windows(sc, [25.0])
