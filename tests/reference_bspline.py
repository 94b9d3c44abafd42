"""Modified cubic B-splines on a uniform mesh of [0, L] (Smith, *Smart Material Systems*, ch. 7–8).

The standard cubic B-splines B_j(x) = B((x - j h) / h), j = -1, ..., N+1, span the C² cubics on
N uniform intervals of width h = L/N. Three of them are non-zero at the root x = 0. Combining
them so that the essential boundary conditions hold gives the modified basis:

* rigid clamp, w(0) = w'(0) = 0: phi_0 = B_0 - 2 B_{-1} - 2 B_1 and phi_i = B_{i+1}, i = 1..N
  (N + 1 functions);
* compliant clamp, w(0) = 0 only: B_0 - 4 B_{-1}, B_1 - B_{-1} and B_2..B_{N+1} (N + 2 functions),
  so that the root rotation stays free and a rotational spring can act on it.

The free end needs no modification (its conditions are natural).

The model no longer uses this module: :mod:`beam.physics.basis` builds the same space of functions on
:class:`scipy.interpolate.BSpline` (``knots = "uniform"``) and, by default, adds double knots at
the patch ends. This hand-written version stays as an independent reference of Smith's basis
(``tests/test_physics_modes.py`` checks that both give the same frequencies).
"""

from __future__ import annotations

import numpy as np


def cardinal_cubic_bspline(s: np.ndarray, derivative: int = 0) -> np.ndarray:
    """The cardinal cubic B-spline B(s), support [-2, 2], or its first or second derivative in s.

    B(0) = 2/3, B(±1) = 1/6, and the B(s - j) sum to one.
    """
    s = np.asarray(s, dtype=float)
    a = np.abs(s)
    inner = a <= 1.0
    outer = (a > 1.0) & (a < 2.0)
    out = np.zeros_like(s)
    if derivative == 0:
        out[inner] = 2.0 / 3.0 - a[inner] ** 2 + 0.5 * a[inner] ** 3
        out[outer] = (2.0 - a[outer]) ** 3 / 6.0
    elif derivative == 1:
        out[inner] = -2.0 * s[inner] + 1.5 * s[inner] * a[inner]
        out[outer] = -np.sign(s[outer]) * 0.5 * (2.0 - a[outer]) ** 2
    elif derivative == 2:
        out[inner] = -2.0 + 3.0 * a[inner]
        out[outer] = 2.0 - a[outer]
    else:
        raise ValueError("derivative must be 0, 1 or 2")
    return out


class ModifiedCubicBasis:
    """The modified cubic B-spline basis of a cantilever.

    Parameters
    ----------
    length_m : float
        Beam length L (m).
    intervals : int
        Number N of uniform intervals (at least 2).
    free_root_rotation : bool
        False: rigid clamp, N + 1 functions with phi(0) = phi'(0) = 0.
        True: compliant clamp, N + 2 functions with phi(0) = 0 only.
    """

    def __init__(self, length_m: float, intervals: int, free_root_rotation: bool = False) -> None:
        if int(intervals) != intervals or intervals < 2:
            raise ValueError(f"intervals must be an integer >= 2, got {intervals!r}")
        self.length_m = float(length_m)
        self.intervals = int(intervals)
        self.spacing_m = self.length_m / self.intervals
        self.free_root_rotation = bool(free_root_rotation)
        n_standard = self.intervals + 3  # B_{-1} .. B_{N+1}
        if free_root_rotation:
            rows = [np.eye(n_standard)[1] - 4.0 * np.eye(n_standard)[0],  # B_0 - 4 B_{-1}
                    np.eye(n_standard)[2] - np.eye(n_standard)[0]]  # B_1 - B_{-1}
        else:
            rows = [np.eye(n_standard)[1] - 2.0 * np.eye(n_standard)[0] - 2.0 * np.eye(n_standard)[2]]
        rows.extend(np.eye(n_standard)[3:])  # B_2 .. B_{N+1}
        #: Combination matrix T (size, N + 3): phi = T @ [B_{-1}, ..., B_{N+1}].
        self.combination = np.array(rows)
        self._centres = np.arange(-1, self.intervals + 2)

    @property
    def size(self) -> int:
        """Number of basis functions (N + 1, or N + 2 with a free root rotation)."""
        return self.combination.shape[0]

    def evaluate(self, x_m: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Values (or x-derivatives) of every basis function at points ``x_m``: shape (len(x), size)."""
        x = np.atleast_1d(np.asarray(x_m, dtype=float))
        s = x[:, None] / self.spacing_m - self._centres[None, :]
        standard = cardinal_cubic_bspline(s, derivative) / self.spacing_m**derivative
        return standard @ self.combination.T
