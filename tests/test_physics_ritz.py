"""Rayleigh–Ritz modes of a batch of nearby parameter sets (the walkers of a posterior) against
the dense eigen-solve, and the fall-back to the dense solve where the error bound fails."""

import numpy as np
import pytest

from beam.physics import modal
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

GEOMETRY = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)  # lab_run_1's strip
EFFECTS = ["air_damping", "kelvin_voigt", "patch_stiffening", "patch_damping"]
#: lab_run_1's posterior: patch density and stiffness ~0.43 kg/m and ~0.79 N m², 0.4 % spread (1-99 %)
CENTRE = {"bending_stiffness_Nm2": 0.491, "patch_coupling_NmV": 1.746e-2, "air_damping_Ns_m2": 0.013,
          "kelvin_voigt_Nm2s": 0.649e-5, "patch_added_density_kg_m": 0.433, "patch_added_stiffness_Nm2": 0.793,
          "patch_added_kelvin_voigt_Nm2s": 1.255e-5}
MODES = 7


def walkers(spread: float, count: int = 64, seed: int = 3) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {name: value * (1.0 + spread * rng.standard_normal(count)) for name, value in CENTRE.items()}


def dense_and_ritz(spread: float):
    """(dense, batched) models' reduced systems for the same walkers; the batched one may take Ritz modes."""
    values = walkers(spread)
    batched = BeamModel(GEOMETRY, EFFECTS)
    reduced, _, _ = batched.reduced_system(values, MODES)
    dense = BeamModel(GEOMETRY, EFFECTS)
    rows = [dense.reduced_system({k: float(v[b]) for k, v in values.items()}, MODES)[0] for b in range(64)]
    reference = {key: np.concatenate([r[key] for r in rows]) for key in reduced}
    return batched, reduced, reference


def test_ritz_modes_of_posterior_walkers_match_the_dense_solve():
    """Walkers spread like lab_run_1's posterior (0.2 % sd) take the Ritz path (one subspace) and
    agree with one-at-a-time dense solves: omega² and the sensor's and force's modal values to
    1e-8 (measured ~2e-10), the damping projections likewise, the discarded modes' static
    gain (0.1-0.4 % of the response) to 1e-6 of itself."""
    batched, ritz, dense = dense_and_ritz(0.002)
    assert len(batched._ritz_bases) == 1
    np.testing.assert_allclose(ritz["omega2"], dense["omega2"], rtol=1e-8)
    for key in ("sensor", "force", "tip"):
        np.testing.assert_allclose(ritz[key], dense[key], rtol=1e-8, atol=1e-8 * np.abs(dense[key]).max())
    np.testing.assert_allclose(ritz["damping"], dense["damping"], rtol=0, atol=1e-8 * np.abs(dense["damping"]).max())
    np.testing.assert_allclose(ritz["static"][:, 0], dense["static"][:, 0], rtol=1e-6)


def test_responses_of_walkers_match_dense_responses():
    values = walkers(0.002, count=16)
    u = np.sin(2 * np.pi * 40.0 * np.arange(2000) * 1e-3) * np.hanning(2000)
    batched = BeamModel(GEOMETRY, EFFECTS)
    fast = batched.response(values, u, 1e-3, MODES)
    assert batched._ritz_bases
    dense = BeamModel(GEOMETRY, EFFECTS)
    slow = np.stack([dense.response({k: float(v[b]) for k, v in values.items()}, u, 1e-3, MODES) for b in range(16)])
    assert np.max(np.abs(fast - slow)) <= 1e-9 * np.max(np.abs(slow))


def test_far_walkers_take_the_dense_solve():
    """Walkers 30 % apart are outside any subspace's trust radius: the dense solve, exactly."""
    batched, ritz, dense = dense_and_ritz(0.3)
    np.testing.assert_allclose(ritz["omega2"], dense["omega2"], rtol=1e-12)


def test_error_bound_rejects_a_poor_subspace():
    """A subspace built 20 % away (from only the modes wanted plus three) cannot hold the modes
    to 1e-7: the bound says so, and it is an upper bound on the true angle."""
    model = BeamModel(GEOMETRY, EFFECTS)
    parts = model.parts
    mass_terms = np.stack([parts.mass_beam, parts.mass_patch])
    stiffness_terms = np.stack([parts.stiffness_beam, parts.stiffness_patch])
    anchor = np.array([1.0, 0.433 / 0.093, 1.0, 0.793 / 0.491])
    far = anchor * np.array([1.0, 1.2, 1.0, 0.8])
    basis = modal.ritz_basis(mass_terms, stiffness_terms, anchor, np.zeros((0, 4)), MODES, extra=3)
    coefficients = np.stack([anchor, far])
    mass = np.einsum("bt,tij->bij", coefficients[:, :2], mass_terms)
    stiffness = np.einsum("bt,tij->bij", coefficients[:, 2:], stiffness_terms)
    omega2, shapes, angle = modal.ritz_modes(basis, coefficients, MODES)
    exact_omega2, exact = modal.undamped_modes(mass, stiffness)
    assert angle[0] < 1e-9 and angle[1] > 1e-7
    # the true angle, in the K-whitened coordinates the bound speaks of: the K-norm of the part
    # of the Ritz mode not along the exact one, relative to the Ritz mode's
    for b in range(2):
        k = stiffness[b]
        for i in range(MODES):
            x, y = shapes[b, :, i], exact[b, :, i]
            away = x - (x @ k @ y) / (y @ k @ y) * y
            assert np.sqrt((away @ k @ away) / (x @ k @ x)) <= angle[b] * (1 + 1e-6) + 1e-10  # + round-off of both
    assert omega2[1] == pytest.approx(exact_omega2[1, :MODES], rel=1e-2)


def stencil(step: float) -> dict[str, np.ndarray]:
    """A centre and forward steps in the three parameters that move the mode shapes' ratios."""
    names = ["bending_stiffness_Nm2", "patch_added_density_kg_m", "patch_added_stiffness_Nm2"]
    values = {k: np.full(4, v) for k, v in CENTRE.items()}
    for j, name in enumerate(names):
        values[name][j + 1] *= 1.0 + step
    return values


def one_at_a_time(values: dict[str, np.ndarray], count: int) -> dict[str, np.ndarray]:
    model = BeamModel(GEOMETRY, EFFECTS)
    rows = [model.reduced_system({k: float(v[b]) for k, v in values.items()}, MODES)[0] for b in range(count)]
    return {key: np.concatenate([r[key] for r in rows]) for key in rows[0]}


def test_stencil_rows_take_first_order_perturbation():
    """A finite-difference stencil (steps 1e-8, relative) in one batch: the centre is solved, the
    other rows by first-order perturbation. Every value agrees with its own dense solve to 1e-10 of
    the largest, and the difference quotient equals the derivative of the dense solve (a central
    difference, steps 1e-4: truncation ~1e-8) to 1e-6 of the largest (measured 1.6e-7; the dense
    solve's own forward difference, with round-off ~1e-12 of the values over steps of 1e-8,
    reaches 1e-4). The discarded modes' static gain (0.1-0.4 % of the response) is the small
    difference of o K⁻¹ f and the retained share, whose derivatives nearly cancel: its
    derivative is within 1.2e-3 of the dense one (measured; that of the dense forward
    difference: 1e-4 of an iteratively refined solve), < 5e-6 of the response's Jacobian."""
    h = 1e-8
    values = stencil(h)
    batched = BeamModel(GEOMETRY, EFFECTS)
    fast, _, _ = batched.reduced_system(values, MODES)
    dense = one_at_a_time(values, 4)
    for key in ("omega2", "sensor", "force", "damping", "static"):
        assert np.max(np.abs(fast[key] - dense[key])) <= 1e-10 * np.max(np.abs(dense[key])), key
    wide = 1e-4
    plus, minus = one_at_a_time(stencil(wide), 4), one_at_a_time(stencil(-wide), 4)
    for key, tolerance in (("omega2", 1e-6), ("sensor", 1e-6), ("force", 1e-6), ("static", 2e-3)):
        quotient = (fast[key][1:] - fast[key][:1]) / h
        derivative = (plus[key][1:] - minus[key][1:]) / (2 * wide)
        scale = np.max(np.abs(derivative), axis=tuple(range(1, derivative.ndim)), keepdims=True)
        assert np.max(np.abs(quotient - derivative) / scale) <= tolerance, key


def test_a_batch_never_mixes_ritz_and_dense_rows():
    """60 walkers close together and 4 far away: the whole batch takes the dense solve (Ritz and
    dense values differ by ~1e-9, enough to spoil a Hessian's difference quotients within a batch)."""
    values = walkers(0.002)
    for name in ("patch_added_density_kg_m", "patch_added_stiffness_Nm2"):
        values[name][:4] *= 1.3
    batched = BeamModel(GEOMETRY, EFFECTS)
    fast, _, _ = batched.reduced_system(values, MODES)
    dense = one_at_a_time(values, 64)
    np.testing.assert_allclose(fast["omega2"], dense["omega2"], rtol=1e-12)
    np.testing.assert_allclose(fast["sensor"], dense["sensor"], rtol=0, atol=1e-12 * np.abs(dense["sensor"]).max())
