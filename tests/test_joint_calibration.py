"""Joint calibration of several records of one beam (beam.calibration.joint): one record jointly is
the single calibration; the joint log posterior is the sum of the records'; per-record parameters;
each record's results from the joint posterior against the record itself."""

from __future__ import annotations

import numpy as np
import pytest

from beam.calibration import calibration_preview
from beam.calibration.joint import JointProblem, joint_calibrate, joint_name, joint_preview, resolve_per_record
from beam.errors import BeamInputError
from beam.io.measurement import Measurement
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel


def free_strip(length_m: float, truth: dict, effects: tuple[str, ...], *, seed: int, sd: float = 0.05,
               rate_Hz: float = 250.0, duration_s: float = 3.0, amplitude: float = 6.4e-4,
               second: float = 0.0, name: str | None = None) -> Measurement:
    """An accelerometer's free decay of a 0.27 kg/m strip clamped at ``length_m``, the sensor 6 cm
    from the tip, offset 0.43 m/s², Gaussian noise ``sd`` (m/s²); ``second``: mode 2's share of
    the initial modal displacement (0: only mode 1 is in the record). The calibration's mesh."""
    geometry = BeamGeometry(length_m=length_m, linear_density_kg_m=0.27, patch_start_m=None, patch_end_m=None,
                            sensor_position_m=length_m - 0.06)
    model = BeamModel(geometry, effects, input_kind=None)
    t = np.arange(int(rate_Hz * duration_s)) / rate_Hz
    clean = model.free_response(truth, t, [amplitude, second * amplitude], [0.0, 0.0], modes=2, output="acceleration")
    y = clean + 0.43 + sd * np.random.default_rng(seed).standard_normal(t.size)
    return Measurement(name or f"strip_{round(100 * length_m)}cm", "simulated strip", geometry, t,
                       acceleration_m_s2=y, nominal={"bending_stiffness_Nm2": 2.333})


TWO_MODES = {"bending_stiffness_Nm2": 2.14, "sensor_mass_kg": 0.004, "damping_ratio_mode_1": 0.005,
             "damping_ratio_mode_2": 0.006}


def test_one_record_jointly_is_the_single_calibration():
    """Same log posterior at every point, same MAP (to the optimiser's precision), same evidence."""
    record = free_strip(0.5, TWO_MODES, ("sensor_mass", "modal_damping"), seed=3, second=0.3, rate_Hz=400.0)
    options = dict(window=(0.0, 2.0), effects="sensor_mass,modal_damping", modes=2)
    single = calibration_preview(record, **options)
    joint = joint_preview([record], **options)
    problem = joint.problem
    assert set(problem.names) == set(single.problem.names) - {"noise_sd"} | {"noise_sd@0"}
    # the log posterior of the joint problem is the single one's, everywhere
    draws = single.laplace.draws(64, seed=1)
    z_single = single.problem.to_internal(draws)
    z_joint = problem.to_internal({problem.record_names(0)[n]: v for n, v in draws.items()})
    np.testing.assert_allclose(problem.log_posterior(z_joint), single.problem.log_posterior(z_single), rtol=1e-12)
    # the same optimum
    assert joint.laplace.map.log_posterior == pytest.approx(single.laplace.map.log_posterior, abs=1e-3)
    for name in single.setup.physical_names:
        assert joint.laplace.map.values[name] == pytest.approx(single.laplace.map.values[name], rel=1e-3)
    assert joint.laplace.log_evidence == pytest.approx(single.laplace.log_evidence, abs=0.1)
    # the record's view of the joint posterior is the single calibration's
    view = joint.record_results()[0]
    assert view.rmse_calibration == pytest.approx(single.rmse_calibration, rel=1e-3)
    assert view.rmse_prediction == pytest.approx(single.rmse_prediction, rel=1e-3)


def test_joint_log_posterior_is_the_sum_of_the_records():
    """At any point: joint log posterior = one prior + each record's log likelihood (each record's
    log posterior minus its own prior)."""
    effects = ("sensor_mass", "modal_damping")
    records = [free_strip(length, TWO_MODES, effects, seed=k, second=0.3, rate_Hz=400.0)
               for k, length in enumerate((0.4, 0.5))]
    singles = [calibration_preview(r, window=(0.0, 2.0), effects=effects, modes=2) for r in records]
    problem = JointProblem([s.problem for s in singles], per_record=("damping_ratio_mode_1",))
    assert "damping_ratio_mode_1@1" in problem.names and "damping_ratio_mode_1" not in problem.names
    values = {"bending_stiffness_Nm2": 2.2, "sensor_mass_kg": 0.003, "damping_ratio_mode_2": 0.007,
              "damping_ratio_mode_1@0": 0.004, "damping_ratio_mode_1@1": 0.006, "noise_sd@0": 0.06, "noise_sd@1": 0.04}
    z = problem.to_internal(values)
    expected = problem.log_prior(z)[0]
    for k, single in enumerate(singles):
        own = {name: values[joint] for name, joint in problem.record_names(k).items()}
        zk = single.problem.to_internal(own)
        expected += single.problem.log_posterior(zk)[0] - single.problem.log_prior(zk)[0]
    assert problem.log_posterior(z)[0] == pytest.approx(expected, rel=1e-12)


def test_per_record_names():
    physical = ("bending_stiffness_Nm2", "clamp_stiffness_Nm_rad", "sensor_mass_kg", "damping_ratio_mode_1")
    assert resolve_per_record("clamp_stiffness", physical) == ("clamp_stiffness_Nm_rad",)
    assert resolve_per_record(["clamp_compliance"], physical) == ("clamp_stiffness_Nm_rad",)
    assert resolve_per_record(None, physical, shared="bending_stiffness,sensor_mass") == (
        "clamp_stiffness_Nm_rad", "damping_ratio_mode_1")
    assert resolve_per_record("modal_damping", physical) == ("damping_ratio_mode_1",)
    with pytest.raises(BeamInputError, match="not a parameter"):
        resolve_per_record("tip_mass", physical)
    with pytest.raises(BeamInputError, match="both shared and per record"):
        resolve_per_record("sensor_mass", physical, shared="sensor_mass")
    assert joint_name("noise_sd", 2) == "noise_sd@2"


def test_reclamped_records_get_their_own_clamp_stiffness():
    """Two records of one strip re-clamped between them (clamp stiffness 150 and 600 N m/rad): with
    the clamp per record each record's stiffness is recovered, EI shared; each record's frequency
    from the joint MAP matches the record's own spectral peak."""
    effects = ("clamp_compliance", "modal_damping")
    truths = [dict(bending_stiffness_Nm2=2.14, clamp_stiffness_Nm_rad=k, damping_ratio_mode_1=0.005,
                   damping_ratio_mode_2=0.006) for k in (150.0, 600.0)]
    records = [free_strip(length, truth, effects, seed=10 + k, second=0.3, rate_Hz=400.0)
               for k, (length, truth) in enumerate(zip((0.4, 0.5), truths))]
    joint = joint_preview(records, window=(0.0, 2.0), effects="clamp_compliance,modal_damping", modes=2,
                          per_record="clamp_stiffness")
    summary = joint.summary()
    for k, truth in enumerate(truths):
        interval = summary[f"clamp_stiffness_Nm_rad@{k}"]
        assert interval["q025"] < truth["clamp_stiffness_Nm_rad"] < interval["q975"]
    assert summary["bending_stiffness_Nm2"]["q025"] < 2.14 < summary["bending_stiffness_Nm2"]["q975"]
    for k, record in enumerate(records):
        entry = joint.record_json(k)
        assert set(entry["parameters"]) == {"clamp_stiffness_Nm_rad"}
        assert entry["rmse_calibration"] == pytest.approx(0.05, rel=0.15)  # the noise
        assert entry["coverage95_prediction"] > 0.85
        # f1 of the joint MAP against the record's spectral peak (zero-padded FFT of its window)
        inside = record.time_s <= 2.0
        y = record.output[inside] - record.output[inside].mean()
        n_fft = 2**20
        f = np.fft.rfftfreq(n_fft, 1 / 400.0)
        spectrum = np.abs(np.fft.rfft(y * np.hanning(y.size), n_fft))
        band = (f > 0.7 * entry["frequencies_Hz"][0]) & (f < 1.3 * entry["frequencies_Hz"][0])
        peak = f[band][np.argmax(spectrum[band])]
        assert entry["frequencies_Hz"][0] == pytest.approx(peak, rel=2e-3)


def test_joint_sampling_runs_emcee_on_the_joint_posterior():
    """A few emcee steps: the posterior's draws are the joint ones, each record's bands from them."""
    effects = ("sensor_mass", "modal_damping")
    records = [free_strip(length, TWO_MODES, effects, seed=20 + k, second=0.3, rate_Hz=300.0, duration_s=2.5)
               for k, length in enumerate((0.4, 0.5))]
    result = joint_calibrate(records, window=(0.0, 1.5), effects="sensor_mass,modal_damping", modes=2, steps=30)
    assert result.posterior is not None and result.posterior.problem is result.problem
    draws = result.draws()
    assert set(draws) == set(result.problem.names)
    out = result.to_json()
    assert [r["record"] for r in out["records"]] == ["strip_40cm", "strip_50cm"]
    assert set(out["parameters"]) == {"bending_stiffness_Nm2", "sensor_mass_kg", "damping_ratio_mode_1",
                                      "damping_ratio_mode_2"}
    for entry in out["records"]:
        assert len(entry["frequencies_Hz"]) == 2 and entry["noise_sd"]["mean"] == pytest.approx(0.05, rel=0.2)
