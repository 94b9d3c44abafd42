"""Independent references for the beam tests: closed-form characteristic equations and a
transfer-matrix solution of a stepped Euler–Bernoulli beam (a second method, no B-splines)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

#: beta_n L of the clamped-free uniform beam.
CANTILEVER_BETA_L = np.array([1.875104, 4.694091, 7.854757, 10.995541])
#: beta_n L of the pinned-free beam (beside its rigid-body mode).
PINNED_FREE_BETA_L = np.array([3.9266, 7.0686, 10.2102])


def bracket_roots(function, low: float, high: float, count: int, grid: int = 4000) -> np.ndarray:
    """First ``count`` sign-change roots of ``function`` on [low, high], refined by brentq."""
    x = np.linspace(low, high, grid)
    values = np.array([function(v) for v in x])
    roots = []
    for i in range(grid - 1):
        if np.sign(values[i]) != np.sign(values[i + 1]):
            roots.append(brentq(function, x[i], x[i + 1], xtol=1e-14))
            if len(roots) == count:
                break
    return np.array(roots)


def cantilever_beta_l(count: int = 4) -> np.ndarray:
    """beta_n L of the clamped-free uniform beam to round-off: roots of 1 + cos cosh = 0."""
    return bracket_roots(lambda b: 1 + np.cos(b) * np.cosh(b), 0.5, 3.5 * count, count)


def tip_mass_beta_l(mass_ratio: float, count: int = 4) -> np.ndarray:
    """Roots of 1 + cos cosh + (m_t / rho L) bL (cos sinh − sin cosh) = 0."""

    def equation(b):
        return 1 + np.cos(b) * np.cosh(b) + mass_ratio * b * (np.cos(b) * np.sinh(b) - np.sin(b) * np.cosh(b))

    return bracket_roots(equation, 0.1, 14.0, count)


def clamp_spring_beta_l(kappa: float, count: int = 4) -> np.ndarray:
    """beta L of a beam with W(0) = 0, EI W''(0) = k W'(0) (kappa = k L / EI), free at L."""

    def determinant(b):
        c, s, ch, sh = np.cos(b), np.sin(b), np.cosh(b), np.sinh(b)
        rows = [[1, 0, 1, 0], [-b, -kappa, b, -kappa], [-c, -s, ch, sh], [s, -c, sh, ch]]
        return np.linalg.det(np.array(rows, dtype=float))

    return bracket_roots(determinant, 0.05, 14.0, count)


def _segment_transfer(omega: float, bending_stiffness: float, density: float, length: float) -> np.ndarray:
    """Maps [W, W', EI W'', (EI W'')'] across a uniform segment."""
    beta = (density * omega**2 / bending_stiffness) ** 0.25

    def basis(s):
        bs = beta * s
        c, sn, ch, sh = np.cos(bs), np.sin(bs), np.cosh(bs), np.sinh(bs)
        ei = bending_stiffness
        return np.array([
            [c, sn, ch, sh],
            [-beta * sn, beta * c, beta * sh, beta * ch],
            [-ei * beta**2 * c, -ei * beta**2 * sn, ei * beta**2 * ch, ei * beta**2 * sh],
            [ei * beta**3 * sn, -ei * beta**3 * c, ei * beta**3 * sh, ei * beta**3 * ch],
        ])

    return basis(length) @ np.linalg.inv(basis(0.0))


def stepped_beam_frequencies_Hz(segments: list[tuple[float, float, float]], count: int, omega_max: float) -> np.ndarray:
    """Clamped-free natural frequencies (Hz) of segments [(EI, rho, length), ...] from the root."""

    def determinant(omega):
        transfer = np.eye(4)
        for bending_stiffness, density, length in segments:
            transfer = _segment_transfer(omega, bending_stiffness, density, length) @ transfer
        return np.linalg.det(transfer[2:, 2:])  # free end: moment and shear vanish

    return bracket_roots(determinant, 1e-3, omega_max, count, grid=20000) / (2 * np.pi)


def mass_spring_determinant(bending_stiffness: float, density: float, length: float, *,
                            clamp_stiffness: float = np.inf, mass: float = 0.0, mass_at: float | None = None):
    """The characteristic determinant D(omega) of a uniform cantilever (EI N m², rho kg/m, L m) held
    at the root by a rotational spring k_theta (N m/rad; ``inf``: a rigid clamp), with a point mass
    (kg, translation only) at ``mass_at`` (m from the root; default the tip): the transfer matrix of
    [W, W', EI W'', (EI W'')'] across the two uniform segments and the mass's point matrix (the shear
    jumps by m omega² W there), the root's state W = 0, EI W'' = k_theta W' (two unknowns: W'(0) and
    the root's shear, or EI W''(0) and the shear for a rigid clamp), the free end's moment and shear
    zero: the 2 x 2 determinant of those two conditions; its roots are the natural frequencies."""
    where = length if mass_at is None else float(mass_at)

    def determinant(omega):
        root = (np.array([[0, 0], [1, 0], [clamp_stiffness, 0], [0, 1]], dtype=float) if np.isfinite(clamp_stiffness)
                else np.array([[0, 0], [0, 0], [1, 0], [0, 1]], dtype=float))
        state = _segment_transfer(omega, bending_stiffness, density, where) @ root
        point = np.eye(4)
        point[3, 0] = mass * omega**2
        state = _segment_transfer(omega, bending_stiffness, density, length - where) @ (point @ state)
        return np.linalg.det(state[2:, :])  # free end: moment and shear vanish

    return determinant


def cantilever_mass_spring_frequencies_Hz(bending_stiffness: float, density: float, length: float, *,
                                          clamp_stiffness: float = np.inf, mass: float = 0.0,
                                          mass_at: float | None = None, count: int = 3,
                                          omega_max: float | None = None) -> np.ndarray:
    """The first ``count`` exact natural frequencies (Hz) of :func:`mass_spring_determinant`'s beam:
    its sign changes on a grid up to ``omega_max`` (default above the count-th mode of the
    clamped-free beam without the mass), refined by brentq."""
    if omega_max is None:
        beta_l = (count + 0.5) * np.pi
        omega_max = beta_l**2 * np.sqrt(bending_stiffness / (density * length**4))
    determinant = mass_spring_determinant(bending_stiffness, density, length, clamp_stiffness=clamp_stiffness,
                                          mass=mass, mass_at=mass_at)
    return bracket_roots(determinant, 1e-3, omega_max, count, grid=400 * (count + 1)) / (2 * np.pi)
