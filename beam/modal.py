"""Fast linear response by modal truncation with exact zero-order-hold (ZOH) stepping.

Pure, batched functions (leading axis B = parameter sets, e.g. emcee walkers):

1. :func:`undamped_modes` — the generalised eigenproblem K v = omega² M v for a stack of (M, K),
   by Cholesky whitening and a symmetric eigensolver; mass-normalised shapes.
2. :func:`complex_modes` — the retained subspace in first-order form x = [eta, eta'],
   x' = A x + b u, with the full (possibly non-proportional) reduced damping matrix, diagonalised
   A = V diag(lambda) V⁻¹ (in closed form when the reduced damping is diagonal). Damping is
   therefore exact for what is retained.
3. :func:`zoh_response` — each complex mode is a scalar ODE xi' = lambda xi + u; with u held over
   each sample the exact update is xi[k+1] = z xi[k] + (z - 1)/lambda u[k], z = exp(lambda dt),
   stepped from rest in compiled code (numba); conjugate pairs are stepped once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np


def undamped_modes(mass: np.ndarray, stiffness: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve K v = omega² M v for stacked symmetric (M, K) of shape (B, n, n).

    Returns
    -------
    omega_squared : (B, n) ascending eigenvalues omega² (rad²/s²).
    shapes : (B, n, n) mass-normalised mode shapes as columns (shapes.T M shapes = I).
    """
    chol = np.linalg.cholesky(mass)
    chol_inv = np.linalg.inv(chol)
    whitened = chol_inv @ stiffness @ np.swapaxes(chol_inv, -1, -2)
    whitened = 0.5 * (whitened + np.swapaxes(whitened, -1, -2))
    omega_squared, vectors = np.linalg.eigh(whitened)
    shapes = np.swapaxes(chol_inv, -1, -2) @ vectors
    return omega_squared, shapes


@dataclass(frozen=True)
class ComplexModes:
    """Diagonalised first-order modal system, batched over B parameter sets.

    Attributes
    ----------
    poles : (B, 2m) complex eigenvalues lambda (1/s); conjugate pairs adjacent, Im > 0 first.
    input_gains : (B, n_in, 2m) complex; V⁻¹ [0, f_r] for each reduced force f_r.
    output_gains : (B, n_out, 2m) complex; [c_r, 0] V for each displacement output row c_r.
    """

    poles: np.ndarray
    input_gains: np.ndarray
    output_gains: np.ndarray


def complex_modes(
    omega_squared: np.ndarray, reduced_damping: np.ndarray, reduced_inputs: np.ndarray, reduced_outputs: np.ndarray
) -> ComplexModes:
    """Diagonalise eta'' + C_r eta' + diag(omega²) eta = f_r u for each of B parameter sets.

    Parameters
    ----------
    omega_squared : (B, m)  retained undamped omega² (rad²/s²).
    reduced_damping : (B, m, m)  shapes.T C shapes (1/s).
    reduced_inputs : (B, n_in, m)  reduced force vectors (shapes.T f).
    reduced_outputs : (B, n_out, m)  displacement output rows (c @ shapes).

    Notes
    -----
    With a diagonal C_r (proportional damping) each mode is a 2x2 block with eigenvectors
    [1, lambda] and poles -c/2 ± sqrt(c²/4 - omega²), in closed form. Otherwise the real 2m x 2m
    matrix goes to LAPACK's dgeev, which returns conjugate pairs adjacent, Im > 0 first.
    """
    batch, m = omega_squared.shape
    diagonal = np.einsum("bii->bi", reduced_damping)
    if np.count_nonzero(reduced_damping) == np.count_nonzero(diagonal):
        half = 0.5 * diagonal
        root = np.sqrt((half * half - omega_squared).astype(complex))  # Im >= 0 when underdamped
        upper, lower = -half + root, -half - root
        poles = np.stack([upper, lower], axis=-1).reshape(batch, 2 * m)
        gap = (lower - upper)[:, None, :]
        input_gains = np.stack([-reduced_inputs / gap, reduced_inputs / gap], axis=-1).reshape(batch, -1, 2 * m)
        output_gains = np.repeat(reduced_outputs.astype(complex), 2, axis=-1)
        return ComplexModes(poles, input_gains, output_gains)
    system = np.zeros((batch, 2 * m, 2 * m))
    system[:, :m, m:] = np.eye(m)
    system[:, m:, :m] = -omega_squared[:, :, None] * np.eye(m)
    system[:, m:, m:] = -reduced_damping
    poles, vectors = np.linalg.eig(system)
    rhs = np.zeros((batch, 2 * m, reduced_inputs.shape[1]))
    rhs[:, m:, :] = np.swapaxes(reduced_inputs, 1, 2)
    input_gains = np.swapaxes(np.linalg.solve(vectors, rhs), 1, 2)
    output_gains = reduced_outputs @ vectors[:, :m, :]
    return ComplexModes(poles, input_gains, output_gains)


def modal_response(
    omega_squared: np.ndarray,
    reduced_damping: np.ndarray,
    reduced_force: np.ndarray,
    reduced_output: np.ndarray,
    sample_interval_s: float,
    voltage: np.ndarray,
    static_gain: np.ndarray | None = None,
) -> np.ndarray:
    """Displacement output y (B, n) of the retained modes under a ZOH voltage, from rest.

    ``static_gain`` (B,), when given, adds static_gain x V[k] to every sample (the static
    correction of the discarded modes), inside the compiled loop.

    The fast path of :func:`complex_modes` + :func:`zoh_response` for one input and one output:
    poles and residues come from the symmetric quadratic eigenproblem
    (lambda² I + lambda C_r + diag(omega²)) v = 0, solved per mode in compiled code by
    two-sided Rayleigh-functional iteration from the proportional-damping estimate (cubic
    convergence, to round-off), with residues r = (c·v)(v·f) / (vᵀ (2 lambda I + C_r) v). Any
    parameter set where the iteration does not settle on m distinct poles is redone with
    LAPACK (:func:`complex_modes`).
    """
    omega_squared = np.ascontiguousarray(omega_squared, dtype=float)
    reduced_damping = np.ascontiguousarray(reduced_damping, dtype=float)
    reduced_force = np.ascontiguousarray(reduced_force, dtype=float)
    reduced_output = np.ascontiguousarray(reduced_output, dtype=float)
    poles, residues, ok = _quadratic_modes(omega_squared, reduced_damping, reduced_force, reduced_output)
    voltage = np.ascontiguousarray(voltage, dtype=float)
    static = np.zeros(poles.shape[0]) if static_gain is None else np.ascontiguousarray(static_gain, dtype=float)
    out = _step_pairs(poles, residues, float(sample_interval_s), voltage, static)
    bad = ~ok
    if bad.any():
        fallback = complex_modes(
            omega_squared[bad], reduced_damping[bad], reduced_force[bad][:, None, :], reduced_output[bad][:, None, :]
        )
        out[bad] = zoh_response(
            fallback.poles, fallback.output_gains[:, 0] * fallback.input_gains[:, 0], sample_interval_s, voltage
        ) + static[bad, None] * voltage
    return out


@numba.njit(cache=True, nogil=True)
def _solve_small(a, b):  # pragma: no cover - jitted
    """Solve a x = b for a small complex matrix by Gaussian elimination with partial pivoting."""
    n = a.shape[0]
    a = a.copy()
    x = b.copy()
    for col in range(n):
        pivot = col
        for row in range(col + 1, n):
            if abs(a[row, col]) > abs(a[pivot, col]):
                pivot = row
        if pivot != col:
            for k in range(n):
                a[col, k], a[pivot, k] = a[pivot, k], a[col, k]
            x[col], x[pivot] = x[pivot], x[col]
        diag = a[col, col]
        if diag == 0:
            diag = 1e-300
        for row in range(col + 1, n):
            factor = a[row, col] / diag
            if factor != 0:
                for k in range(col, n):
                    a[row, k] -= factor * a[col, k]
                x[row] -= factor * x[col]
    for col in range(n - 1, -1, -1):
        acc = x[col]
        for k in range(col + 1, n):
            acc -= a[col, k] * x[k]
        diag = a[col, col]
        x[col] = acc / (diag if diag != 0 else 1e-300)
    return x


@numba.njit(cache=True, nogil=True)
def _quadratic_modes(omega2, damping, force, output):  # pragma: no cover - jitted
    """Upper poles (Im >= 0) and residues per mode; ok[b] False where the iteration failed."""
    batch, m = omega2.shape
    poles = np.zeros((batch, m), np.complex128)
    residues = np.zeros((batch, m), np.complex128)
    ok = np.ones(batch, np.bool_)
    q = np.zeros((m, m), np.complex128)
    for b in range(batch):
        for i in range(m):
            half = 0.5 * damping[b, i, i]
            disc = complex(half * half - omega2[b, i])
            root = np.sqrt(disc)
            lam = -half + root
            if lam.imag < 0:
                lam = -half - root
            if lam.imag <= 0:  # overdamped or rigid: leave it to LAPACK
                ok[b] = False
                break
            v = np.zeros(m, np.complex128)
            v[i] = 1.0
            converged = False
            for _ in range(30):
                for r in range(m):
                    for c in range(m):
                        q[r, c] = lam * damping[b, r, c]
                    q[r, r] += lam * lam + omega2[b, r]
                dq_v = np.empty(m, np.complex128)
                for r in range(m):
                    acc = 2.0 * lam * v[r]
                    for c in range(m):
                        acc += damping[b, r, c] * v[c]
                    dq_v[r] = acc
                x = _solve_small(q, dq_v)
                norm = np.sqrt(np.sum(np.abs(x) ** 2))
                if not np.isfinite(norm) or norm == 0:
                    break
                v = x / norm
                # Rayleigh functional: root of v^T Q(lambda) v = 0 closest to the current lambda
                a2 = np.sum(v * v)
                a1 = 0j
                a0 = 0j
                for r in range(m):
                    a0 += v[r] * v[r] * omega2[b, r]
                    for c in range(m):
                        a1 += v[r] * damping[b, r, c] * v[c]
                disc = np.sqrt(a1 * a1 - 4.0 * a2 * a0)
                first = (-a1 + disc) / (2.0 * a2)
                second = (-a1 - disc) / (2.0 * a2)
                new = first if abs(first - lam) <= abs(second - lam) else second
                step = abs(new - lam)
                lam = new
                if step <= 1e-14 * abs(lam):
                    converged = True
                    break
            if not converged or lam.imag <= 0:
                ok[b] = False
                break
            denom = 0j
            cv = 0j
            vf = 0j
            for r in range(m):
                acc = 2.0 * lam * v[r]
                for c in range(m):
                    acc += damping[b, r, c] * v[c]
                denom += v[r] * acc
                cv += output[b, r] * v[r]
                vf += v[r] * force[b, r]
            poles[b, i] = lam
            residues[b, i] = cv * vf / denom
        if ok[b]:  # the m poles must be distinct modes
            for i in range(m):
                for j in range(i + 1, m):
                    if abs(poles[b, i] - poles[b, j]) <= 1e-8 * abs(poles[b, i]):
                        ok[b] = False
    return poles, residues, ok


def zoh_response(poles: np.ndarray, residues: np.ndarray, sample_interval_s: float, voltage: np.ndarray) -> np.ndarray:
    """Output y (B, n) of the transfer function sum_j residues_j / (s - poles_j) under ZOH, from rest.

    Each mode is stepped exactly: xi_j[k+1] = z_j xi_j[k] + (z_j - 1)/lambda_j u[k],
    z_j = exp(lambda_j dt), y[k] = Re sum_j residues_j xi_j[k]. Poles must come as from
    :func:`complex_modes` (conjugate pairs adjacent, Im > 0 first): pairs are stepped once.
    """
    return _step_modes(
        np.ascontiguousarray(poles), np.ascontiguousarray(residues), float(sample_interval_s),
        np.ascontiguousarray(voltage, dtype=float),
    )


@numba.njit(cache=True, nogil=True)
def zoh_factor(pole, dt):  # pragma: no cover - jitted
    """(exp(lambda dt) - 1) / lambda, continuous at lambda = 0 (series for small |lambda dt|)."""
    x = pole * dt
    if abs(x) < 1e-4:
        return dt * (1.0 + x * (0.5 + x / 6.0))
    return (np.exp(x) - 1.0) / pole


@numba.njit(cache=True, nogil=True)
def _step_modes(poles, residues, dt, voltage):  # pragma: no cover - jitted
    """ZOH stepping of poles as returned by :func:`complex_modes` (pairs adjacent, Im > 0 first)."""
    batch, n_poles = poles.shape
    upper = np.zeros((batch, n_poles), np.complex128)
    weights = np.zeros((batch, n_poles), np.complex128)
    for b in range(batch):
        count = 0
        j = 0
        while j < n_poles:
            pole = poles[b, j]
            if pole.imag > 0 and j + 1 < n_poles and abs(poles[b, j + 1] - np.conj(pole)) <= 1e-12 * abs(pole):
                upper[b, count] = pole  # the conjugate's contribution is the complex conjugate
                weights[b, count] = 2.0 * residues[b, j]
                j += 2
            else:
                upper[b, count] = pole
                weights[b, count] = residues[b, j]
                j += 1
            count += 1
    return _step(upper, weights, dt, voltage, np.zeros(batch))


@numba.njit(cache=True, nogil=True)
def _step_pairs(poles, residues, dt, voltage, static):  # pragma: no cover - jitted
    """ZOH stepping of upper poles only, each standing for a conjugate pair (weight doubled),
    plus static[b] x V[k]."""
    return _step(poles, 2.0 * residues, dt, voltage, static)


@numba.njit(cache=True, nogil=True)
def _step(poles, weights, dt, voltage, static):  # pragma: no cover - jitted
    """y[b, k] = Re sum_j weights_j xi_j[k] + static[b] u[k], xi_j[k+1] = z_j xi_j[k] + (z_j - 1)/lambda_j u[k].

    A zero weight skips its pole (unused slots).
    """
    batch, n_poles = poles.shape
    n = voltage.shape[0]
    out = np.zeros((batch, n))
    z = np.empty(n_poles, np.complex128)
    w = np.empty(n_poles, np.complex128)
    xi = np.empty(n_poles, np.complex128)
    for b in range(batch):
        for j in range(n_poles):
            z[j] = np.exp(poles[b, j] * dt)
            w[j] = weights[b, j] * zoh_factor(poles[b, j], dt)
            xi[j] = 0j
        gain = static[b]
        for k in range(n):
            uk = voltage[k]
            acc = gain * uk
            for j in range(n_poles):
                x = xi[j]
                acc += w[j].real * x.real - w[j].imag * x.imag
                xi[j] = z[j] * x + uk
            out[b, k] = acc
    return out
