"""Fast linear response by modal truncation with exact zero-order-hold (ZOH) stepping.

Pure, batched functions (leading axis B = parameter sets, e.g. emcee walkers):

1. :func:`undamped_modes` — the generalised eigenproblem K v = omega² M v for a stack of (M, K),
   inverted (Cholesky whitening by K + sigma M, a symmetric eigensolver for 1/omega²) so that the
   low modes are accurate relative to their own size; mass-normalised shapes.
2. :func:`complex_modes` — the retained subspace in first-order form x = [eta, eta'],
   x' = A x + b u, with the full (possibly non-proportional) reduced damping matrix, diagonalised
   A = V diag(lambda) V⁻¹ (in closed form when the reduced damping is diagonal). Damping is
   therefore exact for what is retained.
3. :func:`zoh_response` — each complex mode is a scalar ODE xi' = lambda xi + u; with u held over
   each sample the exact update is xi[k+1] = z xi[k] + (z - 1)/lambda u[k], z = exp(lambda dt),
   stepped from rest in compiled code (numba); conjugate pairs are stepped once.
4. :func:`scale_unit_modes` and :func:`cached_modes_response` — the warm path of
   :meth:`beam.physics.model.BeamModel.response`: cached unit-scale shapes rescaled to each parameter
   set, poles and residues by a compiled Rayleigh-functional iteration, and ZOH stepping, in one
   compiled call (validated against 2. and 3. and against the full state space in the tests).
5. :func:`modal_poles_and_weights`, :func:`derivative_weights` and :func:`zoh_response_at` — the
   same modes for any output and irregular time stamps: the input held over each recorded
   interval [t_k, t_k+1) of its own length dt_k, stepped exactly with z_k = exp(lambda dt_k).
6. :func:`modal_decomposition` and :func:`free_basis` — free responses, exact at any times.
7. :func:`ritz_basis`, :func:`ritz_modes`, :func:`ritz_static` — the low modes of many nearby
   members of a family M = sum a_t M_t, K = sum b_t K_t (the walkers of a posterior) from one
   Rayleigh–Ritz subspace, with a residual bound on each mode's error; :func:`perturbed_modes` —
   first-order modes of a finite-difference stencil's points from their centre's.

Outputs
-------
With the modal states xi_j' = lambda_j xi_j + u (one per pole, residues r_j for the sensor's
displacement, G(s) = sum_j r_j / (s - lambda_j)), the sensor's

* displacement is sum_j r_j xi_j;
* velocity is s G(s) = sum_j r_j lambda_j / (s - lambda_j) + sum_j r_j, and sum_j r_j = 0
  (the displacement has no feed-through): residues r_j lambda_j, no direct term;
* acceleration is s² G(s) = sum_j r_j lambda_j² / (s - lambda_j) + sum_j r_j lambda_j: residues
  r_j lambda_j², and the direct term sum_j r_j lambda_j = c_r · f_r, the retained modes' own
  feed-through c Phi_r Phi_r^T f (their acceleration answers the force at once, eta'' = f_r u - ...).

A collapsed conjugate pair (Im lambda > 0 kept, weight 2 r) gives the same with Re taken.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

#: Shift of :func:`undamped_modes` when K may be singular, relative to the largest diagonal
#: ratio K_ii / M_ii (<= the largest omega²): far above round-off (K + sigma M stays positive
#: definite), far below the first flexible mode's omega² on any mesh of up to 400 elements.
RELATIVE_SHIFT = 1e-8


def undamped_modes(mass: np.ndarray, stiffness: np.ndarray, shift: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Solve K v = omega² M v for stacked symmetric (M, K) of shape (B, n, n).

    Solved inverted, so that the low modes are accurate to round-off relative to *their own*
    size: with the Cholesky factor C of K + sigma M, the symmetric eigenproblem of C⁻¹ M C⁻ᵀ
    gives mu = 1 / (omega² + sigma), largest first. A symmetric eigensolver is accurate to
    round-off of the largest eigenvalue; whitened by M instead (K's eigenproblem), the largest
    is omega²_max, 1e10 times omega²_1 on 40 elements: the B1TAPIH response then moved by
    round-off of 1.7e-8 of its size as the tip mass changed by steps of 1e-5, which spoiled the
    Newton steps and Hessians of tip-mass calibrations; inverted, 5e-12
    (tests/test_physics_response.py, the smooth-response test).

    sigma is 0 unless ``shift`` (K may be singular: a free root with a soft clamp, whose
    rigid-body mode then comes out with omega² ~ 0) or K is not numerically positive definite
    (its Cholesky factorisation fails); then sigma = :data:`RELATIVE_SHIFT` max_i(K_ii / M_ii).
    A shift costs accuracy in proportion to sigma / omega²_1 (the same measure with the B1TAPIH
    patch stiffness as the parameter: 2e-9 shifted, 2e-10 not), hence not always.

    Returns
    -------
    omega_squared : (B, n) ascending eigenvalues omega² (rad²/s²).
    shapes : (B, n, n) mass-normalised mode shapes as columns (shapes.T M shapes = I).
    """
    ratios = np.diagonal(stiffness, axis1=-2, axis2=-1) / np.diagonal(mass, axis1=-2, axis2=-1)
    shifted = RELATIVE_SHIFT * ratios.max(axis=-1)
    sigma = shifted if shift else np.zeros_like(shifted)
    try:
        chol = np.linalg.cholesky(stiffness + sigma[:, None, None] * mass)
    except np.linalg.LinAlgError:
        if shift:
            raise
        sigma = shifted
        chol = np.linalg.cholesky(stiffness + sigma[:, None, None] * mass)
    chol_inv = _lower_inverse(chol)
    whitened = chol_inv @ mass @ np.swapaxes(chol_inv, -1, -2)
    whitened = 0.5 * (whitened + np.swapaxes(whitened, -1, -2))
    mu, vectors = _symmetric_eigen(whitened)
    mu, vectors = mu[:, ::-1], vectors[:, :, ::-1]  # largest mu first: lowest omega² first
    omega_squared = 1.0 / mu - sigma[:, None]
    shapes = (np.swapaxes(chol_inv, -1, -2) @ vectors) / np.sqrt(mu)[:, None, :]
    return omega_squared, shapes


def _lower_inverse(lower: np.ndarray) -> np.ndarray:
    """Inverses of a stack of lower-triangular matrices (B, n, n): LAPACK ``dtrtri`` one matrix
    at a time (measured, 100 matrices of 43 x 43: 0.7 ms against 2.4 ms for the general batched
    :func:`numpy.linalg.inv`, the same to 2e-17)."""
    from scipy.linalg import lapack

    out = np.empty_like(lower)
    for b in range(lower.shape[0]):
        inverse, info = lapack.dtrtri(lower[b], lower=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"triangular inverse failed (LAPACK dtrtri info {info})")
        out[b] = inverse  # the upper triangle stays as given (zero from numpy.linalg.cholesky)
    return out


def _symmetric_eigen(stack: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and eigenvectors of a stack of symmetric matrices (B, n, n).

    LAPACK ``dsyevd`` one matrix at a time with its minimal workspace, not
    :func:`numpy.linalg.eigh`: with OpenBLAS's threads, two Python threads solving 64 matrices
    of 43 x 43 at once took 118 ms with numpy against 15 ms so (numpy's optimal workspace runs
    the blocked, threaded reduction, which contends on 2 cores); one thread alone, 7 ms both.
    """
    from scipy.linalg import lapack

    batch, n = stack.shape[0], stack.shape[1]
    values, vectors = np.empty((batch, n)), np.empty((batch, n, n))
    for b in range(batch):
        w, v, info = lapack.dsyevd(stack[b], compute_v=1, lwork=1 + 6 * n + 2 * n * n, liwork=3 + 5 * n)
        if info != 0:
            raise np.linalg.LinAlgError(f"symmetric eigensolver failed (LAPACK dsyevd info {info})")
        values[b], vectors[b] = w, v
    return values, vectors


@dataclass(frozen=True)
class RankOneFactorisation:
    """The undamped eigenproblem K v = omega² (M0 + alpha s sᵀ) v reduced once for every alpha
    (see :func:`rank_one_factorisation`): P orthogonal with Pᵀ C⁻¹ (M0 + alpha s sᵀ) C⁻ᵀ P =
    T0 + alpha |C⁻¹ s|² e1 e1ᵀ, T0 symmetric tridiagonal, K = C Cᵀ.

    Attributes
    ----------
    diagonal : (n,) diagonal of T0 (1/(rad²/s²) for unit coefficients).
    off_diagonal : (n,) its sub-diagonal, padded with one zero (LAPACK ``dstemr``'s layout).
    weight : float
        |C⁻¹ s|²: alpha times it is added to T0[0, 0].
    back : (n, n)
        C⁻ᵀ P: a unit eigenvector y of the tridiagonal matrix with eigenvalue mu gives the
        mass-normalised shape back @ y / sqrt(mu).
    eigenvalues : (n,) ascending eigenvalues lambda of T0 (LAPACK ``dstev``).
    first_row : (n,) z = Yᵀ e1, the first components of T0's unit eigenvectors Y.
    eigenvectors : (n, n) Y.
    back_eigen : (n, n) back @ Y: a unit eigenvector w of diag(lambda) + rho z zᵀ gives the
        shape back_eigen @ w / sqrt(mu).
    """

    diagonal: np.ndarray
    off_diagonal: np.ndarray
    weight: float
    back: np.ndarray
    eigenvalues: np.ndarray
    first_row: np.ndarray
    eigenvectors: np.ndarray
    back_eigen: np.ndarray


def rank_one_factorisation(mass: np.ndarray, stiffness: np.ndarray, vector: np.ndarray) -> RankOneFactorisation:
    """Reduce K v = omega² (M0 + alpha s sᵀ) v, for every alpha at once, to a tridiagonal
    matrix whose one (0, 0) entry depends on alpha.

    In the whitened, inverted form of :func:`undamped_modes` (sigma = 0) the matrix is
    W(alpha) = C⁻¹ M0 C⁻ᵀ + alpha u uᵀ, u = C⁻¹ s. A Householder reflection H maps u to a
    multiple of e1; the Hessenberg (here tridiagonal, W being symmetric) reduction Q of H W0 H
    leaves e1 in place (its reflectors act on rows 2..n), so with P = H Q,
    Pᵀ W(alpha) P = T0 + alpha |u|² e1 e1ᵀ: exact in alpha, one factorisation for every
    value of a point mass (the sensor's or the tip's).

    Parameters
    ----------
    mass : (n, n) M0, the mass matrix without the point mass.
    stiffness : (n, n) K, symmetric positive definite.
    vector : (n,) s, the point mass's row (M = M0 + alpha s sᵀ).

    Raises
    ------
    numpy.linalg.LinAlgError
        When K is not numerically positive definite (then :func:`undamped_modes` shifts it).
    """
    from scipy.linalg import hessenberg, lapack

    chol_inv = np.linalg.inv(np.linalg.cholesky(stiffness))
    whitened = chol_inv @ mass @ chol_inv.T
    whitened = 0.5 * (whitened + whitened.T)
    u = chol_inv @ np.asarray(vector, dtype=float)
    norm = float(np.linalg.norm(u))
    n = u.size
    reflector = u.copy()
    reflector[0] += math.copysign(norm, u[0]) if norm > 0 else 1.0
    householder = np.eye(n) - 2.0 * np.outer(reflector, reflector) / (reflector @ reflector)
    reflected = householder @ whitened @ householder
    reflected = 0.5 * (reflected + reflected.T)
    tridiagonal, q = hessenberg(reflected, calc_q=True)
    off = 0.5 * (np.diagonal(tridiagonal, -1) + np.diagonal(tridiagonal, 1))
    diagonal = np.ascontiguousarray(np.diagonal(tridiagonal))
    back = np.ascontiguousarray(chol_inv.T @ (householder @ q))
    values, eigen, info = lapack.dstev(diagonal.copy(), off.copy(), compute_v=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"tridiagonal eigensolver failed (LAPACK dstev info {info})")
    return RankOneFactorisation(diagonal, np.append(off, 0.0), norm * norm, back, values,
                                np.ascontiguousarray(eigen[0]), eigen, back @ eigen)


#: Iterations of the secular solver before its unsettled rows go to ``dstemr`` (it settles in 3-6).
SECULAR_ITERATIONS = 40


def rank_one_modes(factors: RankOneFactorisation, alpha: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` lowest undamped modes of K v = omega² (M0 + alpha_b s sᵀ) v for each alpha_b.

    The same modes as :func:`undamped_modes` (unshifted) from the tridiagonal reduction of
    :func:`rank_one_factorisation`: every row is T0 + rho e1 e1ᵀ (rho = alpha |C⁻¹ s|²), so with
    T0 = Y diag(lambda) Yᵀ (one LAPACK ``dstev`` in :func:`rank_one_factorisation`) each row is
    a rank-one update of a diagonal matrix whose eigenpairs solve the secular equation
    1/rho + sum_j z_j² / (lambda_j - mu) = 0, z = Yᵀ e1, mu = 1/omega² (:func:`_secular_largest`,
    compiled), then one product with the stored back-transformation. Rows with rho <= 0 (no
    point mass) or a root that did not settle take LAPACK ``dstemr`` (MRRR) on their
    tridiagonal matrix. Hand-written because a row costs 24 µs against 120-200 µs for the dense
    path (41 dof, 4 modes; the measurements: ``docs/decisions.md``, the linear model); the same
    modes as a dense ``scipy.linalg.eigh`` to round-off (tests/test_physics_rank_one.py). Only
    the retained modes are solved.

    Returns
    -------
    omega_squared : (B, count) ascending (rad²/s²).
    shapes : (B, n, count) mass-normalised shapes.
    """
    alpha = np.atleast_1d(np.asarray(alpha, dtype=float))
    n = factors.diagonal.size
    rho = alpha * factors.weight
    if not 0 < count <= n:
        raise np.linalg.LinAlgError(f"{count} modes of a {n}-dof tridiagonal matrix")
    if np.all(rho > 0.0):
        mu, eigen, settled = _secular_largest(factors, rho, count)
        if settled.all():
            return 1.0 / mu, np.matmul(factors.back_eigen, eigen) / np.sqrt(mu)[:, None, :]
        vectors = np.matmul(factors.eigenvectors, eigen)  # into the tridiagonal's basis
        pending = np.flatnonzero(~settled)
    else:
        mu, vectors = np.empty((alpha.size, count)), np.empty((alpha.size, n, count))
        pending = np.flatnonzero(~(rho > 0.0))  # no point mass (or not a number): dstemr decides
        positive = np.flatnonzero(rho > 0.0)
        if positive.size:
            values, eigen, settled = _secular_largest(factors, rho[positive], count)
            mu[positive], vectors[positive] = values, np.matmul(factors.eigenvectors, eigen)
            pending = np.sort(np.concatenate([pending, positive[~settled]]))
    _dstemr_rows(factors, alpha, count, pending, mu, vectors)
    shapes = (factors.back @ vectors) / np.sqrt(mu)[:, None, :]
    return 1.0 / mu, shapes


def _dstemr_rows(factors: RankOneFactorisation, alpha: np.ndarray, count: int, rows: np.ndarray, mu: np.ndarray,
                 vectors: np.ndarray) -> None:
    """Fill ``mu[b]`` (largest first) and ``vectors[b]`` (tridiagonal eigenvectors) for b in
    ``rows`` with LAPACK ``dstemr``, one row at a time."""
    from scipy.linalg import lapack

    n = factors.diagonal.size
    for b in rows:
        d = factors.diagonal.copy()  # dstemr overwrites both arrays
        d[0] += alpha[b] * factors.weight
        found, w, z, info = lapack.dstemr(d, factors.off_diagonal.copy(), 3, 0.0, 0.0, n - count + 1, n, compute_v=1)
        if info != 0 or found != count:
            raise np.linalg.LinAlgError(f"tridiagonal eigensolver failed (LAPACK dstemr info {info})")
        mu[b] = w[count - 1 :: -1]  # largest mu first: lowest omega² first
        vectors[b] = z[:, count - 1 :: -1]


def _secular_largest(factors: RankOneFactorisation, rho: np.ndarray, count: int
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``count`` largest eigenpairs of diag(lambda) + rho_b z zᵀ for every rho_b > 0
    (lambda and z of ``factors``).

    Root i of the secular function g(mu) = 1/rho + sum_j z_j² / (lambda_j - mu) (increasing)
    lies in (lambda_i, lambda_{i+1}), the largest in (lambda_{n-1}, lambda_{n-1} + rho |z|²).
    Each root is sought as mu = origin + tau from the nearer pole of its interval (so that
    lambda_j - mu, and with it the eigenvector z_j / (lambda_j - mu), keep their relative
    accuracy), by the two-pole rational model of the ``dlaed4`` family (the sums over the poles
    below and above matched in value and slope by c + d / (pole - tau), one quadratic per step),
    safeguarded by bisection of a bracket kept from the sign of g (compiled:
    :func:`_secular_kernel`).

    Returns
    -------
    mu : (B, count) largest first.
    vectors : (B, n, count) unit eigenvectors (coordinates in the basis of ``diag(lambda)``).
    settled : (B,) bool; rows whose roots did not converge must be solved another way.
    """
    lam, z = factors.eigenvalues, factors.first_row
    rho = np.ascontiguousarray(rho, dtype=float)
    mu = np.empty((rho.size, count))
    vectors = np.empty((rho.size, lam.size, count))
    settled = np.empty(rho.size, dtype=np.bool_)
    _secular_kernel(lam, z, rho, SECULAR_ITERATIONS, mu, vectors, settled)
    return mu, vectors, settled


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _secular_kernel(lam, z, rho, iterations, mu, vectors, settled):  # pragma: no cover - jitted
    """See :func:`_secular_largest`: roots and unit eigenvectors into ``mu`` and ``vectors``."""
    n = lam.size
    count = mu.shape[1]
    eps = np.finfo(np.float64).eps
    z_sq = z * z
    z_total = 0.0
    for j in range(n):
        z_total += z_sq[j]
    shift = np.empty(n)
    for b in range(rho.size):
        inv_rho = 1.0 / rho[b]
        ok = True
        for r in range(count):
            i = n - 1 - r
            last = i == n - 1
            lower = lam[i]
            gap = rho[b] * z_total if last else lam[i + 1] - lam[i]
            mid = 0.5 * gap
            g_mid = inv_rho
            for j in range(n):
                g_mid += z_sq[j] / ((lam[j] - lower) - mid)
            upper = (not last) and g_mid < 0.0
            origin = lam[i + 1] if upper else lower
            for j in range(n):
                shift[j] = lam[j] - origin
            if upper:
                lo, hi = -0.5 * gap, 0.0
            else:
                lo, hi = 0.0, (gap if last else mid)
            tau = 0.5 * (lo + hi)
            converged = False
            for _ in range(iterations):
                g = inv_rho
                bound = inv_rho
                psi = dpsi = phi = dphi = 0.0
                for j in range(n):
                    delta = shift[j] - tau
                    term = z_sq[j] / delta
                    g += term
                    bound += abs(term)
                    if j <= i:
                        psi += term
                        dpsi += term / delta
                    else:
                        phi += term
                        dphi += term / delta
                if abs(g) <= 8.0 * n * eps * bound:
                    converged = True
                    break
                if g > 0.0:
                    hi = min(hi, tau)
                elif g < 0.0:
                    lo = max(lo, tau)
                d_low = shift[i] - tau
                b_low = dpsi * d_low * d_low  # psi ~ a + b_low / (pole_low - x)
                w = inv_rho + psi - dpsi * d_low
                pole_low = shift[i]
                if last:
                    step = pole_low + b_low / w
                else:
                    d_up = shift[i + 1] - tau
                    d_high = dphi * d_up * d_up  # phi ~ c + d_high / (pole_up - x)
                    w += phi - dphi * d_up
                    pole_up = shift[i + 1]
                    span = pole_up - pole_low
                    if upper:
                        q = -w * span + b_low + d_high
                        step = pole_up - 2.0 * d_high * span / (q + math.sqrt(max(q * q + 4.0 * w * d_high * span, 0.0)))
                    else:
                        q = w * span + b_low + d_high
                        step = pole_low + 2.0 * b_low * span / (q + math.sqrt(max(q * q - 4.0 * w * b_low * span, 0.0)))
                if np.isfinite(step) and lo < step < hi:
                    tau = step
                else:
                    tau = 0.5 * (lo + hi)
            norm = 0.0
            for j in range(n):
                v = z[j] / (shift[j] - tau)
                vectors[b, j, r] = v
                norm += v * v
            norm = math.sqrt(norm)
            for j in range(n):
                vectors[b, j, r] /= norm
            mu[b, r] = origin + tau
            ok = ok and converged and np.isfinite(norm) and norm > 0.0 and mu[b, r] > 0.0
        settled[b] = ok


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


def cached_modes_response(
    which: np.ndarray,
    unit_modes: tuple[np.ndarray, ...],
    scales: np.ndarray,
    sample_interval_s: float,
    voltage: np.ndarray,
    static_correction: bool = True,
    modal_ratios: np.ndarray | None = None,
    order: int = 0,
) -> tuple[np.ndarray, bool]:
    """Sensor output (B, n) of B parameter sets whose retained modes are rescaled cached shapes.

    The whole warm path of :meth:`beam.physics.model.BeamModel.response` in one compiled call:
    :func:`scale_unit_modes`, then poles and residues, then exact ZOH stepping (the fast path of
    :func:`complex_modes` + :func:`zoh_response` for one input and one output). Poles and
    residues come from the symmetric quadratic eigenproblem
    (lambda² I + lambda C_r + diag(omega²)) v = 0, solved per mode by two-sided
    Rayleigh-functional iteration from the proportional-damping estimate (cubic convergence, to
    round-off), with residues r = (c·v)(v·f) / (vᵀ (2 lambda I + C_r) v). Any parameter set
    where the iteration does not settle on m distinct poles is redone with LAPACK
    (:func:`complex_modes`).

    Parameters
    ----------
    which, unit_modes, scales
        As for :func:`scale_unit_modes`.
    sample_interval_s : float
        Sample interval (s).
    voltage : (n,) array
        Input (the voltage in V, or a point force in N), held over each sample.
    static_correction : bool
        Add the quasi-static response of the discarded modes (displacement only, ``order=0``).
    modal_ratios : (B, m) array, optional
        Modal damping ratios zeta_j (0 where a mode has none), see :func:`scale_unit_modes`.
    order : {0, 1, 2}
        Output: sensor displacement (0), velocity (1) or acceleration (2); see the module notes.

    Returns
    -------
    output : (B, n) sensor displacement (m), velocity (m/s) or acceleration (m/s²) per unit input.
    finite : bool
        False if any output sample is NaN or infinite.
    """
    ratios = _ratios(modal_ratios, which.shape[0], unit_modes[0].shape[1])
    correction = 1.0 if static_correction and order == 0 else 0.0
    out, ok, finite, reduced = _cached_modes_response(
        which, *unit_modes, scales, ratios, float(sample_interval_s), voltage, correction, int(order)
    )
    if not ok.all():
        omega2, damping, force, sensor, static = reduced
        bad = ~ok
        poles, weights = modal_poles_and_weights(omega2[bad], damping[bad], force[bad], sensor[bad])
        weights, direct = derivative_weights(poles, weights, order)
        out[bad] = _step(poles, weights, float(sample_interval_s), voltage, direct + static[bad, 0] * correction)
        finite = bool(np.isfinite(out).all())
    return out, finite


def _ratios(modal_ratios: np.ndarray | None, batch: int, m: int) -> np.ndarray:
    if modal_ratios is None:
        return np.zeros((batch, m))
    return np.ascontiguousarray(np.broadcast_to(np.asarray(modal_ratios, dtype=float), (batch, m)))


def scale_unit_modes(
    which: np.ndarray, unit_modes: tuple[np.ndarray, ...], scales: np.ndarray, modal_ratios: np.ndarray | None = None
) -> tuple[np.ndarray, ...]:
    """Retained modes of B parameter sets from U cached unit-scale solutions.

    Mode shapes depend only on the ratios of the mass and of the stiffness coefficients; each
    set b reuses solution ``which[b]`` (solved for rho = EI = 1) and rescales it:
    omega² = (EI/rho) omega_unit², shapes / sqrt(rho), force x k_p. Modal damping adds
    2 zeta_j omega_j to the diagonal of the reduced damping matrix.

    Parameters
    ----------
    which : (B,) int64
        Index of each set's unit solution.
    unit_modes : tuple of arrays
        omega2 (U, m) (rad²/s² at unit scale), projections (U, P, m, m) of the P damping parts,
        force (U, m) per unit coupling, sensor (U, m), tip (U, m), static (U, 2) or (U, 4) (m per
        unit coupling at sensor and tip, per unit EI; then m per unit tip force at sensor and tip).
    scales : (3 + P, B)
        Per set: rho (mass scale, kg/m), EI (stiffness scale, N m²), the force coefficient
        (N m/V for the patch, 1 for a point force in N) and the coefficient of each of the P
        damping parts.
    modal_ratios : (B, m) array, optional
        Damping ratio zeta_j of each retained mode from ``modal_damping`` (0: none).

    Returns
    -------
    omega2 (B, m), damping (B, m, m) (1/s), force (B, m), sensor (B, m), tip (B, m), static (B, 2 or 4).
    """
    ratios = _ratios(modal_ratios, which.shape[0], unit_modes[0].shape[1])
    return _scale_unit_modes(which, *unit_modes, scales, ratios)


@numba.njit(cache=True, nogil=True)
def _scale_unit_modes(which, omega2_u, projections_u, force_u, sensor_u, tip_u, static_u, scales, ratios):  # pragma: no cover - jitted
    batch = which.shape[0]
    m = omega2_u.shape[1]
    n_parts = projections_u.shape[1]
    omega2 = np.empty((batch, m))
    damping = np.zeros((batch, m, m))
    force = np.empty((batch, m))
    sensor = np.empty((batch, m))
    tip = np.empty((batch, m))
    static = np.empty((batch, static_u.shape[1]))
    for b in range(batch):
        u = which[b]
        mass_scale, stiff_scale, force_coef = scales[0, b], scales[1, b], scales[2, b]
        inv_root_mass = 1.0 / np.sqrt(mass_scale)
        for i in range(m):
            omega2[b, i] = omega2_u[u, i] * (stiff_scale / mass_scale)
            force[b, i] = force_u[u, i] * force_coef * inv_root_mass
            sensor[b, i] = sensor_u[u, i] * inv_root_mass
            tip[b, i] = tip_u[u, i] * inv_root_mass
            for j in range(m):
                acc = 0.0
                for p in range(n_parts):
                    acc += scales[3 + p, b] * projections_u[u, p, i, j]
                damping[b, i, j] = acc / mass_scale
            damping[b, i, i] += 2.0 * ratios[b, i] * np.sqrt(max(omega2[b, i], 0.0))
        for k in range(2):
            static[b, k] = static_u[u, k] * (force_coef / stiff_scale)
        for k in range(2, static_u.shape[1]):  # per unit tip force (N), not per unit input
            static[b, k] = static_u[u, k] / stiff_scale
    return omega2, damping, force, sensor, tip, static


@numba.njit(cache=True, nogil=True)
def _cached_modes_response(which, omega2_u, projections_u, force_u, sensor_u, tip_u, static_u, scales, ratios,
                           dt, voltage, static_correction, order):  # pragma: no cover - jitted
    omega2, damping, force, sensor, tip, static = _scale_unit_modes(
        which, omega2_u, projections_u, force_u, sensor_u, tip_u, static_u, scales, ratios
    )
    poles, residues, ok = _quadratic_modes(omega2, damping, force, sensor)
    weights, direct = _derivative_weights(poles, 2.0 * residues, order)
    gain = static[:, 0] * static_correction + direct
    out = _step(poles, weights, dt, voltage, gain)
    finite = True
    for b in range(out.shape[0]):
        if ok[b]:
            for k in range(out.shape[1]):
                if not np.isfinite(out[b, k]):
                    finite = False
                    break
        if not finite:
            break
    return out, ok, finite, (omega2, damping, force, sensor, static)


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
def _quadratic_vectors(omega2, damping):  # pragma: no cover - jitted
    """Upper poles (B, m) (Im >= 0), unit eigenvectors (B, m, m) (mode i in column i) and
    normalisations v^T (2 lambda I + C_r) v (B, m) of (lambda² I + lambda C_r + diag(omega²)) v = 0,
    per mode by two-sided Rayleigh-functional iteration from the proportional-damping estimate;
    ok[b] False where the iteration failed (see :func:`cached_modes_response`)."""
    batch, m = omega2.shape
    poles = np.zeros((batch, m), np.complex128)
    vectors = np.zeros((batch, m, m), np.complex128)
    norms = np.ones((batch, m), np.complex128)
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
            for r in range(m):
                acc = 2.0 * lam * v[r]
                for c in range(m):
                    acc += damping[b, r, c] * v[c]
                denom += v[r] * acc
            poles[b, i] = lam
            norms[b, i] = denom
            for r in range(m):
                vectors[b, r, i] = v[r]
        if ok[b]:  # the m poles must be distinct modes
            for i in range(m):
                for j in range(i + 1, m):
                    if abs(poles[b, i] - poles[b, j]) <= 1e-8 * abs(poles[b, i]):
                        ok[b] = False
    return poles, vectors, norms, ok


@numba.njit(cache=True, nogil=True)
def _quadratic_modes(omega2, damping, force, output):  # pragma: no cover - jitted
    """Upper poles (Im >= 0) and residues (c·v)(v·f) / (v^T (2 lambda I + C_r) v) per mode
    (:func:`_quadratic_vectors`); ok[b] False where the iteration failed."""
    poles, vectors, norms, ok = _quadratic_vectors(omega2, damping)
    batch, m = omega2.shape
    residues = np.zeros((batch, m), np.complex128)
    for b in range(batch):
        if not ok[b]:
            continue
        for i in range(m):
            cv = 0j
            vf = 0j
            for r in range(m):
                cv += output[b, r] * vectors[b, r, i]
                vf += vectors[b, r, i] * force[b, r]
            residues[b, i] = cv * vf / norms[b, i]
    return poles, residues, ok


def _with_conjugates(upper: np.ndarray) -> np.ndarray:
    """(..., m) -> (..., 2m): each entry followed by its conjugate."""
    return np.stack([upper, np.conj(upper)], axis=-1).reshape(*upper.shape[:-1], 2 * upper.shape[-1])


def quadratic_complex_modes(
    omega_squared: np.ndarray, reduced_damping: np.ndarray, reduced_inputs: np.ndarray, reduced_outputs: np.ndarray
) -> ComplexModes:
    """:func:`complex_modes` with the non-proportional case solved by the compiled
    Rayleigh-functional iteration of :func:`cached_modes_response` instead of LAPACK's dgeev on
    the 2m x 2m first-order matrix (a set where it does not settle goes to dgeev).

    The reduced system is symmetric, so the residue matrix of the pole lambda_j is
    v_j v_jᵀ / (v_jᵀ (2 lambda_j I + C_r) v_j): output gains c_r·v_j, input gains
    (v_j·f_r) / (v_jᵀ (2 lambda_j I + C_r) v_j), and their conjugates for the conjugate pole,
    adjacent with Im > 0 first as from dgeev. The same modes to round-off (tests/test_physics_modes.py);
    measured 24 sets of 8 modes: 0.43 ms against 0.90 ms (the spring's fits of a diagnosis of
    ``lab_run_1`` call it ~300 times).
    """
    diagonal = np.einsum("bii->bi", reduced_damping)
    if np.count_nonzero(reduced_damping) == np.count_nonzero(diagonal):  # the closed form
        return complex_modes(omega_squared, reduced_damping, reduced_inputs, reduced_outputs)
    omega2 = np.ascontiguousarray(omega_squared, dtype=float)
    damping = np.ascontiguousarray(reduced_damping, dtype=float)
    batch, m = omega2.shape
    poles, vectors, norms, ok = _quadratic_vectors(omega2, damping)
    outputs = np.asarray(reduced_outputs, dtype=float) @ vectors  # (B, n_out, m)
    inputs = (np.asarray(reduced_inputs, dtype=float) @ vectors) / norms[:, None, :]  # (B, n_in, m)
    result = ComplexModes(_with_conjugates(poles), _with_conjugates(inputs), _with_conjugates(outputs))
    if not ok.all():
        bad = np.flatnonzero(~ok)
        fallback = complex_modes(omega2[bad], damping[bad], np.asarray(reduced_inputs)[bad], np.asarray(reduced_outputs)[bad])
        result.poles[bad], result.input_gains[bad], result.output_gains[bad] = (
            fallback.poles, fallback.input_gains, fallback.output_gains)
    return result


def modal_poles_and_weights(
    omega_squared: np.ndarray, reduced_damping: np.ndarray, reduced_force: np.ndarray, reduced_output: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Collapsed poles and displacement weights of eta'' + C_r eta' + diag(omega²) eta = f_r u, y = c_r eta.

    Parameters
    ----------
    omega_squared : (B, m)
        Retained undamped omega² (rad²/s²).
    reduced_damping : (B, m, m)
        Reduced damping matrix (1/s), modal damping included.
    reduced_force, reduced_output : (B, m)
        Reduced input vector and displacement output row.

    Returns
    -------
    poles : (B, P) complex
        One pole per conjugate pair (Im > 0) and every real pole (an overdamped mode has two),
        padded with -1 where a set has fewer (P = m when every set is underdamped, else 2m).
    weights : (B, P) complex
        y = Re sum_j weights_j xi_j with xi_j' = lambda_j xi_j + u: twice the residue for a
        pair, the residue for a real pole, 0 for padding.

    Notes
    -----
    The compiled Rayleigh-functional iteration of :func:`cached_modes_response`; a set where it
    does not settle (overdamped or nearly repeated modes) is redone with LAPACK
    (:func:`complex_modes`).
    """
    omega2 = np.ascontiguousarray(omega_squared, dtype=float)
    damping = np.ascontiguousarray(reduced_damping, dtype=float)
    force = np.ascontiguousarray(reduced_force, dtype=float)
    output = np.ascontiguousarray(reduced_output, dtype=float)
    poles, residues, ok = _quadratic_modes(omega2, damping, force, output)
    weights = 2.0 * residues
    if ok.all():
        return poles, weights
    batch, m = omega2.shape
    all_poles = np.full((batch, 2 * m), -1.0 + 0j)
    all_weights = np.zeros((batch, 2 * m), complex)
    all_poles[:, :m], all_weights[:, :m] = poles, weights
    bad = np.flatnonzero(~ok)
    fallback = complex_modes(omega2[bad], damping[bad], force[bad][:, None, :], output[bad][:, None, :])
    collapsed_poles, collapsed_weights = _collapse(
        fallback.poles, fallback.output_gains[:, 0] * fallback.input_gains[:, 0]
    )
    all_poles[bad], all_weights[bad] = collapsed_poles, collapsed_weights
    return all_poles, all_weights


def derivative_weights(poles: np.ndarray, weights: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Weights and direct term (B,) of the displacement's ``order``-th time derivative (see the module notes).

    ``order`` 0: unchanged, no direct term; 1 (velocity): weights x lambda, no direct term;
    2 (acceleration): weights x lambda², direct term Re sum_j weights_j lambda_j.
    """
    if order not in (0, 1, 2):
        raise ValueError(f"order must be 0, 1 or 2, got {order!r}")
    return _derivative_weights(np.ascontiguousarray(poles), np.ascontiguousarray(weights), int(order))


@numba.njit(cache=True, nogil=True)
def _derivative_weights(poles, weights, order):  # pragma: no cover - jitted
    batch, n_poles = poles.shape
    out = weights.copy()
    direct = np.zeros(batch)
    if order >= 1:
        for b in range(batch):
            for j in range(n_poles):
                out[b, j] = weights[b, j] * poles[b, j]
    if order == 2:
        for b in range(batch):
            acc = 0.0
            for j in range(n_poles):
                acc += out[b, j].real
                out[b, j] = out[b, j] * poles[b, j]
            direct[b] = acc
    return out, direct


def zoh_response_at(
    poles: np.ndarray, weights: np.ndarray, direct: np.ndarray, time_s: np.ndarray, inputs: np.ndarray
) -> np.ndarray:
    """Output (B, n) at increasing times ``time_s`` under an input held over each recorded interval, from rest.

    Each collapsed mode is stepped exactly over its own interval dt_k = t_k+1 - t_k:
    xi_j[k+1] = z xi_j[k] + (z - 1)/lambda_j u[k], z = exp(lambda_j dt_k); then
    y[k] = Re sum_j weights_j xi_j[k] + direct u[k]. On a uniform grid it equals the stepping
    of :func:`zoh_response` (to round-off).

    Parameters
    ----------
    poles, weights : (B, P) complex
        From :func:`modal_poles_and_weights` (and :func:`derivative_weights`).
    direct : (B,)
        Direct (feed-through or static-correction) gain.
    time_s : (n,)
        Strictly increasing sample times (s).
    inputs : (n,)
        Input held over [t_k, t_k+1).
    """
    steps = np.ascontiguousarray(np.diff(np.asarray(time_s, dtype=float)))
    return _step_at(
        np.ascontiguousarray(poles, dtype=complex), np.ascontiguousarray(weights, dtype=complex),
        np.ascontiguousarray(direct, dtype=float), steps, np.ascontiguousarray(inputs, dtype=float),
    )


@numba.njit(cache=True, nogil=True)
def _step_at(poles, weights, direct, steps, inputs):  # pragma: no cover - jitted
    """Per-step ZOH update; one complex exponential per pole and step (the steps differ)."""
    batch, n_poles = poles.shape
    n = inputs.shape[0]
    out = np.empty((batch, n))
    state = np.zeros(n_poles, np.complex128)
    for b in range(batch):
        state[:] = 0.0
        for k in range(n):
            uk = inputs[k]
            acc = direct[b] * uk
            for j in range(n_poles):
                acc += (weights[b, j] * state[j]).real
            out[b, k] = acc
            if k + 1 < n:
                dt = steps[k]
                for j in range(n_poles):
                    pole = poles[b, j]
                    state[j] = np.exp(pole * dt) * state[j] + zoh_factor(pole, dt) * uk
    return out


def modal_decomposition(omega_squared: np.ndarray, reduced_damping: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and eigenvectors of the retained first-order system x = [eta, eta'], x' = A x.

    Returns
    -------
    poles : (B, 2m) complex
        Sorted by frequency |Im lambda| then by Re lambda; conjugate pairs adjacent, Im > 0 first.
    vectors : (B, 2m, 2m) complex
        Columns v_j with A v_j = lambda_j v_j (top half: displacement, bottom: velocity).
    """
    omega2 = np.asarray(omega_squared, dtype=float)
    batch, m = omega2.shape
    system = np.zeros((batch, 2 * m, 2 * m))
    system[:, :m, m:] = np.eye(m)
    system[:, m:, :m] = -omega2[:, :, None] * np.eye(m)
    system[:, m:, m:] = -np.asarray(reduced_damping, dtype=float)
    poles, vectors = np.linalg.eig(system)
    order = np.lexsort((-poles.imag, poles.real, np.round(np.abs(poles.imag), 9)), axis=-1)
    poles = np.take_along_axis(poles, order, axis=-1)
    vectors = np.take_along_axis(vectors, order[:, None, :], axis=-1)
    return poles, vectors


def free_basis(poles: np.ndarray, time_s: np.ndarray) -> np.ndarray:
    """Real basis (B, n, 2m) of free responses at times ``time_s`` (s), tau = t - t_0.

    For each conjugate pair (in the order of :func:`modal_decomposition`) the columns
    exp(Re lambda tau) cos(Im lambda tau) and exp(Re lambda tau) sin(Im lambda tau); for each real
    pole exp(lambda tau). Any free response of the retained modes — displacement, velocity or
    acceleration alike, since each is a combination of the same exponentials — is
    ``basis @ amplitudes`` for some real amplitudes (2m of them).
    """
    tau = np.asarray(time_s, dtype=float) - float(np.asarray(time_s)[0])
    batch, count = poles.shape
    out = np.empty((batch, tau.size, count))
    for b in range(batch):
        column = 0
        j = 0
        while j < count:
            pole = poles[b, j]
            values = np.exp(pole * tau)
            if pole.imag > 0:
                out[b, :, column], out[b, :, column + 1] = values.real, values.imag
                column += 2
                j += 2  # skip the conjugate
            else:
                out[b, :, column] = values.real
                column += 1
                j += 1
    return out


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
    upper, weights = _collapse(poles, residues)
    return _step(upper, weights, dt, voltage, np.zeros(poles.shape[0]))


@numba.njit(cache=True, nogil=True)
def _collapse(poles, residues):  # pragma: no cover - jitted
    """One pole per conjugate pair (weight 2 r) and every real pole (weight r); unused slots get
    pole -1 and weight 0."""
    batch, n_poles = poles.shape
    upper = np.full((batch, n_poles), -1.0 + 0j)
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
    return upper, weights


@numba.njit(cache=True, nogil=True)
def _step(poles, weights, dt, voltage, static):  # pragma: no cover - jitted
    """y[b, k] = Re sum_j weights_j xi_j[k] + static[b] u[k], xi_j[k+1] = z_j xi_j[k] + (z_j - 1)/lambda_j u[k].

    Real arithmetic on split real and imaginary parts. One or a few sets are stepped one after
    the other; larger batches step all their poles together, one time step at a time, so the
    inner loop runs over B x m independent poles (SIMD). A zero weight adds nothing (unused slots).
    """
    batch, n_poles = poles.shape
    size = batch * n_poles
    z_re, z_im = np.empty(size), np.empty(size)
    w_re, w_im = np.empty(size), np.empty(size)
    for b in range(batch):
        for j in range(n_poles):
            z = np.exp(poles[b, j] * dt)
            w = weights[b, j] * zoh_factor(poles[b, j], dt)
            p = b * n_poles + j
            z_re[p], z_im[p], w_re[p], w_im[p] = z.real, z.imag, w.real, -w.imag
    if batch < 4:
        return _step_each(z_re, z_im, w_re, w_im, batch, voltage, static)
    return _step_together(z_re, z_im, w_re, w_im, batch, voltage, static)


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _step_each(z_re, z_im, w_re, w_im, batch, voltage, static):  # pragma: no cover - jitted
    n_poles = z_re.size // batch
    n = voltage.shape[0]
    out = np.empty((batch, n))
    x_re, x_im = np.zeros(n_poles), np.zeros(n_poles)
    for b in range(batch):
        zr, zi = z_re[b * n_poles:(b + 1) * n_poles], z_im[b * n_poles:(b + 1) * n_poles]
        wr, wi = w_re[b * n_poles:(b + 1) * n_poles], w_im[b * n_poles:(b + 1) * n_poles]
        x_re[:] = 0.0
        x_im[:] = 0.0
        gain = static[b]
        for k in range(n):
            uk = voltage[k]
            acc = gain * uk
            for j in range(n_poles):
                a, c = x_re[j], x_im[j]
                acc += wr[j] * a + wi[j] * c
                x_re[j] = zr[j] * a - zi[j] * c + uk
                x_im[j] = zr[j] * c + zi[j] * a
            out[b, k] = acc
    return out


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "contract"})
def _step_together(z_re, z_im, w_re, w_im, batch, voltage, static):  # pragma: no cover - jitted
    size = z_re.size
    n_poles = size // batch
    n = voltage.shape[0]
    out = np.empty((batch, n))
    x_re, x_im, terms = np.zeros(size), np.zeros(size), np.empty(size)
    for k in range(n):
        uk = voltage[k]
        for p in range(size):
            a, c = x_re[p], x_im[p]
            terms[p] = w_re[p] * a + w_im[p] * c
            x_re[p] = z_re[p] * a - z_im[p] * c + uk
            x_im[p] = z_re[p] * c + z_im[p] * a
        for b in range(batch):
            acc = static[b] * uk
            for j in range(b * n_poles, (b + 1) * n_poles):
                acc += terms[j]
            out[b, k] = acc
    return out


@dataclass(frozen=True)
class RitzBasis:
    """A subspace for the low modes of a family M = sum_t a_t M_t, K = sum_t b_t K_t near one member
    (see :func:`ritz_basis`).

    Attributes
    ----------
    anchor : (T,) the coefficients (mass terms, then stiffness terms) of the member it was built at.
    vectors : (n, r) V, M-orthonormal at the anchor.
    mass_parts, stiffness_parts : (T_m, r, r), (T_k, r, r)
        Vᵀ M_t V and Vᵀ K_t V: the reduced matrices of any member are their combinations.
    whitener : (n, n)
        C_a⁻¹ with K_a = C_a C_aᵀ the anchor's stiffness: the norm of a residual in K_a⁻¹ (the
        error bound of :func:`ritz_modes`).
    mass_terms, stiffness_terms : (T_m, n, n), (T_k, n, n)
        The full parts (residuals, :func:`ritz_static`).
    """

    anchor: np.ndarray
    vectors: np.ndarray
    mass_parts: np.ndarray
    stiffness_parts: np.ndarray
    whitener: np.ndarray
    mass_terms: np.ndarray
    stiffness_terms: np.ndarray


def ritz_basis(
    mass_terms: np.ndarray, stiffness_terms: np.ndarray, anchor: np.ndarray, steps: np.ndarray, count: int, extra: int = 2,
) -> RitzBasis:
    """Rayleigh–Ritz subspace for the ``count`` lowest modes of the members near ``anchor``.

    The subspace is spanned by the anchor's ``count + extra`` lowest undamped modes and by the
    ``count`` lowest modes of each member ``anchor + steps[k]`` (one snapshot per coefficient
    that varies; a forward difference spans each mode's first derivative in that coefficient),
    made M-orthonormal at the anchor (directions below 1e-10 of the largest dropped). Why: on
    lab_run_1's posterior draws 52 µs a member against ~160-190 µs dense, within 3e-10 in omega²
    (the measurements: ``docs/decisions.md``, the linear model); tests/test_physics_ritz.py
    checks the modes against the dense solve.

    Parameters
    ----------
    mass_terms, stiffness_terms : (T_m, n, n), (T_k, n, n)
        The symmetric parts M_t and K_t.
    anchor : (T_m + T_k,)
        Coefficients a_t then b_t of the anchor member.
    steps : (S, T_m + T_k)
        Coefficient offsets of the snapshot members.
    count : int
        Number m of modes wanted.
    """
    n_mass = mass_terms.shape[0]
    members = np.concatenate([anchor[None, :], anchor[None, :] + steps])
    mass = np.einsum("ut,tij->uij", members[:, :n_mass], mass_terms)
    stiffness = np.einsum("ut,tij->uij", members[:, n_mass:], stiffness_terms)
    _, shapes = undamped_modes(mass, stiffness)
    n = mass.shape[-1]
    columns = np.concatenate([shapes[0, :, : min(n, count + extra)]] + [s[:, :count] for s in shapes[1:]], axis=1)
    lower = np.linalg.cholesky(mass[0])
    left, singular, _ = np.linalg.svd(lower.T @ columns, full_matrices=False)
    left = left[:, singular > 1e-10 * singular[0]]
    vectors = np.linalg.solve(lower.T, left)
    whitener = np.linalg.inv(np.linalg.cholesky(stiffness[0]))
    reduce = lambda parts: np.einsum("ia,tij,jb->tab", vectors, parts, vectors)  # noqa: E731
    return RitzBasis(anchor.copy(), vectors, reduce(mass_terms), reduce(stiffness_terms), whitener,
                     np.asarray(mass_terms, dtype=float), np.asarray(stiffness_terms, dtype=float))


def _apply_terms(terms: np.ndarray, coefficients: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """sum_t coefficients[b, t] terms[t] @ vectors[b] for (B, n, k) vectors: one product per term
    over all B k columns (a single BLAS call each, instead of assembling B matrices)."""
    batch, n, k = vectors.shape
    flat = np.swapaxes(vectors, 0, 1).reshape(n, batch * k)
    out = np.zeros((batch, n, k))
    for t in range(terms.shape[0]):
        out += coefficients[:, t, None, None] * np.swapaxes((terms[t] @ flat).reshape(n, batch, k), 0, 1)
    return out


def ritz_static(basis: RitzBasis, coefficients: np.ndarray, loads: np.ndarray, tolerance: float = 1e-14,
                max_terms: int = 60) -> np.ndarray | None:
    """K⁻¹ loads (B, n, L) for members near the anchor, by the Neumann series around K_a, or None.

    K = K_a + dK, K⁻¹ = sum_k (-K_a⁻¹ dK)^k K_a⁻¹; with positive semi-definite parts,
    -e K_a <= dK <= e K_a for e = max_t |b_t - b_t^a| / b_t^a, so the series converges at
    least as e^k (e <= 0.05 in the trust radius of :meth:`beam.physics.model.BeamModel._ritz_rows`;
    ~0.004 for lab_run_1's walkers: 5 terms). Summed until a term is below ``tolerance`` of the
    sum; None if not within ``max_terms``. Measured on lab_run_1's walkers (batches of 64):
    ~10 µs per member, against 9 µs for a dense solve plus 17 µs to assemble each K.
    """
    n_mass = basis.mass_parts.shape[0]
    change = coefficients[:, n_mass:] - basis.anchor[n_mass:]
    inverse = basis.whitener.T @ basis.whitener  # K_a⁻¹
    term = np.einsum("ij,jl->il", inverse, loads)[None].repeat(coefficients.shape[0], axis=0)
    total = term.copy()
    size = np.abs(total).max()
    for _ in range(max_terms):
        term = -_apply_terms_fixed(inverse, basis.stiffness_terms, change, term)
        total += term
        if np.abs(term).max() <= tolerance * size:
            return total
    return None


def _apply_terms_fixed(inverse: np.ndarray, terms: np.ndarray, coefficients: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """inverse @ (sum_t coefficients[b, t] terms[t]) @ vectors[b], batched (see :func:`_apply_terms`)."""
    applied = _apply_terms(terms, coefficients, vectors)
    batch, n, k = applied.shape
    flat = np.swapaxes(applied, 0, 1).reshape(n, batch * k)
    return np.swapaxes((inverse @ flat).reshape(n, batch, k), 0, 1)


def ritz_modes(
    basis: RitzBasis, coefficients: np.ndarray, count: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``count`` lowest modes of B members from the Ritz subspace, with a bound on their error.

    The reduced pencils (r x r) are solved by :func:`undamped_modes` (inverted, as the dense
    solve). The bound: for a Ritz pair (omega², x) with xᵀ M x = 1 and residual
    res = K x - omega² M x, the inverted, K-whitened problem W y = mu y (W = C⁻¹ M C⁻ᵀ,
    mu = 1/omega², y = Cᵀ x / omega) has the residual norm eta = |C⁻¹ res| / omega³ for the
    unit y, and the angle between y and the exact mode is at most eta / gap (Davis–Kahan), gap
    the distance of mu to the neighbouring eigenvalues (taken from the Ritz values, whose
    ``count + 1``-th the basis holds). |C⁻¹ res| is bounded with the anchor's factor:
    K >= s K_a with s = min_t b_t / b_t^a over the anchor's nonzero stiffness terms (all parts
    positive semi-definite), so |C⁻¹ res|² <= |C_a⁻¹ res|² / s.

    Parameters
    ----------
    basis : RitzBasis
    coefficients : (B, T_m + T_k)
        Coefficients of the members.
    count : int
        m <= r - 1.

    Returns
    -------
    omega_squared : (B, m) ascending (rad²/s²).
    shapes : (B, n, m) mass-normalised.
    angle : (B,) the bound on the largest angle (rad) between a Ritz mode and the exact one
        (inf where the bound cannot be formed).
    """
    n_mass = basis.mass_parts.shape[0]
    reduced_mass = np.einsum("bt,tij->bij", coefficients[:, :n_mass], basis.mass_parts)
    reduced_stiffness = np.einsum("bt,tij->bij", coefficients[:, n_mass:], basis.stiffness_parts)
    omega_squared, vectors = undamped_modes(reduced_mass, reduced_stiffness)
    shapes = basis.vectors @ vectors[:, :, :count]
    omega2 = omega_squared[:, :count]
    residual = (_apply_terms(basis.stiffness_terms, coefficients[:, n_mass:], shapes)
                - _apply_terms(basis.mass_terms, coefficients[:, :n_mass], shapes) * omega2[:, None, :])
    anchor = basis.anchor[n_mass:]
    used = anchor > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        floor = np.min(coefficients[:, n_mass:][:, used] / anchor[used], axis=1)
        eta = np.linalg.norm(basis.whitener @ residual, axis=1) / np.sqrt(floor)[:, None] / omega2**1.5
        mu = 1.0 / omega_squared[:, : count + 1]
        gaps = np.full(omega2.shape, np.inf)
        gaps = np.minimum(gaps, mu[:, :count] - mu[:, 1 : count + 1])
        gaps[:, 1:] = np.minimum(gaps[:, 1:], mu[:, : count - 1] - mu[:, 1:count])
        angle = np.max(eta / gaps, axis=1)
    angle = np.where(np.isfinite(angle) & (floor > 0), angle, np.inf)
    return omega2, shapes, angle


def perturbed_modes(
    omega_squared: np.ndarray, shapes: np.ndarray, mass_change: np.ndarray, stiffness_change: np.ndarray, count: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` lowest modes of (M + dM, K + dK) to first order in the changes, from all modes of (M, K).

    With every mass-normalised mode phi_j (omega² = lambda_j) of (M, K) and
    a_ji = phi_jᵀ (dK - lambda_i dM) phi_i:

    * lambda_i + a_ii;
    * phi_i + sum_{j != i} phi_j a_ji / (lambda_i - lambda_j) - phi_i (phi_iᵀ dM phi_i) / 2
      (the change keeps the shape mass-normalised to first order).

    For the forward-difference stencils of a Levenberg–Marquardt Jacobian (relative changes of
    ~1e-8, :func:`beam.physics.model._stencil_centres`) the neglected second order is
    round-off, and the difference quotient becomes the analytic derivative of the dense solve.

    Parameters
    ----------
    omega_squared : (n,) all eigenvalues, ascending (distinct).
    shapes : (n, n) all mass-normalised shapes.
    mass_change, stiffness_change : (S, n, n) dM and dK of S perturbed members.
    count : int
        Number m of modes wanted.

    Returns
    -------
    omega_squared : (S, m), shapes : (S, n, m).
    """
    lam = omega_squared[:count]
    kept = shapes[:, :count]
    stiff = shapes.T @ stiffness_change @ kept  # (S, n, m): phi_jᵀ dK phi_i
    mass = shapes.T @ mass_change @ kept  # (S, n, m): phi_jᵀ dM phi_i
    coupling = stiff - mass * lam[None, None, :]  # a_ji
    rows = np.arange(count)
    new_lam = lam[None, :] + coupling[:, rows, rows]
    with np.errstate(divide="ignore"):
        weights = 1.0 / (lam[None, :] - omega_squared[:, None])  # (n, m): 1/(lambda_i - lambda_j)
    weights[rows, rows] = 0.0
    change = shapes @ (coupling * weights[None, :, :]) - 0.5 * kept[None, :, :] * mass[:, rows, rows][:, None, :]
    return new_lam, kept[None, :, :] + change


collapse_pairs = _collapse  # the public name of the pole collapse (beam.physics.nonlinear steps with it too)
