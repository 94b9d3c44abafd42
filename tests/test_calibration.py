"""Beam calibration on simulated records with known truth."""

import json
import subprocess
import sys

import numpy as np
import pytest
from simulated_data import TRUE_BASE, simulated_measurement

from beam.calibration import calibrate, calibration_preview, make_setup
from beam.errors import BeamInputError
from beam.io.measurement import write_measurement
from beam.physics.excitation import Excitation

NOISE = 1e-5
BASE_NAMES = tuple(TRUE_BASE)


def test_default_window_is_the_first_30_percent_and_bad_windows_are_refused():
    record = simulated_measurement(TRUE_BASE, duration_s=2.0)
    setup = make_setup(record)
    assert setup.window == (0.0, pytest.approx(0.3 * record.time_s[-1]))
    assert setup.effects == ("air_damping", "kelvin_voigt") and setup.modes == 4
    with pytest.raises(BeamInputError, match="outside the record"):
        make_setup(record, window=(1.5, 2.5))
    with pytest.raises(BeamInputError, match="shorter than one period"):
        make_setup(record, window=(0.0, 0.1))


def test_a_window_from_zero_fits_a_record_whose_first_stamp_is_later_by_less_than_a_step():
    """A phone's first stamp is a fraction of a sample after 0: ``0:1`` is its first second; a
    window starting two steps before the record still lies outside it."""
    from dataclasses import replace

    record = simulated_measurement(TRUE_BASE, duration_s=2.0)
    step = float(np.median(np.diff(record.time_s)))
    late = replace(record, time_s=record.time_s + 0.6 * step)
    assert make_setup(late, window=(0.0, 1.0)).window == (0.0, 1.0)
    with pytest.raises(BeamInputError, match="outside the record"):
        make_setup(late, window=(-2 * step, 1.0))
    with pytest.raises(BeamInputError, match="unknown effect"):
        make_setup(record, effects="air_damping,tip_masss")
    with pytest.raises(BeamInputError, match="modes must be between 1 and 43"):  # 40 elements, patch knots
        make_setup(record, modes=50)


@pytest.mark.parametrize("stiffness_error", [0.9, 1.1, 1.3])
def test_spectral_start_finds_the_truth_with_nominal_stiffness_off(stiffness_error):
    """Nominal EI 10 % (and 30 %) off still converges on a 1 s window with three modes excited."""
    record = simulated_measurement(
        TRUE_BASE, nominal=dict(TRUE_BASE, bending_stiffness_Nm2=0.491 * stiffness_error), seed=3
    )
    result = calibration_preview(record, window=(0.0, 1.0), modes=4)
    stiffness = result.summary()["bending_stiffness_Nm2"]
    assert abs(stiffness["mean"] / 0.491 - 1) < 1e-4
    assert stiffness["q025"] <= 0.491 <= stiffness["q975"]


def test_preview_intervals_cover_the_truth_across_seeds():
    inside = 0
    for seed in range(4):
        result = calibration_preview(simulated_measurement(TRUE_BASE, seed=10 + seed), modes=4)
        summary = result.summary()
        inside += sum(summary[n]["q025"] <= TRUE_BASE[n] <= summary[n]["q975"] for n in BASE_NAMES)
        assert abs(result.rmse_prediction / NOISE - 1) < 0.1
    assert inside >= 14  # of 16: 95 % intervals


def test_mcmc_posterior_covers_the_truth_and_predicts_to_the_noise_floor():
    record = simulated_measurement(TRUE_BASE, seed=21)
    result = calibrate(record, seed=1, modes=4)
    summary = result.to_json()
    # one record: standardised errors (95 % interval coverage is tested across seeds above)
    for name in BASE_NAMES:
        posterior = summary["parameters"][name]
        assert abs(posterior["mean"] - TRUE_BASE[name]) < 3 * posterior["sd"], name
    assert abs(summary["noise_sd"]["mean"] - NOISE) < 3 * summary["noise_sd"]["sd"]
    assert abs(summary["rmse_prediction"] / NOISE - 1) < 0.1
    assert 0.90 <= summary["coverage95_prediction"] <= 0.98
    assert summary["converged"] and summary["ess_min"] >= 1000 and summary["rhat_max"] <= 1.01
    # EI and the Kelvin-Voigt coefficient trade off through the damping of the high modes; the
    # matrix is symmetric with a unit diagonal
    correlation = summary["correlation"]
    assert correlation["bending_stiffness_Nm2"]["bending_stiffness_Nm2"] == pytest.approx(1.0)
    assert correlation["air_damping_Ns_m2"]["kelvin_voigt_Nm2s"] == pytest.approx(correlation["kelvin_voigt_Nm2s"]["air_damping_Ns_m2"])


def test_a_missing_effect_inflates_the_prediction_error_and_the_stiffness_bias():
    record = simulated_measurement(dict(TRUE_BASE, tip_mass_kg=0.005), seed=4)
    without = calibration_preview(record, window=(0.0, 1.0), modes=4)
    with_it = calibration_preview(record, window=(0.0, 1.0), effects="air_damping,kelvin_voigt,tip_mass", modes=4)
    assert without.rmse_prediction > 100 * NOISE
    assert without.coverage95_prediction < 0.9
    stiffness = without.summary()["bending_stiffness_Nm2"]
    assert not stiffness["q025"] <= 0.491 <= stiffness["q975"]  # biased and over-confident
    assert abs(with_it.rmse_prediction / NOISE - 1) < 0.1
    tip = with_it.summary()["tip_mass_kg"]
    assert tip["q025"] <= 0.005 <= tip["q975"]


def test_two_calibration_windows_of_one_record_give_materially_different_predictions():
    """The paper's finding: with physics missing (a hardening spring), the early, large-amplitude
    window and the late, small-amplitude window give incompatible, over-confident stiffnesses."""
    pulse = Excitation("pulse", amplitude_V=40.0, width_s=0.08)
    record = simulated_measurement(dict(TRUE_BASE, tip_cubic_stiffness_N_m3=1e4), excitation=pulse, duration_s=4.0, seed=5)
    early = calibration_preview(record, window=(0.0, 1.0), modes=4)
    late = calibration_preview(record, window=(3.0, 4.0), modes=4)
    a, b = early.summary()["bending_stiffness_Nm2"], late.summary()["bending_stiffness_Nm2"]
    assert abs(a["mean"] - b["mean"]) > 20 * np.hypot(a["sd"], b["sd"])
    assert a["mean"] / b["mean"] > 1.2
    for s in (a, b):
        assert not s["q025"] <= 0.491 <= s["q975"]
    assert np.abs(early.bands.mean - late.bands.mean).max() > 0.2 * np.abs(record.displacement_m).max()
    repaired = calibration_preview(record, window=(0.0, 1.0), effects="air_damping,kelvin_voigt,tip_cubic_spring", modes=4)
    assert repaired.rmse_prediction < 2 * NOISE < early.rmse_prediction / 100


def test_ar1_likelihood_flags_correlated_residuals_but_does_not_repair_missing_physics():
    """Measured: AR(1) widens the posterior and the bands a little and its coefficient goes to ~1
    (the residuals are far from white), but the residual of a missing tip mass is an oscillation
    at the model's own frequencies, which AR(1) cannot describe: coverage is not restored."""
    record = simulated_measurement(dict(TRUE_BASE, tip_mass_kg=0.002), seed=6)
    iid = calibration_preview(record, window=(0.0, 1.0), modes=4)
    ar1 = calibration_preview(record, window=(0.0, 1.0), likelihood="ar1", modes=4)
    sd_iid = iid.summary()["bending_stiffness_Nm2"]["sd"]
    sd_ar1 = ar1.summary()["bending_stiffness_Nm2"]["sd"]
    assert sd_ar1 > 1.3 * sd_iid
    assert ar1.summary()["ar1_coefficient"]["mean"] > 0.9
    width = lambda r: np.mean(r.bands.prediction_upper - r.bands.prediction_lower)  # noqa: E731
    assert width(ar1) > 1.1 * width(iid)
    assert ar1.coverage95_prediction < 0.6 and iid.coverage95_prediction < 0.6
    repaired = calibration_preview(record, window=(0.0, 1.0), effects="air_damping,kelvin_voigt,tip_mass", modes=4)
    assert repaired.coverage95_prediction > 0.9


def test_cli_calibrate_json_and_saved_files(tmp_path):
    record = simulated_measurement(TRUE_BASE, duration_s=2.0, seed=7)
    write_measurement(tmp_path / "run", record)
    command = [sys.executable, "-m", "beam", "calibrate", str(tmp_path / "run.csv"), "--window", "0:0.8",
               "--steps", "200", "--seed", "3", "--json", "--save", str(tmp_path / "out" / "fit")]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    for key in ("parameters", "noise_sd", "rmse_calibration", "rmse_prediction", "coverage95_prediction",
                "ess_min", "rhat_max", "correlation", "seconds"):
        assert key in summary
    assert set(summary["parameters"]) == set(BASE_NAMES)
    assert set(summary["parameters"]["bending_stiffness_Nm2"]) == {"mean", "sd", "q025", "q975"}
    assert (tmp_path / "out" / "fit.nc").stat().st_size > 0
    band = np.genfromtxt(tmp_path / "out" / "fit.band.csv", delimiter=",", names=True)
    assert band.size == record.sample_count and np.all(band["prediction_lower_m"] <= band["prediction_upper_m"])


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--window", "9:10"], "outside the record"),
        (["--window", "0:0.05"], "shorter than one period"),
        (["--window", "0.5"], "START:END"),
        (["--effects", "magic"], "unknown effect"),
        (["--modes", "0"], "positive integer"),
        (["--likelihood", "gp"], "invalid choice"),
    ],
)
def test_cli_calibrate_bad_input_is_one_error_line(tmp_path, arguments, message):
    record = simulated_measurement(TRUE_BASE, duration_s=1.0, seed=8)
    write_measurement(tmp_path / "run", record)
    result = subprocess.run([sys.executable, "-m", "beam", "calibrate", str(tmp_path / "run.toml"), *arguments],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], result.stderr
