"""The MAP search's finite differences: a parameter the prediction is proportional to needs no model call."""

from __future__ import annotations

import numpy as np
import pytest

from beam.calibration import prepare
from beam.calibration.fit import _Objective
from beam.io.measurement import read_measurement
from beam.physics.effects import EFFECTS
from tests.simulated_data import TRUE_BASE, simulated_measurement

ROOT_EFFECTS = ("air_damping", "kelvin_voigt")
LINEAR_EFFECTS = [e for e in EFFECTS if not EFFECTS[e].nonlinear and e not in ROOT_EFFECTS]


@pytest.fixture(scope="module")
def lab_run_1():
    return read_measurement("assets/measurements/lab_run_1.csv")


def _random_points(problem, count: int, seed: int) -> dict[str, np.ndarray]:
    """Natural values drawn log-uniformly over the middle of each physical prior range."""
    rng = np.random.default_rng(seed)
    values = {}
    for p in problem.parameters:
        if p.name in problem.noise_names:
            continue
        lo, hi = np.log(p.prior.lower), np.log(p.prior.upper)
        values[p.name] = np.exp(lo + (0.25 + 0.5 * rng.random(count)) * (hi - lo))
    return values


@pytest.mark.parametrize("effect", LINEAR_EFFECTS)
def test_a_linear_driven_prediction_is_proportional_to_the_patch_coupling(lab_run_1, effect):
    """The premise of ``Problem.proportional_to``: with every other parameter held, the response of a
    linear model to the patch voltage scales exactly with k_p (every catalogue effect)."""
    setup, problem = prepare(lab_run_1, window=(0.0, 1.0), effects=ROOT_EFFECTS + (effect,), modes=5)
    assert problem.proportional_to == "patch_coupling_NmV"
    values = _random_points(problem, 6, seed=3)
    scaled = dict(values, patch_coupling_NmV=1.7 * values["patch_coupling_NmV"])
    base, response = problem.predict(values), problem.predict(scaled)
    peak = np.abs(base).max(axis=1, keepdims=True)
    assert np.all(np.abs(response - 1.7 * base) <= 1e-10 * 1.7 * peak)


def test_no_proportional_parameter_for_the_spring_or_a_free_response(lab_run_1):
    _, spring = prepare(lab_run_1, window=(0.0, 1.0), effects=ROOT_EFFECTS + ("tip_cubic_spring",), modes=4)
    assert spring.proportional_to is None  # the spring's response is not linear in k_p
    free = read_measurement("assets/real/adxl_50cm_114655.csv")
    _, problem = prepare(free, window=(0.0, 2.0), effects=("modal_damping",), modes=4)
    assert problem.proportional_to is None  # nothing drives a free response


@pytest.mark.parametrize("effects", [ROOT_EFFECTS, ROOT_EFFECTS + ("patch_stiffening", "tip_mass")])
def test_jacobian_with_the_proportional_shortcut_matches_full_finite_differences(effects):
    """The search's Jacobian (whitened residuals, internal coordinates) with the k_p column formed from
    the unperturbed prediction equals the one with a model call for that column too, and both match a
    central difference of the model (an independent, second-order estimate) to finite-difference accuracy."""
    measurement = simulated_measurement(dict(TRUE_BASE), seed=5)
    _, problem = prepare(measurement, window=(0.0, 1.0), effects=effects, modes=4)
    objective = _Objective(problem)
    assert objective.proportional >= 0
    values = _random_points(problem, 4, seed=11)
    values["noise_sd"] = np.full(4, 1e-5)
    z = problem.to_internal(values)
    x = z[:, objective.model_index]
    _, _, r_short, jac_short = objective.evaluate(x, z, profile=False)
    objective.proportional = -1
    _, _, r_full, jac_full = objective.evaluate(x, z, profile=False)
    np.testing.assert_allclose(r_short, r_full, rtol=0, atol=1e-12 * np.abs(r_full).max())
    c = list(objective.model_index).index(problem.index("patch_coupling_NmV"))
    for i in range(4):
        scale = np.linalg.norm(jac_full[i, :, c])
        assert np.linalg.norm(jac_short[i, :, c] - jac_full[i, :, c]) <= 1e-6 * scale
        # central difference of the whitened residual in k_p's internal coordinate
        h = 1e-4
        up, down = z[i:i + 1].copy(), z[i:i + 1].copy()
        up[0, problem.index("patch_coupling_NmV")] += h
        down[0, problem.index("patch_coupling_NmV")] -= h
        sd = values["noise_sd"][i]
        central = -(problem.predict(problem.from_internal(up)) - problem.predict(problem.from_internal(down)))[0] / (2 * h * sd)
        n = central.size
        assert np.linalg.norm(jac_short[i, :n, c] - central) <= 1e-5 * np.linalg.norm(central)


def test_the_last_drop_before_the_continuations_measures_against_the_best_start_reached():
    """Before the trust-region continuations a start that cannot catch up (far behind, expecting
    little) is dropped even when no start converged: the best start's log posterior is already
    reached. A start still climbing (the Gauss–Newton model expects a good share of the gap) goes on,
    and without ``reference`` the rule still waits for a converged start."""
    from beam.calibration.fit import _drop_worse_basins

    lp = np.array([10383.2, 5992.9, 7501.4, 10380.0])
    predicted = np.array([3.3, 6.8, 517.0, 2.0])  # nats the Gauss–Newton model expects to gain
    converged = np.zeros(4, dtype=bool)
    dropped = np.zeros(4, dtype=bool)
    _drop_worse_basins(lp, predicted, converged, dropped, settled=np.inf)
    assert not dropped.any()  # nothing converged: no reference
    _drop_worse_basins(lp, predicted, converged, dropped, settled=np.inf, reference=float(lp.max()))
    # 4,390 nats behind expecting 6.8: dropped; 2,882 behind expecting 517 (> a tenth of the gap):
    # kept; 3.2 behind: within the margin, kept; the best itself: kept
    assert dropped.tolist() == [False, True, False, False]
