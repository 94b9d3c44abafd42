"""Numerical guards: the model and the calibration give finite numbers or one BeamInputError.

Never a NaN returned silently: each case below gives finite numbers or one BeamInputError
(the model checks its output, the calibration refuses records without information, the
geometry refuses lengths and densities where the model is not finite).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from simulated_data import GEOMETRY, TRUE_BASE, simulated_measurement

from beam.calibration import calibration_preview, make_setup
from beam.calibration.records import decimate_measurement
from beam.errors import BeamInputError
from beam.io.limits import LENGTH_RANGE_M, LINEAR_DENSITY_RANGE_KG_M
from beam.io.measurement import Measurement
from beam.physics.effects import PARAMETER_SPECS
from beam.physics.excitation import Excitation
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

LINEAR_EFFECTS = ("air_damping", "kelvin_voigt", "tip_mass", "clamp_compliance", "patch_stiffening")
RATE = 1000.0
TIME = np.arange(1500) / RATE
CHIRP = Excitation("chirp", amplitude_V=10.0, start_Hz=2.0, stop_Hz=250.0, duration_s=1.0).voltage(TIME)
DAMPED = dict(TRUE_BASE)


def _corners(model: BeamModel) -> dict[str, np.ndarray]:
    """Every parameter at either end of its default prior range: 2^p parameter sets, batched."""
    names = model.parameter_names
    rows = np.array(list(itertools.product((0, 1), repeat=len(names))))
    return {name: np.where(rows[:, i] == 0, PARAMETER_SPECS[name].prior_low, PARAMETER_SPECS[name].prior_high)
            for i, name in enumerate(names)}


def _assert_finite(values: np.ndarray) -> None:
    values = np.asarray(values)
    assert np.all(np.isfinite(values)), f"{np.count_nonzero(~np.isfinite(values))} non-finite values"


# ---------------------------------------------------------------------------------------------
# the model at the edges of what calibration explores
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("modes", [4, None])
def test_response_is_finite_at_every_corner_of_the_priors(modes):
    model = BeamModel(GEOMETRY, LINEAR_EFFECTS)
    corners = _corners(model)
    _assert_finite(model.response(corners, CHIRP, 1 / RATE, modes=modes))


@pytest.mark.parametrize("length, density", list(itertools.product(LENGTH_RANGE_M, LINEAR_DENSITY_RANGE_KG_M)))
def test_the_geometry_range_keeps_the_model_finite(length, density):
    """The corners of LENGTH_RANGE_M x LINEAR_DENSITY_RANGE_KG_M, with every prior corner."""
    geometry = BeamGeometry(length, density, 0.2 * length, 0.4 * length, 0.6 * length)
    model = BeamModel(geometry, LINEAR_EFFECTS)
    corners = _corners(model)
    for modes in (4, None):
        _assert_finite(model.response(corners, CHIRP[:300], 1 / RATE, modes=modes))
    for index in (0, -1):
        _assert_finite(model.natural_modes({name: float(v[index]) for name, v in corners.items()}))


@pytest.mark.parametrize("modes", [1, 4, None])
def test_zero_damping_gives_a_finite_undamped_response(modes):
    """air = 0 and Kelvin-Voigt = 0: the undamped beam, finite and equal to the bare model."""
    damped_model = BeamModel(GEOMETRY, ("air_damping", "kelvin_voigt"))
    undamped = damped_model.response(dict(TRUE_BASE, air_damping_Ns_m2=0.0, kelvin_voigt_Nm2s=0.0), CHIRP, 1 / RATE,
                                     modes=modes)
    bare = BeamModel(GEOMETRY).response({k: TRUE_BASE[k] for k in ("bending_stiffness_Nm2", "patch_coupling_NmV")},
                                        CHIRP, 1 / RATE, modes=modes)
    _assert_finite(undamped)
    np.testing.assert_allclose(undamped, bare, rtol=1e-9, atol=1e-12 * np.max(np.abs(bare)))
    tiny = damped_model.response(dict(TRUE_BASE, air_damping_Ns_m2=1e-300, kelvin_voigt_Nm2s=5e-324), CHIRP,
                                 1 / RATE, modes=modes)
    np.testing.assert_allclose(tiny, bare, rtol=1e-9, atol=1e-12 * np.max(np.abs(bare)))


@pytest.mark.parametrize("amplitude_V", [10.0, 100.0, 1e3, 1e4])
@pytest.mark.parametrize("damping", [TRUE_BASE, dict(TRUE_BASE, air_damping_Ns_m2=0.0, kelvin_voigt_Nm2s=0.0)],
                         ids=["damped", "undamped"])
def test_a_stiff_cubic_spring_at_large_amplitude_stays_finite(amplitude_V, damping):
    """k3 = 1e7 N/m3 (the top of its prior) driven up to the 1e4 V the calibration accepts."""
    model = BeamModel(GEOMETRY, ("air_damping", "kelvin_voigt", "tip_cubic_spring"))
    voltage = np.where(TIME[:400] < 0.02, amplitude_V, 0.0)
    response = model.response(dict(damping, tip_cubic_stiffness_N_m3=1e7), voltage, 1 / RATE)
    _assert_finite(response)
    assert np.max(np.abs(response)) < GEOMETRY.length_m * 10  # hardening bounds the motion


def test_constant_and_zero_voltage_give_finite_responses():
    """A held 5 V step oscillates about the static deflection c K^-1 f V; zero volts give exactly 0."""
    model = BeamModel(GEOMETRY, ("air_damping", "kelvin_voigt"))
    matrices = model.system_matrices(TRUE_BASE)
    static = model.parts.sensor_values @ np.linalg.solve(matrices["stiffness"][0], matrices["force"][0]) * 5.0
    for modes in (4, None):
        step = model.response(TRUE_BASE, np.full(20_000, 5.0), 1 / RATE, modes=modes)
        _assert_finite(step)
        assert step[10_000:].mean() == pytest.approx(static, rel=0.02)
    assert np.all(model.response(TRUE_BASE, np.zeros(500), 1 / RATE) == 0.0)


@pytest.mark.parametrize("modes", [0, 44, 1000, -1, 2.5, True])
def test_more_modes_than_the_mesh_holds_is_one_clear_error(modes):
    model = BeamModel(GEOMETRY)
    with pytest.raises(BeamInputError, match=r"modes must be between 1 and 43"):
        model.response({"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 0.0175}, CHIRP, 1 / RATE, modes=modes)


def test_more_modes_than_the_mesh_holds_in_calibration():
    measurement = simulated_measurement(TRUE_BASE, duration_s=1.5, rate_Hz=400.0)
    with pytest.raises(BeamInputError, match=r"modes must be between 1 and 43 \(the mesh holds 43 modes\), got 44"):
        make_setup(measurement, modes=44)
    with pytest.raises(BeamInputError, match="modes must be between 1 and 43"):
        calibration_preview(measurement, modes=50)


# ---------------------------------------------------------------------------------------------
# the model returning NaN/inf silently (lead's beam/physics/model.py): the fix is one finiteness check
# ---------------------------------------------------------------------------------------------

_MODEL_FIX = ("BeamModel.response returns non-finite values silently; fix in beam/physics/model.py: after computing `out`, "
              "`if not np.isfinite(out).all(): raise BeamInputError('the response overflows ...')` (and in "
              "natural_modes/reduced_system for a LinAlgError or OverflowError of the eigensolver)")


def _response_or_error(model: BeamModel, parameters, voltage) -> None:
    """Finite output or a BeamInputError: anything else (NaN, another exception) fails."""
    try:
        out = model.response(parameters, voltage, 1 / RATE)
    except BeamInputError:
        return
    _assert_finite(out)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("case", ["air damping 1e300", "Kelvin-Voigt 1e300", "voltage 1e308", "k3 1e12 at 1 kV"])
def test_model_never_returns_nan_silently(case):
    effects = ("air_damping", "kelvin_voigt") + (("tip_cubic_spring",) if "k3" in case else ())
    model = BeamModel(GEOMETRY, effects)
    parameters, voltage = dict(TRUE_BASE), CHIRP[:400]
    if case == "air damping 1e300":
        parameters["air_damping_Ns_m2"] = 1e300
    elif case == "Kelvin-Voigt 1e300":
        parameters["kelvin_voigt_Nm2s"] = 1e300
    elif case == "voltage 1e308":
        voltage = np.full(400, 1e308)
    else:
        parameters["tip_cubic_stiffness_N_m3"] = 1e12
        voltage = CHIRP[:1500] * 100
    _response_or_error(model, parameters, voltage)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("length", [1e-6, 1e-300, 1e300])
def test_model_outside_the_geometry_range_gives_an_error_not_nan(length):
    """Lengths outside LENGTH_RANGE_M, where the model is not finite, are refused at once, in code
    as in a sidecar: a BeamInputError naming the range, never a NaN later."""
    with pytest.raises(BeamInputError, match=r"length_m must lie in \[0.01, 100\] m"):
        BeamGeometry(length, 1.0, 0.0, length / 2, length)


# ---------------------------------------------------------------------------------------------
# calibration on degenerate records (lead's beam/calibration/setup.py)
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def short_record() -> Measurement:
    return simulated_measurement(TRUE_BASE, duration_s=1.5, rate_Hz=400.0)


def _with(record: Measurement, voltage=None, displacement=None) -> Measurement:
    return Measurement(record.name, record.title, record.geometry, record.time_s,
                       record.voltage_V if voltage is None else voltage,
                       record.displacement_m if displacement is None else displacement, nominal=record.nominal)


def _preview_or_error(record: Measurement) -> None:
    """calibration_preview gives finite summaries and bands, or a BeamInputError; nothing else."""
    try:
        result = calibration_preview(record)
    except BeamInputError:
        return
    for name, summary in result.summary().items():
        assert np.isfinite(summary["mean"]) and np.isfinite(summary["sd"]), name
    _assert_finite(result.bands.mean)
    _assert_finite(result.bands.prediction_upper)
    assert np.isfinite(result.laplace.log_evidence)


def test_constant_voltage_calibrates_to_finite_numbers(short_record):
    _preview_or_error(_with(short_record, voltage=np.full(short_record.sample_count, 5.0)))


_CALIBRATION_FIX = ("fix in beam/calibration/setup.py make_setup: call "
                    "beam.calibration.records.check_calibration_record(measurement, window) after resolve_window")


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("case", ["zero displacement", "displacement 1e-300", "displacement 1e300", "voltage 1e300"])
def test_degenerate_records_do_not_escape_as_other_exceptions(short_record, case):
    """Today: RuntimeError (Laplace outside the prior) or ValueError (log-uniform prior bounds inf)."""
    d, v = short_record.displacement_m, short_record.voltage_V
    record = {
        "zero displacement": lambda: _with(short_record, displacement=np.zeros_like(d)),
        "displacement 1e-300": lambda: _with(short_record, displacement=d * 1e-300),
        "displacement 1e300": lambda: _with(short_record, displacement=d * 1e300),
        "voltage 1e300": lambda: _with(short_record, voltage=v * 1e300),
    }[case]()
    _preview_or_error(record)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("case", ["zero voltage", "zero voltage and displacement", "constant displacement"])
def test_records_without_information_are_refused(short_record, case):
    """Today these 'calibrate' to finite nonsense (RMSE 0, or EI on a prior bound) instead of an error."""
    n = short_record.sample_count
    voltage = np.zeros(n) if "zero voltage" in case else None
    displacement = {"zero voltage": None, "zero voltage and displacement": np.zeros(n),
                    "constant displacement": np.full(n, 1e-3)}[case]
    try:
        calibration_preview(_with(short_record, voltage=voltage, displacement=displacement))
    except BeamInputError:
        return
    raise AssertionError(f"{case}: calibrated a record that holds no information")


def test_a_decimated_long_record_calibrates_to_the_truth():
    """20,000 samples at 10 kHz decimated to 5,000 (factor 4): the preview recovers EI and k_p."""
    record = simulated_measurement(TRUE_BASE, rate_Hz=10_000.0, duration_s=2.0, noise_m=1e-5)
    small, factor = decimate_measurement(record, 5_000)
    assert factor == 4 and small.sample_count == 5_000
    result = calibration_preview(small)
    summary = result.summary()
    for name in ("bending_stiffness_Nm2", "patch_coupling_NmV"):
        assert summary[name]["mean"] == pytest.approx(TRUE_BASE[name], rel=2e-3), name
    _assert_finite(result.bands.mean)
