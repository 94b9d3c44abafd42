"""Natural frequencies and damping of the Galerkin model against analytic references."""

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from reference_beams import (
    CANTILEVER_BETA_L,
    PINNED_FREE_BETA_L,
    cantilever_beta_l,
    clamp_spring_beta_l,
    stepped_beam_frequencies_Hz,
    tip_mass_beta_l,
)
from reference_bspline import ModifiedCubicBasis, cardinal_cubic_bspline

from beam.errors import BeamInputError
from beam.io.config import load_config
from beam.physics.basis import (
    DEFAULT_INTERVALS,
    SplineBasis,
    gauss_points,
    knot_vector,
    segment_elements,
)
from beam.physics.geometry import BeamGeometry
from beam.physics.model import BeamModel

LENGTH, DENSITY, STIFFNESS = 0.5, 0.1, 0.5
GEOMETRY = BeamGeometry(LENGTH, DENSITY, 0.1, 0.2, 0.3)
BASE = {"bending_stiffness_Nm2": STIFFNESS, "patch_coupling_NmV": 0.01}
B1TAPIH = Path(__file__).resolve().parents[1] / "assets" / "b1tapih.toml"
UNDAMPED_PATCH = ("bending_stiffness_Nm2", "patch_coupling_NmV", "patch_added_density_kg_m", "patch_added_stiffness_Nm2")


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


@pytest.mark.parametrize("knots", ["patch", "uniform"])
@pytest.mark.parametrize("free_root", [False, True])
def test_spline_basis_boundary_conditions_and_size(knots, free_root):
    basis = SplineBasis.for_geometry(GEOMETRY, 16, knots, free_root)
    # N + 3 cubic B-splines on N elements, two more for the double knots, less one or two at the root
    assert basis.size == 16 + 3 + (2 if knots == "patch" else 0) - (1 if free_root else 2)
    assert basis.intervals == 16
    np.testing.assert_allclose(basis.evaluate([0.0], 0), 0.0, atol=1e-15)
    slopes = basis.evaluate([0.0], 1)[0]
    if free_root:
        assert np.abs(slopes).max() > 1.0  # the root rotation stays free
    else:
        np.testing.assert_allclose(slopes, 0.0, atol=1e-12)
    # with every B-spline kept back in, they sum to one: the dropped ones are the root's
    x = np.linspace(0.0, LENGTH, 57)
    assert np.all(basis.evaluate(x).sum(axis=1) <= 1.0 + 1e-14)


def test_patch_knots_let_the_curvature_jump_but_not_the_slope():
    basis = SplineBasis.for_geometry(GEOMETRY, 16, "patch")
    uniform = SplineBasis.for_geometry(GEOMETRY, 16, "uniform")
    for end in (GEOMETRY.patch_start_m, GEOMETRY.patch_end_m):
        left, right = end - 1e-9, end + 1e-9
        for b in (basis, uniform):
            # slopes of order 50 /m; 2e-9 m apart they differ by the curvature times 2e-9 m only
            np.testing.assert_allclose(b.evaluate([left], 1), b.evaluate([right], 1), atol=1e-4)
        assert np.abs(basis.evaluate([left], 2) - basis.evaluate([right], 2)).max() > 1.0  # 1/m: C¹ only
    # the uniform knots are C² everywhere (the patch ends 0.1, 0.2 m fall inside elements of L/16)
    x = np.array([GEOMETRY.patch_start_m, GEOMETRY.patch_end_m])
    # curvatures of order 1000 /m²; 2e-9 m apart they differ by the third derivative times 2e-9 m only
    np.testing.assert_allclose(uniform.evaluate(x - 1e-9, 2), uniform.evaluate(x + 1e-9, 2), atol=1e-3)


def test_knot_vector_doubles_the_patch_ends_and_spreads_the_elements_evenly():
    knots = knot_vector(GEOMETRY, 16, "patch")
    values, counts = np.unique(knots, return_counts=True)
    assert values.size == 17 and counts[0] == counts[-1] == 4 and values[0] == 0.0 and values[-1] == LENGTH
    doubled = values[counts == 2]
    np.testing.assert_allclose(doubled, [GEOMETRY.patch_start_m, GEOMETRY.patch_end_m], rtol=0, atol=0)
    assert np.all(counts[1:-1][counts[1:-1] != 2] == 1)
    # the share minimises the largest element, against every share of 16 elements over 3 segments
    lengths = np.array([0.1, 0.1, 0.3])
    best = min(max(lengths / (a, b, 16 - a - b)) for a in range(1, 15) for b in range(1, 16 - a))
    assert max(lengths / segment_elements(lengths, 16)) == pytest.approx(best, rel=1e-15)
    np.testing.assert_allclose(np.diff(values).max(), best, rtol=1e-12)
    # a patch that starts at the root or ends at the tip adds no knot there
    root_patch = BeamGeometry(LENGTH, DENSITY, 0.0, 0.2, 0.3)
    values, counts = np.unique(knot_vector(root_patch, 16, "patch"), return_counts=True)
    assert values.size == 17 and counts[0] == 4 and values[counts == 2].tolist() == [0.2]
    with pytest.raises(BeamInputError, match="knots must be one of"):
        knot_vector(GEOMETRY, 16, "chebyshev")
    with pytest.raises(BeamInputError, match="at least 3"):
        knot_vector(GEOMETRY, 2, "patch")


def test_gauss_points_integrate_degree_seven_exactly():
    x, w = gauss_points(np.array([0.0, 0.13, 0.5]))
    np.testing.assert_allclose(np.sum(w * x**7), 0.5**8 / 8, rtol=1e-13)


@pytest.mark.parametrize("start, end, tolerance", [
    (1e-6, 0.1, 1e-5),  # a patch starting 1 µm from the root: that knot is dropped
    (5e-4, 0.1, 1e-5),  # 0.04 L/N from the root: kept, a short first element
    (0.3, 0.4573 - 1e-7, 1e-5),  # ending 0.1 µm before the tip: that knot is dropped
    (0.15, 0.151, 3e-3),  # a 1 mm patch (0.09 L/N): no knots, the uniform layout's first-order error
])
def test_patch_ends_next_to_the_root_the_tip_or_each_other_stay_accurate(start, end, tolerance):
    """Patch ends too close to the root, the tip or each other would cut off one tiny element
    (a patch ending 1e-7 m before the tip gave infinite responses): beam.physics.basis.patch_breaks."""
    length, density, stiffness, added_density, added_stiffness = 0.4573, 0.093, 0.491, 0.433, 0.793
    segments = [(stiffness, density, start), (stiffness + added_stiffness, density + added_density, end - start),
                (stiffness, density, length - end)]
    reference = stepped_beam_frequencies_Hz(segments, 4, 2 * np.pi * 400)
    model = BeamModel(BeamGeometry(length, density, start, end, 0.27), ["patch_stiffening"])
    parameters = {"bending_stiffness_Nm2": stiffness, "patch_coupling_NmV": 0.01,
                  "patch_added_density_kg_m": added_density, "patch_added_stiffness_Nm2": added_stiffness}
    frequencies, _ = model.natural_modes(parameters, 4)
    assert np.abs(frequencies / reference - 1).max() <= tolerance, frequencies / reference - 1
    response = model.response(parameters, np.sin(2 * np.pi * 30 * np.arange(500) * 1e-3), 1e-3)
    assert np.isfinite(response).all() and 1e-6 < np.abs(response).max() < 1e-2


@pytest.mark.parametrize("free_root", [False, True])
def test_uniform_knots_span_smiths_modified_basis(free_root):
    """``knots = "uniform"`` spans the same functions as Smith's hand-written basis: every
    modified B-spline is a combination of the scipy B-splines, with the same combination for
    values and curvatures."""
    smith = ModifiedCubicBasis(LENGTH, 16, free_root)
    basis = SplineBasis.for_geometry(GEOMETRY, 16, "uniform", free_root)
    assert basis.size == smith.size
    x = np.linspace(0.0, LENGTH, 301)
    coefficients, *_ = np.linalg.lstsq(basis.evaluate(x), smith.evaluate(x), rcond=None)
    for derivative, scale in ((0, 1.0), (1, 16 / LENGTH), (2, (16 / LENGTH) ** 2)):
        residual = basis.evaluate(x, derivative) @ coefficients - smith.evaluate(x, derivative)
        assert np.abs(residual).max() <= 1e-12 * scale


def test_uniform_knots_reproduce_smiths_frequencies_of_the_patched_beam():
    """The paper's discretisation is still there: the stepped beam assembled by hand on Smith's
    basis (uniform N = 16, quadrature split at the patch ends) against ``knots = "uniform"``."""
    config = load_config(B1TAPIH)
    geometry, values = config.geometry, config.parameters
    smith = ModifiedCubicBasis(geometry.length_m, 16)
    breaks = np.unique(np.r_[np.linspace(0.0, geometry.length_m, 17), geometry.patch_start_m, geometry.patch_end_m])
    x, w = gauss_points(breaks)
    on = (x > geometry.patch_start_m) & (x < geometry.patch_end_m)
    density = geometry.linear_density_kg_m + values["patch_added_density_kg_m"] * on
    stiffness = values["bending_stiffness_Nm2"] + values["patch_added_stiffness_Nm2"] * on
    phi, curvature = smith.evaluate(x, 0), smith.evaluate(x, 2)
    omega2 = scipy.linalg.eigh(curvature.T @ ((w * stiffness)[:, None] * curvature),
                               phi.T @ ((w * density)[:, None] * phi), eigvals_only=True)[:4]
    undamped = {k: values[k] for k in UNDAMPED_PATCH}
    frequencies, _ = BeamModel(geometry, ["patch_stiffening"], 16, "uniform").natural_modes(undamped, 4)
    np.testing.assert_allclose(frequencies, np.sqrt(omega2) / (2 * np.pi), rtol=1e-10)


def b1tapih_stepped_reference() -> tuple[BeamGeometry, dict, np.ndarray]:
    """The bundled B1TAPIH beam with its patch, undamped, and its exact transfer-matrix frequencies (Hz)."""
    config = load_config(B1TAPIH)
    g, v = config.geometry, config.parameters
    stiffness, density = v["bending_stiffness_Nm2"], g.linear_density_kg_m
    segments = [(stiffness, density, g.patch_start_m),
                (stiffness + v["patch_added_stiffness_Nm2"], density + v["patch_added_density_kg_m"], g.patch_end_m - g.patch_start_m),
                (stiffness, density, g.length_m - g.patch_end_m)]
    return g, {k: v[k] for k in UNDAMPED_PATCH}, stepped_beam_frequencies_Hz(segments, 4, 2 * np.pi * 400)


def test_b1tapih_with_its_patch_matches_the_stepped_beam_to_1e_5_at_the_default_mesh():
    geometry, parameters, reference = b1tapih_stepped_reference()
    # an independent Hermite FE simulator with nodes at the patch ends (3 decimals)
    np.testing.assert_allclose(reference, [5.513, 29.415, 93.276, 193.850], rtol=0, atol=6e-4)
    frequencies, _ = BeamModel(geometry, ["patch_stiffening"]).natural_modes(parameters, 4)
    assert np.abs(frequencies / reference - 1).max() <= 1e-5, frequencies / reference - 1


@pytest.mark.parametrize("geometry", ["b1tapih", "test"])
def test_uniform_cantilever_matches_beta_l_to_1e_5_at_the_default_mesh(geometry):
    """No patch stiffening: the frequencies (not beta L: twice as sensitive) to 1e-5, with the
    patch knots of the geometry in the mesh."""
    g = load_config(B1TAPIH).geometry if geometry == "b1tapih" else GEOMETRY
    frequencies, _ = BeamModel(g, intervals=DEFAULT_INTERVALS).natural_modes(BASE, 4)
    exact = cantilever_beta_l(4) ** 2 / (2 * np.pi * g.length_m**2) * np.sqrt(STIFFNESS / g.linear_density_kg_m)
    assert np.abs(frequencies / exact - 1).max() <= 1e-5, frequencies / exact - 1


@pytest.mark.parametrize("with_patch", [True, False])
def test_patch_knots_converge_at_fourth_order_with_and_without_the_patch(with_patch):
    """Observed order of the frequency error against the largest element, N = 8, 16, 32."""
    geometry, parameters, reference = b1tapih_stepped_reference()
    effects = ["patch_stiffening"] if with_patch else []
    if not with_patch:
        parameters = {k: parameters[k] for k in BASE}
        reference = cantilever_beta_l(4) ** 2 / (2 * np.pi * geometry.length_m**2) * np.sqrt(
            parameters["bending_stiffness_Nm2"] / geometry.linear_density_kg_m)
    sizes, errors = [], []
    for intervals in (8, 16, 32):
        frequencies, _ = BeamModel(geometry, effects, intervals).natural_modes(parameters, 4)
        errors.append(np.abs(frequencies / reference - 1))
        sizes.append(np.diff(np.unique(knot_vector(geometry, intervals))).max())
    orders = np.polyfit(np.log(sizes), np.log(np.array(errors)), 1)[0]
    assert np.all((orders > 3.5) & (orders < 4.5)), orders


def test_uniform_knots_converge_at_fourth_order_on_a_uniform_beam():
    reference = CANTILEVER_BETA_L[1:3]  # modes 2-3: well above the 7-digit precision of the table
    errors = []
    for intervals in (4, 8, 16):
        frequencies, _ = BeamModel(GEOMETRY, intervals=intervals, knots="uniform").natural_modes(BASE, 3)
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
    frequencies, _ = BeamModel(GEOMETRY, ["clamp_compliance"]).natural_modes(parameters, 4)
    np.testing.assert_allclose(beta_l(frequencies), clamp_spring_beta_l(kappa), rtol=1e-4)


def test_stiff_clamp_spring_recovers_the_rigid_clamp():
    parameters = dict(BASE, clamp_stiffness_Nm_rad=1e9)
    frequencies, _ = BeamModel(GEOMETRY, ["clamp_compliance"]).natural_modes(parameters, 4)
    np.testing.assert_allclose(beta_l(frequencies), CANTILEVER_BETA_L, rtol=1e-4)


def test_soft_clamp_spring_recovers_the_pinned_free_beam():
    parameters = dict(BASE, clamp_stiffness_Nm_rad=1e-9)
    # 16 elements: the rigid-body pole (exact beta L 0.0074) sits at the round-off of the first-order
    # eigenproblem, which grows with N (beta L 0.0075 at 16 elements, 0.011 at the default 40)
    frequencies, _ = BeamModel(GEOMETRY, ["clamp_compliance"], 16).natural_modes(parameters, 4)
    assert beta_l(frequencies[0]) < 1e-2  # the rigid-body rotation about the pin
    np.testing.assert_allclose(beta_l(frequencies[1:]), PINNED_FREE_BETA_L, rtol=1e-4)


def test_uniform_beam_damping_ratios_follow_the_proportional_formula():
    gamma, kelvin_voigt = 0.02, 2e-5
    parameters = dict(BASE, air_damping_Ns_m2=gamma, kelvin_voigt_Nm2s=kelvin_voigt)
    frequencies, ratios = BeamModel(GEOMETRY, ["air_damping", "kelvin_voigt"]).natural_modes(parameters, 4)
    # the undamped Galerkin frequencies: |lambda| = omega_n exactly for proportional damping, up
    # to the round-off of dgeev on a first-order system whose spectrum spans four decades (mode 1
    # came out 6.6e-10 relative on one OpenBLAS kernel, 1e-11 on another)
    undamped, _ = BeamModel(GEOMETRY).natural_modes(BASE, 4)
    np.testing.assert_allclose(frequencies, undamped, rtol=2e-9)
    omega = 2 * np.pi * undamped
    expected = gamma / (2 * DENSITY * omega) + kelvin_voigt * omega / (2 * STIFFNESS)
    np.testing.assert_allclose(ratios, expected, rtol=1e-8)
    # and against the analytic omega_n of the continuum to the mesh accuracy
    analytic = CANTILEVER_BETA_L**2 / LENGTH**2 * np.sqrt(STIFFNESS / DENSITY)
    np.testing.assert_allclose(ratios, gamma / (2 * DENSITY * analytic) + kelvin_voigt * analytic / (2 * STIFFNESS), rtol=3e-4)


def test_uniform_knots_converge_only_at_first_order_on_the_stepped_beam():
    """Second method: exact stepped-beam frequencies. Uniform C² splines (``knots = "uniform"``,
    Smith's mesh) cannot represent the curvature jump at the patch ends, so convergence there is
    first order (documented; the default patch knots fix it)."""
    length, density, stiffness, start, end, added_density, added_stiffness = 0.4573, 0.093, 0.491, 0.15, 0.25, 0.433, 0.793
    segments = [(stiffness, density, start), (stiffness + added_stiffness, density + added_density, end - start),
                (stiffness, density, length - end)]
    reference = stepped_beam_frequencies_Hz(segments, 4, 2 * np.pi * 400)
    geometry = BeamGeometry(length, density, start, end, 0.27)
    parameters = {"bending_stiffness_Nm2": stiffness, "patch_coupling_NmV": 0.01,
                  "patch_added_density_kg_m": added_density, "patch_added_stiffness_Nm2": added_stiffness}
    errors = {}
    for intervals in (16, 32, 128):
        frequencies, _ = BeamModel(geometry, ["patch_stiffening"], intervals, "uniform").natural_modes(parameters, 4)
        errors[intervals] = np.abs(frequencies / reference - 1)
    assert errors[16].max() < 0.015
    assert errors[128].max() < 0.002
    assert np.all(errors[128] < errors[32]) and np.all(errors[32] < errors[16])


@pytest.mark.parametrize("effect, parameter", [("tip_mass", "tip_mass_kg"), ("sensor_mass", "sensor_mass_kg")])
def test_point_mass_modes_of_a_free_model_match_the_dense_eigensolver(effect, parameter, monkeypatch):
    """The tridiagonal point-mass path (one factorisation for every mass) against the dense
    eigenproblem of each M, K (the same normalised matrices) and, for a tip mass, the
    characteristic equation."""
    model = BeamModel(GEOMETRY, [effect], 32, input_kind=None)
    dense = BeamModel(GEOMETRY, [effect], 32, input_kind=None)
    monkeypatch.setattr(dense, "_point_mass_modes", lambda *args: None)
    ratios = np.array([0.0, 0.2, 1.0, 3.0])
    values = {"bending_stiffness_Nm2": np.full(ratios.size, STIFFNESS), parameter: ratios * DENSITY * LENGTH}
    reduced, _, _ = model.reduced_system(values, 4)
    expected, _, _ = dense.reduced_system(values, 4)
    assert model._point_mass_factors and not dense._point_mass_factors  # each took its path
    for name in ("omega2", "sensor", "tip", "damping"):
        np.testing.assert_allclose(reduced[name], expected[name], rtol=1e-12, atol=1e-12 * np.abs(expected[name]).max())
    for i, ratio in enumerate(ratios):  # one set at a time: the same numbers as the batch
        single, _, _ = model.reduced_system({"bending_stiffness_Nm2": STIFFNESS, parameter: float(ratio * DENSITY * LENGTH)}, 4)
        np.testing.assert_allclose(single["omega2"][0], reduced["omega2"][i], rtol=1e-14)
        if effect == "tip_mass":
            exact = cantilever_beta_l() if ratio == 0 else tip_mass_beta_l(ratio)
            beta = (reduced["omega2"][i] * DENSITY * LENGTH**4 / STIFFNESS) ** 0.25
            np.testing.assert_allclose(beta, exact, rtol=1e-5)
