"""Galerkin component matrices of the cantilever, one per physical term.

Every matrix the effects need is assembled once per geometry and mesh, for a unit coefficient:
the model then forms M, C, K and the force as sums ``coefficient * part`` (see
:class:`beam.physics.effects.Term`). The basis is :class:`beam.physics.basis.SplineBasis` (cubic B-splines, the
patch ends as double knots by default). Quadrature is Gauss–Legendre on each knot interval, also
split at the patch ends (which are knots already unless ``knots = "uniform"``), so that piecewise
properties are integrated exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from beam.physics.basis import (
    DEFAULT_INTERVALS,
    DEFAULT_KNOTS,
    KnotLayout,
    SplineBasis,
    gauss_points,
)
from beam.physics.geometry import BeamGeometry


@dataclass(frozen=True)
class GalerkinParts:
    """Unit-coefficient parts of the weak form (n = number of basis functions).

    Attributes
    ----------
    mass_beam : (n, n)  ∫_0^L phi_i phi_j dx (m); times rho (mass) or gamma (air damping).
    mass_patch : (n, n)  ∫_patch phi_i phi_j dx; times the added density.
    mass_tip : (n, n)  phi_i(L) phi_j(L); times the tip mass.
    mass_sensor : (n, n)  phi_i(x_obs) phi_j(x_obs); times the sensor's mass (a point mass at the
        sensor, translation only: the board's rotary inertia is neglected).
    stiffness_beam : (n, n)  ∫_0^L phi_i'' phi_j'' dx (1/m³); times EI (stiffness) or cI (damping).
    stiffness_patch : (n, n)  ∫_patch phi_i'' phi_j'' dx; times the added EI or cI.
    stiffness_clamp : (n, n)  phi_i'(0) phi_j'(0); times the clamp's rotational stiffness.
    patch_force : (n,)  ∫_patch phi_i'' dx = phi_i'(p_r) - phi_i'(p_l); times k_p V(t) (zero
        without a patch).
    point_force : (n,)  phi_i(x_f): the generalised force of a unit point force at x_f (zero
        without a force position); times F(t) (N).
    tip_values : (n,)  phi_i(L): tip displacement w(L) = tip_values @ q.
    sensor_values : (n,)  phi_i(x_obs): sensor displacement y = sensor_values @ q.
    sensor_curvatures : (n,)  phi_i''(x_obs) (1/m²): curvature w''(x_obs) = sensor_curvatures @ q;
        a strain gauge there reads -(h/2) w''(x_obs).
    """

    basis: SplineBasis
    mass_beam: np.ndarray
    mass_patch: np.ndarray
    mass_tip: np.ndarray
    mass_sensor: np.ndarray
    stiffness_beam: np.ndarray
    stiffness_patch: np.ndarray
    stiffness_clamp: np.ndarray
    patch_force: np.ndarray
    point_force: np.ndarray
    tip_values: np.ndarray
    sensor_values: np.ndarray
    sensor_curvatures: np.ndarray

    @property
    def size(self) -> int:
        return self.basis.size


def assemble_parts(geometry: BeamGeometry, intervals: int = DEFAULT_INTERVALS, free_root_rotation: bool = False,
                   knots: KnotLayout = DEFAULT_KNOTS, double_knots=()) -> GalerkinParts:
    """Assemble the Galerkin parts of ``geometry`` with ``intervals`` elements in a knot layout.

    Parameters
    ----------
    geometry : BeamGeometry
        Beam, patch and sensor (m).
    intervals : int
        Number of elements (knot intervals).
    free_root_rotation : bool
        Keep the root rotation free (compliant clamp) instead of clamping it.
    knots : {"patch", "uniform"}
        Knot layout (:func:`beam.physics.basis.knot_vector`).
    double_knots : sequence of float
        Points (m) where an effect's own part makes the curvature jump (double knots there).
    """
    basis = SplineBasis.for_geometry(geometry, intervals, knots, free_root_rotation, double_knots)
    patch_ends = [geometry.patch_start_m, geometry.patch_end_m] if geometry.has_patch else []
    breaks = np.unique(np.concatenate([basis.breakpoints_m, patch_ends]))
    x, w = gauss_points(breaks)
    if geometry.has_patch:
        on_patch = (x >= geometry.patch_start_m) & (x <= geometry.patch_end_m)
    else:
        on_patch = np.zeros(x.shape, dtype=bool)
    values = basis.evaluate(x, 0)
    curvatures = basis.evaluate(x, 2)

    def gram(f: np.ndarray, weights: np.ndarray) -> np.ndarray:
        g = f.T @ (weights[:, None] * f)
        return 0.5 * (g + g.T)

    tip = basis.evaluate([geometry.length_m], 0)[0]
    root_slope = basis.evaluate([0.0], 1)[0]
    if geometry.has_patch:
        patch_slopes = basis.evaluate([geometry.patch_start_m, geometry.patch_end_m], 1)
        patch_force = patch_slopes[1] - patch_slopes[0]
    else:
        patch_force = np.zeros(basis.size)
    sensor = basis.evaluate([geometry.sensor_position_m], 0)[0]
    if geometry.force_position_m is not None:
        point_force = basis.evaluate([geometry.force_position_m], 0)[0]
    else:
        point_force = np.zeros(basis.size)
    return GalerkinParts(
        basis=basis,
        mass_beam=gram(values, w),
        mass_patch=gram(values, w * on_patch),
        mass_tip=np.outer(tip, tip),
        mass_sensor=np.outer(sensor, sensor),
        stiffness_beam=gram(curvatures, w),
        stiffness_patch=gram(curvatures, w * on_patch),
        stiffness_clamp=np.outer(root_slope, root_slope),
        patch_force=patch_force,
        point_force=point_force,
        tip_values=tip,
        sensor_values=sensor,
        sensor_curvatures=basis.evaluate([geometry.sensor_position_m], 2)[0],
    )
