"""Cubic B-spline Galerkin basis of the cantilever, on a knot vector with the patch ends as knots.

The basis functions are the cubic B-splines of :class:`scipy.interpolate.BSpline` on an *open*
(clamped) knot vector of [0, L]: the end knots 0 and L are repeated four times, so that at the
root B_0(0) = 1, every other function vanishes there, and only B_0 and B_1 have a nonzero slope.
The essential boundary conditions are therefore met by dropping functions rather than by
combining them:

* rigid clamp, w(0) = w'(0) = 0: B_0 and B_1 are dropped;
* compliant clamp, w(0) = 0 only: B_0 is dropped, so the root rotation stays free and a
  rotational spring can act on it.

The free end needs nothing (its conditions are natural). Two knot layouts
(``[model] knots``):

``"patch"`` (default)
    The patch ends are double knots: the splines are only C¹ there, so the curvature may jump
    where EI jumps (and where the piezo moment starts and stops), as the exact solution does.
    The ``intervals`` elements are shared among the segments [0, p_l], [p_l, p_r], [p_r, L] so
    that the largest element is as small as possible, uniform within each segment. The
    frequencies of a patched beam then converge at fourth order (h⁴), as for a uniform beam.
    A patch end very close to the root or the tip, or the ends of a patch shorter than
    L / (4 N), are not made knots (:func:`patch_breaks`). An effect whose own Galerkin part
    makes the curvature jump at a point (the rotary inertia of a sensor: a moment there) asks
    for a double knot there too (``double_knots``, :attr:`beam.physics.effects.effect.Effect.knots`),
    a segment end like the patch's.
``"uniform"``
    N uniform elements, single (C²) knots: the same space of functions as the modified cubic
    B-splines of Smith (*Smart Material Systems*, ch. 7–8), so the paper's discretisation is
    reproduced (the frequencies agree with :class:`beam.physics.basis.ModifiedCubicBasis` to 1e-10
    at N = 16). Where EI jumps inside an element the curvature cannot jump, and the
    frequencies of a patched beam converge only at first order.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from beam.errors import BeamInputError
from beam.physics.geometry import BeamGeometry

#: Polynomial degree of the basis (cubic).
DEGREE = 3
#: Knot layouts of ``[model] knots``.
KNOT_LAYOUTS: tuple[str, ...] = ("patch", "uniform")
#: Default knot layout.
DEFAULT_KNOTS = "patch"
#: Default number of elements (knot intervals) of the Galerkin model: with the patch knots the
#: first four frequencies of the bundled B1TAPIH beam, with and without patch stiffening, are
#: within 1e-5 of the exact (transfer-matrix) solution (tests/test_physics_modes.py).
DEFAULT_INTERVALS = 40
#: Bounds on the number of elements.
INTERVALS_RANGE = (2, 400)
#: Shortest segments a patch knot may cut off, as fractions of L / intervals: next to the root,
#: next to the tip, and the patch itself (:func:`patch_breaks`).
MIN_SEGMENT_FRACTIONS = (0.005, 0.5, 0.25)

KnotLayout = Literal["patch", "uniform"]


def segment_elements(segment_lengths_m: np.ndarray, intervals: int) -> np.ndarray:
    """Share ``intervals`` elements among segments so that the largest element is the smallest.

    Every segment gets at least one element; each further element goes to the segment whose
    elements are currently the longest (ties: the first). The result minimises the largest
    element length over all shares of ``intervals`` elements.

    Parameters
    ----------
    segment_lengths_m : numpy.ndarray
        Lengths of the segments (m), all positive.
    intervals : int
        Number of elements, at least the number of segments.

    Returns
    -------
    numpy.ndarray
        Number of elements of each segment (sums to ``intervals``).
    """
    lengths = np.asarray(segment_lengths_m, dtype=float)
    counts = np.ones(lengths.size, dtype=int)
    for _ in range(intervals - lengths.size):
        counts[np.argmax(lengths / counts)] += 1
    return counts


def patch_breaks(geometry: BeamGeometry, intervals: int, double_knots=()) -> np.ndarray:
    """Segment ends of the ``"patch"`` layout (m): 0, the patch ends that become knots, the
    ``double_knots`` asked for (m; kept under the rules for a patch end next to the root or the
    tip, and dropped within a patch's minimum length of another end), L.

    A patch end is not made a knot when the segment it would cut off is shorter than a fraction
    of h = L / ``intervals`` (:data:`MIN_SEGMENT_FRACTIONS`): such a segment is one short
    element, and the eigenproblem's conditioning grows as the fourth power of the ratio of the
    element lengths (a patch starting 1e-4 h from the root, or ending 1e-7 m from the tip, gave
    garbage). Measured on the B1TAPIH beam at N = 40: largest error of the first four
    frequencies against the transfer matrix, and round-off of the response as the patch
    stiffness moves by steps of 1e-5 (relative to the response):

    * next to the root the knot is kept down to 0.005 h (error 4.4e-6, round-off <= 1e-9 down to
      0.001 h); dropping it costs more there (3.5e-4 at 0.004 h, 1e-5 at 1e-4 h), since the
      root carries the largest moment;
    * next to the tip a short element is badly conditioned (round-off 1.5e-8 at 0.25 h, 3e-8
      at 0.1 h) while dropping the knot costs nothing (the moment vanishes at a free end; error
      4.6e-6): dropped below 0.5 h;
    * a patch shorter than 0.25 h gets no knots: with them the round-off reached 4e-7 at 0.1 h;
      without them the curvature jump is smoothed as in the uniform layout (error 2.8e-3 at
      0.2 h, 1.7e-3 at 0.1 h, 2e-4 at 0.01 h; raise ``intervals`` for such a patch).

    The quadrature is still split at the patch ends, so the properties stay exact; only the
    curvature jump is smoothed there, as in the uniform layout.
    """
    length = geometry.length_m
    h = length / intervals
    root, tip, patch = (fraction * h for fraction in MIN_SEGMENT_FRACTIONS)
    start, end = geometry.patch_start_m, geometry.patch_end_m
    ends = []
    if geometry.has_patch and end - start >= patch:  # a beam without a patch has no property jump
        ends = [p for p in (start, end) if root <= p <= length - tip]
    for p in sorted(float(x) for x in double_knots):
        if root <= p <= length - tip and all(abs(p - q) >= patch for q in ends):
            ends.append(p)
    return np.array([0.0, *sorted(ends), length])


def knot_vector(geometry: BeamGeometry, intervals: int, knots: KnotLayout = DEFAULT_KNOTS,
                double_knots=()) -> np.ndarray:
    """Open cubic knot vector of [0, L] for a knot layout (see the module docstring).

    Parameters
    ----------
    geometry : BeamGeometry
        Beam length and patch ends (m).
    intervals : int
        Number of elements (distinct knot intervals).
    knots : {"patch", "uniform"}
        Knot layout.
    double_knots : sequence of float
        Points (m) where an effect's part makes the curvature jump: segment ends of the
        ``"patch"`` layout (:func:`patch_breaks`); in the ``"uniform"`` layout the knot nearest
        each is moved there and doubled.

    Returns
    -------
    numpy.ndarray
        Knots (m), non-decreasing, 0 and L four times each, with ``"patch"`` the patch ends and
        the ``double_knots`` twice (those of :func:`patch_breaks`).
    """
    if knots not in KNOT_LAYOUTS:
        raise BeamInputError(f"knots must be one of {', '.join(repr(k) for k in KNOT_LAYOUTS)}, got {knots!r}")
    if isinstance(intervals, bool) or int(intervals) != intervals or not INTERVALS_RANGE[0] <= intervals <= INTERVALS_RANGE[1]:
        raise BeamInputError(f"intervals must be an integer in [{INTERVALS_RANGE[0]}, {INTERVALS_RANGE[1]}], got {intervals!r}")
    length = geometry.length_m
    if knots == "uniform":
        interior = np.linspace(0.0, length, int(intervals) + 1)[1:-1]
        for p in double_knots:
            if 0.0 < p < length and interior.size:
                nearest = int(np.argmin(np.abs(interior - p)))
                interior = np.sort(np.concatenate([np.delete(interior, nearest), [float(p), float(p)]]))
    else:
        breaks = patch_breaks(geometry, int(intervals), double_knots)
        if intervals < breaks.size - 1:
            raise BeamInputError(
                f"intervals must be at least {breaks.size - 1} with knots = 'patch' (one element per segment "
                f"between the root, the patch ends and the tip), got {intervals}"
            )
        counts = segment_elements(np.diff(breaks), int(intervals))
        pieces = [np.linspace(a, b, n + 1)[1:-1] for a, b, n in zip(breaks[:-1], breaks[1:], counts)]
        interior = np.sort(np.concatenate(pieces + [np.repeat(breaks[1:-1], 2)]))
    return np.concatenate([np.zeros(DEGREE + 1), interior, np.full(DEGREE + 1, length)])


class SplineBasis:
    """Cubic B-splines on an open knot vector of [0, L], clamped at the root.

    Parameters
    ----------
    knots_m : numpy.ndarray
        Open knot vector (m): non-decreasing, first and last knot four times, interior knots at
        most twice (so every function is at least C¹ and its second derivative square-integrable).
    free_root_rotation : bool
        False: rigid clamp, phi(0) = phi'(0) = 0 (B_0 and B_1 dropped).
        True: compliant clamp, phi(0) = 0 only (B_0 dropped).
    """

    def __init__(self, knots_m: np.ndarray, free_root_rotation: bool = False) -> None:
        t = np.asarray(knots_m, dtype=float)
        multiplicity = np.unique(t, return_counts=True)[1]
        if (t.ndim != 1 or np.any(np.diff(t) < 0) or t[0] != 0.0 or multiplicity[0] != DEGREE + 1
                or multiplicity[-1] != DEGREE + 1 or np.any(multiplicity[1:-1] > 2)):
            raise ValueError("knots_m must be an open cubic knot vector from 0 with interior knots at most double")
        from scipy.interpolate import (
            BSpline,  # here: beam.io.config reads this module's constants, without scipy
        )

        self.knots_m = t
        self.free_root_rotation = bool(free_root_rotation)
        #: Number of standard B-splines on the knot vector.
        self.n_standard = t.size - DEGREE - 1
        #: Index of the first kept B-spline (1 with a free root rotation, else 2).
        self.first = 1 if free_root_rotation else 2
        self._splines = [BSpline(t, np.eye(self.n_standard)[:, self.first:], DEGREE, extrapolate=False)]
        for _ in range(2):
            self._splines.append(self._splines[-1].derivative())

    @classmethod
    def for_geometry(cls, geometry: BeamGeometry, intervals: int, knots: KnotLayout = DEFAULT_KNOTS,
                     free_root_rotation: bool = False, double_knots=()) -> SplineBasis:
        """The basis of ``geometry`` with ``intervals`` elements in a knot layout (:func:`knot_vector`)."""
        return cls(knot_vector(geometry, intervals, knots, double_knots), free_root_rotation)

    @property
    def length_m(self) -> float:
        """Beam length L (m)."""
        return float(self.knots_m[-1])

    @property
    def breakpoints_m(self) -> np.ndarray:
        """The distinct knots (m): element ends, 0 and L included."""
        return np.unique(self.knots_m)

    @property
    def intervals(self) -> int:
        """Number of elements (distinct knot intervals)."""
        return self.breakpoints_m.size - 1

    @property
    def size(self) -> int:
        """Number of basis functions: standard B-splines less the one or two dropped at the root."""
        return self.n_standard - self.first

    def evaluate(self, x_m: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Values (or x-derivatives, 1/m^derivative) of every basis function at ``x_m``: shape (len(x), size).

        Points must lie in [0, L]. At a double knot the second derivative is taken from the
        element on the right (left at x = L); quadrature never samples it there.
        """
        if derivative not in (0, 1, 2):
            raise ValueError("derivative must be 0, 1 or 2")
        x = np.atleast_1d(np.asarray(x_m, dtype=float))
        values = self._splines[derivative](x)
        if np.isnan(values).any():
            raise ValueError(f"points must lie in [0, {self.length_m}] m")
        return values


def gauss_points(breakpoints_m: np.ndarray, points_per_interval: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes (m) and weights (m) on each interval between sorted breakpoints.

    Four points integrate polynomials of degree 7 exactly: products of two cubics on each
    element, times a property constant on it.
    """
    nodes, weights = np.polynomial.legendre.leggauss(points_per_interval)
    left, right = breakpoints_m[:-1, None], breakpoints_m[1:, None]
    half = 0.5 * (right - left)
    x = (left + right) * 0.5 + half * nodes[None, :]
    w = half * weights[None, :]
    return x.ravel(), w.ravel()
