"""Maximum a posteriori (MAP) point estimate of a :class:`~beam.inference.problem.Problem`.

The search runs in the internal coordinates (see :mod:`beam.inference.priors`) and has two
stages:

1. **Multi-start least squares** (:func:`scipy.optimize.least_squares`, trust-region
   reflective, bounded) over the physical parameters with the noise parameters held at moment
   estimates. The objective is the exact negative log posterior at those noise values: the
   whitened residuals plus one pseudo-residual per Gaussian prior (flat priors add nothing in
   the internal coordinate). The Jacobian comes from one vectorised model call per iterate.
   Oscillation fits are multimodal in frequency, so the quality of the starting points matters:
   a problem supplies its own through ``Problem.initial_guesses`` (the toy uses the periodogram
   peak, :func:`beam.toy.spectral_initial_guesses`); otherwise the prior centre and a few
   seeded prior draws are tried (:func:`default_initial_guesses`).
2. **Newton polish** of the best start over *all* sampled parameters (noise included) with a
   central finite-difference gradient and Hessian of the log posterior. All stencil points of
   one iterate are evaluated in a single vectorised call, as are the trial points of the
   backtracking line search. The final Hessian is the one the Laplace approximation uses
   (:mod:`beam.inference.laplace`).

Parameters whose MAP sits on a prior bound are reported in :attr:`MapResult.at_bound`; the
Newton step keeps them on the bound (active set) and the derivatives there are taken at a
point moved inside by one and a half finite-difference steps.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from beam.inference.problem import Problem
from beam.inference.progress import report

__all__ = ["MapResult", "NewtonOutcome", "default_initial_guesses", "fd_derivatives", "find_map", "newton_iterations",
           "newton_step", "steps_from_hessian"]

_SQRT_EPS = float(np.sqrt(np.finfo(float).eps))
#: A Newton decrement (expected gain, nats) this small is within finite-difference error:
#: the point is within ~0.05 posterior sd of the mode.
FD_LIMITED_DECREMENT = 1e-3


@dataclass
class MapResult:
    """Outcome of :func:`find_map`.

    Attributes
    ----------
    z : ndarray, shape (ndim,)
        MAP in internal coordinates.
    values : dict of str to float
        MAP in natural units, fixed parameters included.
    log_posterior : float
        Unnormalised log posterior at the MAP (log prior + log likelihood, nats).
    gradient, hessian : ndarray
        Finite-difference gradient (ndim,) and Hessian (ndim, ndim) of the log posterior at
        (or, on a bound, just inside) the MAP, internal coordinates.
    hessian_point : ndarray, shape (ndim,)
        Where ``gradient`` and ``hessian`` were evaluated.
    converged : bool
        True when the Newton decrement fell below the tolerance.
    message : str
        Human-readable outcome.
    n_starts : int
        Number of starting points tried.
    start_log_posteriors : list of float
        Log posterior reached from each start after stage 1 (same order as the starts).
    at_bound : tuple of str
        Parameters whose MAP is on (within a finite-difference step of) a prior bound.
    n_iterations : int
        Newton iterations.
    """

    z: np.ndarray
    values: dict[str, float]
    log_posterior: float
    gradient: np.ndarray
    hessian: np.ndarray
    hessian_point: np.ndarray
    converged: bool
    message: str
    n_starts: int
    start_log_posteriors: list[float] = field(default_factory=list)
    at_bound: tuple[str, ...] = ()
    n_iterations: int = 0


def default_initial_guesses(problem: Problem, n_random: int = 8, seed: int = 0) -> list[dict[str, float]]:
    """Prior centre plus ``n_random`` seeded prior draws of the physical parameters.

    Noise parameters are left out: :func:`find_map` estimates them from each guess's residuals.
    """
    rng = np.random.default_rng(seed)
    names = problem.model_names
    guesses = [{n: float(problem.parameter(n).prior.from_internal(problem.parameter(n).prior.internal_centre())) for n in names}]
    for _ in range(n_random):
        guesses.append({n: float(problem.parameter(n).prior.sample(rng, 1)[0]) for n in names})
    return guesses


def _interior(problem: Problem, z: np.ndarray, margin: np.ndarray) -> np.ndarray:
    lo, hi = problem.internal_bounds
    width = hi - lo
    m = np.minimum(margin, 0.25 * np.where(np.isfinite(width), width, np.inf))
    return np.clip(z, lo + m, hi - m)


def _scales(problem: Problem) -> np.ndarray:
    return np.array([p.prior.internal_scale for p in problem.parameters])


def fd_derivatives(
    problem: Problem, z: np.ndarray, h: np.ndarray, free: np.ndarray | None = None
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """Central finite-difference gradient and Hessian of the log posterior in one model call.

    Parameters
    ----------
    problem : Problem
        The problem.
    z : ndarray, shape (ndim,)
        Internal point.
    h : ndarray, shape (ndim,)
        Steps in the internal coordinates.
    free : ndarray of bool, shape (ndim,), optional
        Differentiate along these coordinates only (the others are held at ``z`` and get zero
        gradient and Hessian entries). Default: all.

    Returns
    -------
    f0 : float
        Log posterior at the evaluation point.
    grad : ndarray, shape (ndim,)
        Gradient of the log posterior.
    hess : ndarray, shape (ndim, ndim)
        Hessian of the log posterior (negative definite at a regular maximum).
    zc : ndarray, shape (ndim,)
        Evaluation point: ``z`` with the differentiated coordinates moved inside the bounds
        by ``1.5 h`` where needed, so that every stencil point lies in the prior support.

    Notes
    -----
    ``1 + 2 k²`` points for ``k`` differentiated coordinates: the centre, ``±h_i`` along each
    axis and the four corners ``(±h_i, ±h_j)`` of every pair, evaluated in one vectorised
    :meth:`Problem.log_posterior` call.
    """
    z = np.asarray(z, dtype=float)
    d = z.size
    free = np.ones(d, dtype=bool) if free is None else np.asarray(free, dtype=bool)
    idx = np.flatnonzero(free)
    k = idx.size
    lo, hi = problem.internal_bounds
    h = np.minimum(np.asarray(h, dtype=float), 0.2 * np.where(np.isfinite(hi - lo), hi - lo, np.inf))
    zc = np.where(free, _interior(problem, z, 1.5 * h), z)
    grad = np.zeros(d)
    hess = np.zeros((d, d))
    if k == 0:
        return float(problem.log_posterior(zc)[0]), grad, hess, zc
    hk = h[idx]
    e = np.zeros((k, d))
    e[np.arange(k), idx] = hk
    iu, ju = np.triu_indices(k, 1)
    pts = np.concatenate(
        [
            zc[None, :],
            zc + e,
            zc - e,
            zc + e[iu] + e[ju],
            zc + e[iu] - e[ju],
            zc - e[iu] + e[ju],
            zc - e[iu] - e[ju],
        ]
    )
    f = problem.log_posterior(pts)
    f0 = f[0]
    fp, fm = f[1 : 1 + k], f[1 + k : 1 + 2 * k]
    m = len(iu)
    fpp, fpm, fmp, fmm = (f[1 + 2 * k + j * m : 1 + 2 * k + (j + 1) * m] for j in range(4))
    grad[idx] = (fp - fm) / (2.0 * hk)
    sub = np.empty((k, k))
    sub[np.diag_indices(k)] = (fp - 2.0 * f0 + fm) / (hk * hk)
    off = (fpp - fpm - fmp + fmm) / (4.0 * hk[iu] * hk[ju])
    sub[iu, ju] = off
    sub[ju, iu] = off
    hess[np.ix_(idx, idx)] = sub
    return float(f0), grad, hess, zc


def _complete_guess(problem: Problem, guess: Mapping[str, float]) -> np.ndarray:
    """Internal vector of a (possibly partial) guess; noise parameters from its residuals."""
    values: dict[str, float] = {}
    for p in problem.parameters:
        if p.name in guess:
            values[p.name] = float(guess[p.name])
        else:  # physical: prior centre; noise: placeholder replaced below
            values[p.name] = float(p.prior.from_internal(p.prior.internal_centre()))
    z = _interior(problem, problem.to_internal(values), 1e-6 * _scales(problem))
    missing_noise = [n for n in problem.noise_names if n in problem.names and n not in guess]
    if missing_noise:
        natural = {n: float(v[0]) for n, v in problem.from_internal(z).items()}
        noise = problem.noise_estimate(natural)
        for n in missing_noise:
            prior = problem.parameter(n).prior
            z[problem.index(n)] = prior.to_internal(max(noise[n], 1e-300) if prior.log_coordinate else noise[n])
    return _interior(problem, np.nan_to_num(z, nan=0.0), 1e-6 * _scales(problem))


def _least_squares_stage(problem: Problem, z0: np.ndarray, max_nfev: int) -> np.ndarray:
    """Stage 1: fit the physical parameters with the noise parameters held at ``z0``."""
    idx = np.array([problem.index(n) for n in problem.model_names], dtype=int)
    if idx.size == 0:
        return z0
    lo, hi = problem.internal_bounds
    lo, hi = lo[idx], hi[idx]
    scale = _scales(problem)[idx]
    priors = [problem.parameters[i].prior for i in idx]
    cache: dict[str, object] = {}

    def evaluate(x: np.ndarray):
        key = x.tobytes()
        if cache.get("key") == key:
            return cache["r"], cache["J"]
        h = _SQRT_EPS * np.maximum(np.abs(x), scale)
        h = np.where(x + h > hi, -h, h)  # step backwards on an upper bound
        zz = np.tile(z0, (1 + idx.size, 1))
        zz[:, idx] = x
        zz[1 + np.arange(idx.size), idx] += h
        w = problem.whitened_residuals(zz)
        jac = ((w[1:] - w[0]) / h[:, None]).T
        pr = [p.pseudo_residual(xi) for p, xi in zip(priors, x)]
        rows = [w[0]] + pr
        jrows = [jac]
        for k, (p, r) in enumerate(zip(priors, pr)):
            if r.size:
                jp = np.zeros((r.size, idx.size))
                jp[:, k] = (p.pseudo_residual(x[k] + h[k]) - r) / h[k]
                jrows.append(jp)
        r_all = np.concatenate(rows)
        j_all = np.vstack(jrows)
        if not np.all(np.isfinite(r_all)):
            r_all = np.where(np.isfinite(r_all), r_all, 1e150)
            j_all = np.nan_to_num(j_all, nan=0.0, posinf=0.0, neginf=0.0)
        cache.update(key=key, r=r_all, J=j_all)
        return r_all, j_all

    x0 = np.clip(z0[idx], lo + 1e-9 * scale, hi - 1e-9 * scale)
    sol = optimize.least_squares(
        lambda x: evaluate(x)[0],
        x0,
        jac=lambda x: evaluate(x)[1],
        bounds=(lo, hi),
        method="trf",
        x_scale="jac",
        max_nfev=max_nfev,
    )
    z = z0.copy()
    z[idx] = sol.x
    return z


def _update_noise(problem: Problem, z: np.ndarray) -> np.ndarray:
    """Replace the sampled noise parameters of ``z`` by moment estimates from its residuals."""
    noise_idx = [problem.index(n) for n in problem.noise_names if n in problem.names]
    if not noise_idx:
        return z
    values = {n: float(v[0]) for n, v in problem.from_internal(z).items()}
    noise = problem.noise_estimate(values)
    z = z.copy()
    for n in problem.noise_names:
        if n in problem.names:
            prior = problem.parameter(n).prior
            z[problem.index(n)] = prior.to_internal(max(noise[n], 1e-300) if prior.log_coordinate else noise[n])
    return _interior(problem, z, 1e-6 * _scales(problem))


def _initial_steps(problem: Problem, z: np.ndarray) -> np.ndarray:
    """First finite-difference steps, from the Gauss-Newton (Fisher) approximation of -H."""
    d = problem.ndim
    scale = _scales(problem)
    h = 1e-3 * scale
    h0 = _SQRT_EPS * np.maximum(np.abs(z), scale)
    zz = np.tile(_interior(problem, z, 2.0 * h0), (d + 1, 1))
    zz[1 + np.arange(d), np.arange(d)] += h0
    w = problem.whitened_residuals(zz)
    jac = ((w[1:] - w[0]) / h0[:, None]).T
    fisher = jac.T @ jac
    for name in problem.noise_names:  # whitened residuals miss the log-determinant terms
        if name in problem.names:
            i = problem.index(name)
            fisher[i, i] += 2.0 * problem.data.size
    return steps_from_hessian(-np.diag(fisher), h, scale)


def steps_from_hessian(hessian_diagonal: np.ndarray, fallback: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Finite-difference steps of a tenth of the *conditional* posterior sd, ``0.1 / sqrt(-H_ii)``,
    clipped to [1e-10, 0.05] x the prior scale (``fallback`` where -H_ii is not positive).

    The conditional (not marginal) width is the scale on which the log posterior changes
    along one axis, which is what the accuracy of a difference quotient depends on.
    """
    curvature = -np.asarray(hessian_diagonal, dtype=float)
    positive = np.isfinite(curvature) & (curvature > 0.0)
    h = np.where(positive, 0.1 / np.sqrt(np.where(positive, curvature, 1.0)), fallback)
    return np.clip(h, 1e-10 * scale, 0.05 * scale)


def newton_step(grad: np.ndarray, hess: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Modified Newton step along the free coordinates (curvatures replaced by their magnitude,
    floored at 1e-8 of the largest: an ascent direction also where the log posterior is not
    concave)."""
    step = np.zeros_like(grad)
    if np.any(free):
        w, v = np.linalg.eigh(-hess[np.ix_(free, free)])
        w = np.maximum(np.abs(w), 1e-8 * max(abs(w).max(), 1e-300))
        step[free] = v @ ((v.T @ grad[free]) / w)
    return step


@dataclass
class NewtonOutcome:
    """Where :func:`newton_iterations` stopped (internal coordinates)."""

    z: np.ndarray
    gradient: np.ndarray | None
    hessian: np.ndarray | None
    hessian_point: np.ndarray | None
    converged: bool
    message: str
    iterations: int
    steps: np.ndarray


def newton_iterations(
    problem: Problem,
    z: np.ndarray,
    h: np.ndarray,
    *,
    max_iterations: int,
    tolerance: float,
    stall_decrement: float = 0.0,
    stall_gain: float = 0.0,
) -> NewtonOutcome:
    """Newton iteration on the log posterior with finite-difference derivatives.

    Each iteration: central-difference gradient and Hessian in one batched call
    (:func:`fd_derivatives`), an active set on the bounds (a coordinate within two steps of a
    bound with the gradient pushing out is pinned there), the modified Newton step
    (:func:`newton_step`) and a backtracking line search whose 12 trial points are evaluated in
    one call. At convergence (Newton decrement below ``tolerance`` nats) the Hessian is refreshed
    once with steps matched to the posterior width (:func:`steps_from_hessian`).

    ``stall_decrement`` / ``stall_gain`` (default off): stop once a step from a point whose
    decrement is below ``stall_decrement`` nats gains less than ``stall_gain`` nats — the
    finite-difference Hessian cannot resolve a nearly flat, non-quadratic direction better.

    Parameters
    ----------
    problem : Problem
        The problem.
    z : ndarray, shape (ndim,)
        Starting point, internal coordinates.
    h : ndarray, shape (ndim,)
        First finite-difference steps, internal coordinates.
    max_iterations : int
        Iteration cap.
    tolerance : float
        Newton decrement (expected log-posterior gain, nats) at which to stop.
    """
    lo, hi = problem.internal_bounds
    scale = _scales(problem)
    z = np.asarray(z, dtype=float).copy()
    converged, message, iteration = False, "Newton iteration limit reached", 0
    grad = hess = zc = None
    for iteration in range(1, max_iterations + 1):
        report(f"Newton polish of the MAP: iteration {iteration}")
        converged = False
        f0, grad, hess, zc = fd_derivatives(problem, z, h)
        if not (np.isfinite(f0) and np.all(np.isfinite(grad)) and np.all(np.isfinite(hess))):
            message = "non-finite log posterior near the optimum"
            break
        free = ~(((z <= lo + 2.0 * h) & (grad < 0.0)) | ((z >= hi - 2.0 * h) & (grad > 0.0)))
        if np.all(free) and np.array_equal(zc, z):
            z_eval, g_free, h_free, f_ref = z, grad, hess, f0
        else:  # derivatives along the free coordinates with the pinned ones exactly on their bound
            f_ref, g_free, h_free, z_eval = fd_derivatives(problem, np.where(free, zc, z), h, free)
        step = newton_step(g_free, h_free, free)
        decrement = float(g_free @ step)
        new_h = steps_from_hessian(np.diag(hess), h, scale)
        if decrement < tolerance:
            converged, message, z = True, "converged", z_eval
            if np.allclose(new_h, h, rtol=0.5):
                break
            h = new_h  # refresh the Hessian once with steps matched to the posterior width
            continue
        ts = 0.5 ** np.arange(0, 12)
        candidates = np.clip(z_eval + ts[:, None] * step, lo, hi)
        f = problem.log_posterior(candidates)
        ok = f >= f_ref + 1e-4 * ts * decrement
        if not np.any(ok):
            if np.max(f) > f_ref:
                z = candidates[int(np.argmax(f))]
            elif decrement < FD_LIMITED_DECREMENT:
                converged, message, z = True, "converged to the accuracy of the finite differences", z_eval
                break
            else:
                message = "line search failed to improve the log posterior"
                break
        else:
            best = int(np.argmax(ok))
            z = candidates[best]
            if decrement < stall_decrement and f[best] - f_ref < stall_gain:
                converged, message = True, "converged to the accuracy of the finite differences"
                break
        h = new_h
    return NewtonOutcome(z, grad, hess, zc, converged, message, iteration, h)


def find_map(
    problem: Problem,
    guesses: Sequence[Mapping[str, float]] | None = None,
    *,
    max_nfev: int = 200,
    max_newton: int = 30,
    tol: float = 1e-7,
) -> MapResult:
    """Maximum a posteriori estimate, robust to the multimodality of oscillation fits.

    Parameters
    ----------
    problem : Problem
        The calibration problem.
    guesses : sequence of mapping, optional
        Starting points in natural units (keys may be partial, see
        :class:`~beam.inference.problem.Problem`). Default: ``problem.initial_guesses(problem)``
        when the problem has that hook, else :func:`default_initial_guesses`.
    max_nfev : int
        Function-evaluation cap of each least-squares start.
    max_newton : int
        Iteration cap of the Newton polish.
    tol : float
        Newton decrement (expected log-posterior gain, nats) at which to stop.

    Returns
    -------
    MapResult
    """
    if guesses is None:
        guesses = problem.initial_guesses(problem) if problem.initial_guesses else default_initial_guesses(problem)
    guesses = list(guesses)
    if not guesses:
        raise ValueError("find_map needs at least one initial guess")
    starts, start_lp = [], []
    two_pass = problem.likelihood != "iid"
    for i, guess in enumerate(guesses, 1):
        report(f"MAP search: start {i} of {len(guesses)}")
        z = _complete_guess(problem, guess)
        z = _update_noise(problem, _least_squares_stage(problem, z, max_nfev))
        if two_pass:  # the whitening depends on the noise parameters: fit once more
            z = _update_noise(problem, _least_squares_stage(problem, z, max_nfev))
        lp = float(problem.log_posterior(z)[0])
        starts.append(z)
        start_lp.append(lp if np.isfinite(lp) else -np.inf)
    best = int(np.argmax(start_lp))
    if not np.isfinite(start_lp[best]):
        raise ValueError("no starting point has a finite log posterior")
    newton = newton_iterations(problem, starts[best], _initial_steps(problem, starts[best]), max_iterations=max_newton,
                               tolerance=tol)
    z, grad, hess, zc = newton.z, newton.gradient, newton.hessian, newton.hessian_point
    converged, message, n_it = newton.converged, newton.message, newton.iterations
    lo, hi = problem.internal_bounds
    h = steps_from_hessian(np.diag(hess), _initial_steps(problem, z), _scales(problem))
    at_bound = tuple(n for i, n in enumerate(problem.names) if z[i] <= lo[i] + 2 * h[i] or z[i] >= hi[i] - 2 * h[i])
    lp = float(problem.log_posterior(z)[0])
    values = {n: float(v[0]) for n, v in problem.from_internal(z).items()}
    return MapResult(
        z=z,
        values=values,
        log_posterior=lp,
        gradient=grad,
        hessian=hess,
        hessian_point=zc,
        converged=converged,
        message=message,
        n_starts=len(guesses),
        start_log_posteriors=start_lp,
        at_bound=at_bound,
        n_iterations=n_it,
    )
