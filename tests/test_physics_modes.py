"""Natural frequencies and damping of the Galerkin model against analytic references."""

import numpy as np
import pytest
from reference_beams import (
    CANTILEVER_BETA_L,
    PINNED_FREE_BETA_L,
    clamp_spring_beta_l,
    stepped_beam_frequencies_Hz,
    tip_mass_beta_l,
)

from beam.physics.basis import ModifiedCubicBasis, cardinal_cubic_bspline, gauss_points
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

LENGTH, DENSITY, STIFFNESS = 0.5, 0.1, 0.5
GEOMETRY = BeamGeometry(LENGTH, DENSITY, 0.1, 0.2, 0.3)
BASE = {"bending_stiffness_Nm2": STIFFNESS, "patch_coupling_NmV": 0.01}


def beta_l(frequencies_Hz: np.ndarray) -> np.ndarray:
    """beta L = (omega² rho L⁴ / EI)^(1/4) of a uniform beam."""
    omega = 2 * np.pi * np.asarray(frequencies_Hz)
    return (omega**2 * DENSITY * LENGTH**4 / STIFFNESS) ** 0.25


def test_cardinal_spline_partition_of_unity_and_derivatives():
    x = np.linspace(-0.5, 0.5, 101)
    total = sum(cardinal_cubic_bspline(x - j) for j in range(-3, 4))
    np.testing.assert_allclose(total, 1.0, atol=1e-14)
    h = 1e-6  # derivatives against central differences
    for derivative in (1, 2):
        numeric = (cardinal_cubic_bspline(x + h, derivative - 1) - cardinal_cubic_bspline(x - h, derivative - 1)) / (2 * h)
        # O(h) difference error where the next derivative jumps (s = 0, ±1): 1.5 h at most
        np.testing.assert_allclose(cardinal_cubic_bspline(x, derivative), numeric, atol=2e-6)


@pytest.mark.parametrize("free_root", [False, True])
def test_modified_basis_boundary_conditions(free_root):
    basis = ModifiedCubicBasis(LENGTH, 16, free_root)
    assert basis.size == (18 if free_root else 17)
    np.testing.assert_allclose(basis.evaluate([0.0], 0), 0.0, atol=1e-15)
    slopes = basis.evaluate([0.0], 1)[0]
    if free_root:
        assert np.abs(slopes).max() > 1.0  # the root rotation stays free
    else:
        np.testing.assert_allclose(slopes, 0.0, atol=1e-12)


def test_gauss_points_integrate_degree_seven_exactly():
    x, w = gauss_points(np.array([0.0, 0.13, 0.5]))
    np.testing.assert_allclose(np.sum(w * x**7), 0.5**8 / 8, rtol=1e-13)


def test_uniform_cantilever_matches_beta_l_to_1e_4_at_16_intervals():
    frequencies, _ = BeamModel(GEOMETRY, intervals=16).natural_modes(BASE, 4)
    relative = np.abs(beta_l(frequencies) / CANTILEVER_BETA_L - 1)
    assert relative.max() <= 1e-4, relative
    # frequency error is twice the beta L error; mode 4 is the worst (~1.7e-4)
    assert np.abs(frequencies / (CANTILEVER_BETA_L**2 / (2 * np.pi * LENGTH**2) * np.sqrt(STIFFNESS / DENSITY)) - 1).max() < 2e-4


def test_frequency_error_falls_at_fourth_order_as_the_mesh_doubles():
    reference = CANTILEVER_BETA_L[1:3]  # modes 2-3: well above the 7-digit precision of the table
    errors = []
    for intervals in (4, 8, 16):
        frequencies, _ = BeamModel(GEOMETRY, intervals=intervals).natural_modes(BASE, 3)
        errors.append(np.abs(beta_l(frequencies[1:3]) / reference - 1))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 3.5) & (orders < 4.6)), orders


@pytest.mark.parametrize("mass_ratio", [0.2, 1.0, 3.0])
def test_tip_mass_frequencies_match_characteristic_equation(mass_ratio):
    parameters = dict(BASE, tip_mass_kg=mass_ratio * DENSITY * LENGTH)
    frequencies, _ = BeamModel(GEOMETRY, ["tip_mass"], 32).natural_modes(parameters, 4)
    np.testing.assert_allclose(beta_l(frequencies), tip_mass_beta_l(mass_ratio), rtol=1e-5)


@pytest.mark.parametrize("kappa", [0.5, 5.0, 50.0])
def test_clamp_spring_matches_restrained_root_equation(kappa):
    parameters = dict(BASE, clamp_stiffness_Nm_rad=kappa * STIFFNESS / LENGTH)
    frequencies, _ = BeamModel(GEOMETRY, ["clamp_compliance"], 16).natural_modes(parameters, 4)
    np.testing.assert_allclose(beta_l(frequencies), clamp_spring_beta_l(kappa), rtol=1e-4)


def test_stiff_clamp_spring_recovers_the_rigid_clamp():
    parameters = dict(BASE, clamp_stiffness_Nm_rad=1e9)
    frequencies, _ = BeamModel(GEOMETRY, ["clamp_compliance"], 16).natural_modes(parameters, 4)
    np.testing.assert_allclose(beta_l(frequencies), CANTILEVER_BETA_L, rtol=1e-4)


def test_soft_clamp_spring_recovers_the_pinned_free_beam():
    parameters = dict(BASE, clamp_stiffness_Nm_rad=1e-9)
    frequencies, _ = BeamModel(GEOMETRY, ["clamp_compliance"], 16).natural_modes(parameters, 4)
    assert beta_l(frequencies[0]) < 1e-2  # the rigid-body rotation about the pin
    np.testing.assert_allclose(beta_l(frequencies[1:]), PINNED_FREE_BETA_L, rtol=1e-4)


def test_uniform_beam_damping_ratios_follow_the_proportional_formula():
    gamma, kelvin_voigt = 0.02, 2e-5
    parameters = dict(BASE, air_damping_Ns_m2=gamma, kelvin_voigt_Nm2s=kelvin_voigt)
    frequencies, ratios = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"], 16).natural_modes(parameters, 4)
    # the undamped Galerkin frequencies: |lambda| = omega_n exactly for proportional damping
    undamped, _ = BeamModel(GEOMETRY, intervals=16).natural_modes(BASE, 4)
    np.testing.assert_allclose(frequencies, undamped, rtol=1e-10)
    omega = 2 * np.pi * undamped
    expected = gamma / (2 * DENSITY * omega) + kelvin_voigt * omega / (2 * STIFFNESS)
    np.testing.assert_allclose(ratios, expected, rtol=1e-8)
    # and against the analytic omega_n of the continuum to the mesh accuracy
    analytic = CANTILEVER_BETA_L**2 / LENGTH**2 * np.sqrt(STIFFNESS / DENSITY)
    np.testing.assert_allclose(ratios, gamma / (2 * DENSITY * analytic) + kelvin_voigt * analytic / (2 * STIFFNESS), rtol=3e-4)


def test_patch_stiffening_converges_to_the_stepped_beam_transfer_matrix_solution():
    """Second method: exact stepped-beam frequencies. Uniform C² splines cannot represent the
    curvature jump at the patch ends, so convergence there is first order (documented)."""
    length, density, stiffness, start, end, added_density, added_stiffness = 0.4573, 0.093, 0.491, 0.15, 0.25, 0.433, 0.793
    segments = [(stiffness, density, start), (stiffness + added_stiffness, density + added_density, end - start),
                (stiffness, density, length - end)]
    reference = stepped_beam_frequencies_Hz(segments, 4, 2 * np.pi * 400)
    geometry = BeamGeometry(length, density, start, end, 0.27)
    parameters = {"bending_stiffness_Nm2": stiffness, "patch_coupling_NmV": 0.01,
                  "patch_added_density_kg_m": added_density, "patch_added_stiffness_Nm2": added_stiffness}
    errors = {}
    for intervals in (16, 32, 128):
        frequencies, _ = BeamModel(geometry, ["patch_stiffening"], intervals).natural_modes(parameters, 4)
        errors[intervals] = np.abs(frequencies / reference - 1)
    assert errors[16].max() < 0.015
    assert errors[128].max() < 0.002
    assert np.all(errors[128] < errors[32]) and np.all(errors[32] < errors[16])
