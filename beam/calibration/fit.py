"""Fast MAP search for the beam calibration: every start in one batched model call per step.

:func:`beam.inference.find_map` runs one :func:`scipy.optimize.least_squares` per start, each
iteration one model call of 1 + k parameter sets (the point and its k forward-difference
neighbours), and then a Newton polish with a full finite-difference Hessian per iteration. On
the beam that is 500-800 parameter sets in ~100 small calls, where the per-call overhead of the
model and of scipy dominates. Here instead:

1. **Lock-step Levenberg–Marquardt** (:func:`levenberg_marquardt`): all starting points advance
   together; one model call per iteration evaluates, for every active start, the trial point
   *and* its forward-difference stencil (so an accepted step already has its Jacobian; a
   rejected one costs nothing but that call). Residuals are the whitened data residuals plus
   one pseudo-residual per Gaussian prior (exact, analytic Jacobian). The noise parameters are
   profiled: re-estimated from each trial's residuals (for the i.i.d. likelihood, the
   conditional MAP of the noise sd exactly; the acceptance test compares the log posterior at
   those noise values, i.e. the profile posterior). Moré's scaling (running maximum of the
   column norms), Nielsen's damping update, a box trust region on the steps (see
   :data:`LM_RADIUS`), bounds by projection with an active set. A start has converged when the
   undamped Gauss–Newton model predicts less than :data:`LM_TOLERANCE` nats of further gain.
   A start that settles in a basin clearly worse than another start's optimum, or comes close
   to a better start (:data:`LM_SAME_POINT`), is dropped; one still climbing never is.
2. **Trust-region continuation**: a start still improving after :data:`LM_MAX_ITERATIONS`
   lock-step iterations continues alone with :func:`scipy.optimize.least_squares`
   (trust-region reflective, the stage-1 search of :func:`beam.inference.find_map`).
3. **Newton polish of the best start** (:func:`newton_polish`) with the central finite-
   difference gradient and Hessian of the log posterior over all parameters, noise included —
   the Newton iteration of :func:`beam.inference.find_map` (active set on bounds, modified
   Newton, batched line search). Levenberg–Marquardt stops at a coarse tolerance because near
   the optimum the Gauss–Newton matrix misses the curvature of flat directions (two damping
   mechanisms trading off under model discrepancy) and converges only linearly there; Newton
   converges in one or two iterations, and its final Hessian is the one the Laplace
   approximation uses: the same Hessian as before, not a Gauss–Newton approximation (the
   Laplace evidence ranks candidate effects, and with missing physics the residual-curvature
   term that Gauss–Newton drops is not small).

From the same starts it finds the MAPs of :func:`beam.inference.find_map` from a third or less
of the parameter sets (the measurements: ``docs/decisions.md``, inference).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numba
import numpy as np
from scipy import optimize

from beam.inference import AR1_COEFFICIENT, NOISE_SD, MapResult, Problem
from beam.inference.likelihood import log_likelihood, whiten
from beam.inference.optimize import newton_iterations, steps_from_hessian
from beam.inference.progress import report, reporting

__all__ = ["LmResult", "fast_map", "internal_starts", "levenberg_marquardt", "newton_polish"]

_SQRT_EPS = float(np.sqrt(np.finfo(float).eps))
#: Predicted decrease of the negative log posterior (nats) below which a start has converged
#: (the Newton polish takes it from there).
LM_TOLERANCE = 0.1
#: Iteration cap of the lock-step Levenberg–Marquardt; a start still improving then continues
#: alone with scipy's trust-region reflective least squares (at most TRUST_REGION_MAX_NFEV
#: evaluations, the cap of the old search).
LM_MAX_ITERATIONS = 40
TRUST_REGION_MAX_NFEV = 200
#: Box trust region of the steps, per coordinate, in units of min(1, prior scale): LM_RADIUS
#: at first (a factor e for a parameter sampled in log), doubled (up to LM_MAX_RADIUS) after a
#: good step the box shortened, halved after a rejected one. A step that leaves the box is
#: recomputed with the damping raised by LM_BOX_FACTORS until it fits: without the box the
#: Gauss–Newton extrapolation along a parameter the data barely feel yet (an effect switched on
#: weakly) jumps from bound to bound.
LM_RADIUS = 1.0
LM_MAX_RADIUS = 8.0
LM_MIN_RADIUS = 1e-6
LM_BOX_FACTORS = 4.0 ** np.arange(0, 9)
#: A start more than LM_DROP_MARGIN nats worse than a converged one and nearly settled (the
#: Gauss–Newton model expects less than LM_DROP_SETTLED nats, and less than a tenth of the gap)
#: is dropped: a worse basin. A start still climbing is never dropped, however far behind: a
#: crawl along a valley can end 1,700 nats higher (a tip mass switched on from 20 % of its range).
LM_DROP_MARGIN = 5.0
LM_DROP_SETTLED = 1.0
#: An active start this close to a better start, in every coordinate (units of min(1, prior
#: scale)) and in the Gauss–Newton metric (nats, ½ δᵀ JᵀJ δ at the better start), is in its
#: basin and dropped. Basins of an oscillation fit lie whole phase cycles apart, thousands of
#: posterior sd along the frequency.
LM_SAME_POINT = 0.5
LM_SAME_BASIN = 10.0
#: The Newton polish stops once a step from a point with a decrement below
#: POLISH_STALL_DECREMENT nats (~0.1 posterior sd from the mode) gains less than
#: POLISH_STALL_GAIN nats: either it converges quadratically and is there, or the finite-
#: difference Hessian cannot resolve a nearly flat, non-quadratic direction any better.
POLISH_STALL_DECREMENT = 1e-2
POLISH_STALL_GAIN = 1e-3


@dataclass
class LmResult:
    """Outcome of :func:`levenberg_marquardt` for every start.

    Attributes
    ----------
    z : ndarray, shape (m, ndim)
        Final point of each start, internal coordinates (noise parameters profiled).
    log_posterior : ndarray, shape (m,)
        Log posterior there (nats); ``-inf`` for a start without a finite one.
    converged : ndarray of bool, shape (m,)
        Whether each start met the tolerance, or its trust-region continuation converged
        (False for dropped starts).
    dropped : ndarray of bool, shape (m,)
        Starts abandoned in a worse basin or in a better start's basin.
    iterations : int
        Lock-step iterations (= batched model calls - 1, besides any continuation).
    fd_steps : ndarray, shape (m, ndim)
        Finite-difference steps for a Newton polish from each final point: a tenth of the
        conditional sd of the Gauss–Newton (Fisher) curvature, internal coordinates.
    """

    z: np.ndarray
    log_posterior: np.ndarray
    converged: np.ndarray
    dropped: np.ndarray
    iterations: int
    fd_steps: np.ndarray

    @property
    def best(self) -> int:
        """Index of the start with the highest log posterior."""
        return int(np.argmax(self.log_posterior))


class _Objective:
    """Residuals, Jacobians and profiled noise of a problem at a batch of trial points."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.model_index = np.array([problem.index(n) for n in problem.model_names], dtype=int)
        self.noise_index = {n: problem.index(n) for n in problem.noise_names if n in problem.names}
        lo, hi = problem.internal_bounds
        self.lo, self.hi = lo, hi
        self.scale = np.array([p.prior.internal_scale for p in problem.parameters])
        quadratic = [problem.parameters[i].prior.internal_quadratic() for i in self.model_index]
        gaussian = [j for j, q in enumerate(quadratic) if q is not None and np.isfinite(q[2])]
        self.prior_columns = np.array(gaussian, dtype=int)
        self.prior_mu = np.array([quadratic[j][1] for j in gaussian])
        self.prior_sigma = np.array([quadratic[j][2] for j in gaussian])
        # the column the prediction is proportional to (Problem.proportional_to), or -1
        column = problem.index(problem.proportional_to) if problem.proportional_to is not None else -1
        hits = np.flatnonzero(self.model_index == column)
        self.proportional = int(hits[0]) if hits.size else -1
        self.proportional_prior = problem.parameters[column].prior if hits.size else None

    @property
    def k(self) -> int:
        return self.model_index.size

    def steps(self, x: np.ndarray) -> np.ndarray:
        """Forward-difference steps (m, k), backwards near an upper bound."""
        hi, scale = self.hi[self.model_index], self.scale[self.model_index]
        h = _SQRT_EPS * np.maximum(np.abs(x), scale)
        return np.where(x + h > hi, -h, h)

    def full(self, x: np.ndarray, noise_z: np.ndarray) -> np.ndarray:
        """Internal vectors (m, ndim) from model coordinates (m, k) and noise coordinates."""
        z = noise_z.copy()
        z[:, self.model_index] = x
        return z

    def evaluate(self, x: np.ndarray, template: np.ndarray, *, profile: bool = True):
        """Internal points, log posteriors, stacked residuals (m, N) and Jacobians (m, N, k) at
        points ``x`` (m, k).

        One model call for all points and their stencils; ``template`` (m, ndim) supplies the
        noise coordinates, re-estimated from each point's residuals when ``profile``. The
        stencil row of a parameter the prediction is proportional to
        (:attr:`~beam.inference.Problem.proportional_to`) is the point's prediction scaled by
        the perturbed value over the value, not a model call: the same finite difference for one
        row in 1 + k fewer (a seventh of the rows of a patch model's search).
        """
        problem, k = self.problem, self.k
        m = x.shape[0]
        h = self.steps(x)
        stencil = np.repeat(x[:, None, :], 1 + k, axis=1)
        stencil[:, 1 + np.arange(k), np.arange(k)] += h
        called = np.ones(1 + k, dtype=bool)
        if self.proportional >= 0:
            called[1 + self.proportional] = False
        width = int(called.sum())
        rows = self.full(stencil[:, called].reshape(m * width, k), np.repeat(template, width, axis=0))
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            computed = problem.predict(problem.from_internal(rows)).reshape(m, width, -1)
        if width == 1 + k:
            prediction = computed
        else:
            c, prior = self.proportional, self.proportional_prior
            prediction = np.empty((m, 1 + k, computed.shape[-1]))
            prediction[:, called] = computed
            with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
                ratio = prior.from_internal(x[:, c] + h[:, c]) / prior.from_internal(x[:, c])
            prediction[:, 1 + c] = computed[:, 0] * ratio[:, None]
        residual = problem.data - prediction
        z = template.copy()
        z[:, self.model_index] = x
        if profile:
            z = self._profiled_noise(residual[:, 0], z)
        values = problem.from_internal(z)
        noise_values = {n: values[n] for n in problem.noise_names}
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            lp = problem.log_prior(z) + log_likelihood(problem.likelihood, residual[:, 0], noise_values)
            white = whiten(problem.likelihood, residual.reshape(m * (1 + k), -1),
                           {n: np.repeat(v, 1 + k) for n, v in noise_values.items()}).reshape(m, 1 + k, -1)
        lp = np.where(np.isfinite(lp), lp, -np.inf)
        jac = np.swapaxes((white[:, 1:] - white[:, :1]) / h[:, :, None], 1, 2)  # (m, n, k)
        r, jac = self._with_priors(white[:, 0], jac, x)
        return z, lp, r, jac

    def _profiled_noise(self, residual: np.ndarray, z: np.ndarray) -> np.ndarray:
        """``z`` with its noise coordinates set to the moment estimates of
        :func:`beam.inference.likelihood.estimate_noise_parameters` from ``residual`` (m, n):
        the residual RMS and, for AR(1), the lag-one autocorrelation clipped to ±0.98."""
        estimates = {NOISE_SD: np.sqrt(np.mean(residual * residual, axis=1))}
        if AR1_COEFFICIENT in self.noise_index:
            denominator = np.einsum("ij,ij->i", residual[:, :-1], residual[:, :-1])
            numerator = np.einsum("ij,ij->i", residual[:, 1:], residual[:, :-1])
            safe = np.where(denominator > 0.0, denominator, 1.0)
            estimates[AR1_COEFFICIENT] = np.clip(np.where(denominator > 0.0, numerator / safe, 0.0), -0.98, 0.98)
        for name, column in self.noise_index.items():
            prior = self.problem.parameters[column].prior
            value = np.maximum(estimates[name], 1e-300) if prior.log_coordinate else estimates[name]
            margin = 1e-6 * self.scale[column]
            with np.errstate(invalid="ignore"):
                internal = np.clip(prior.to_internal(value), self.lo[column] + margin, self.hi[column] - margin)
            z[:, column] = np.where(np.isfinite(internal), internal, z[:, column])
        return z

    def fisher_steps(self, jac: np.ndarray) -> np.ndarray:
        """Finite-difference steps (m, ndim) from the Gauss–Newton curvature of Jacobians ``jac``
        (m, N, k); the noise sd's curvature in its log coordinate is 2n (i.i.d. Fisher)."""
        m = jac.shape[0]
        diagonal = np.zeros((m, self.problem.ndim))
        diagonal[:, self.model_index] = -np.sum(jac * jac, axis=1)
        if NOISE_SD in self.noise_index:
            diagonal[:, self.noise_index[NOISE_SD]] = -2.0 * self.problem.data.size
        return np.array([steps_from_hessian(d, 1e-3 * self.scale, self.scale) for d in diagonal]).reshape(m, -1)

    def _with_priors(self, white: np.ndarray, jac: np.ndarray, x: np.ndarray):
        """Append the Gaussian priors' pseudo-residuals and their (constant) Jacobian rows."""
        if self.prior_columns.size == 0:
            return white, jac
        m, p = x.shape[0], self.prior_columns.size
        pseudo = (x[:, self.prior_columns] - self.prior_mu) / self.prior_sigma
        rows = np.zeros((m, p, self.k))
        rows[:, np.arange(p), self.prior_columns] = 1.0 / self.prior_sigma
        return np.concatenate([white, pseudo], axis=1), np.concatenate([jac, rows], axis=1)


def _lm_steps(r: np.ndarray, jac: np.ndarray, lam: np.ndarray, x: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              scaling: np.ndarray, cap: np.ndarray):
    """Levenberg–Marquardt steps of m starts at once (Moré's scaling ``scaling``, (m, k)), with
    coordinates pinned on a bound they would leave, inside the box ±``cap`` (m, k).

    A step that leaves the box is recomputed with the damping raised by the factors
    :data:`LM_BOX_FACTORS` (a shorter step, turned towards the scaled gradient) until it fits;
    as a last resort it is shortened along its direction. (Clipping the components instead can
    turn it uphill.)

    Returns
    -------
    steps : ndarray, shape (m, k)
        The steps.
    gains : ndarray, shape (m,)
        Decrease of ½|r|² the linear model predicts for them.
    clipped : ndarray of bool, shape (m,)
        Which steps the box shortened.
    gauss_newton : ndarray, shape (m,)
        Decrease the linear model predicts for the undamped, unbounded (Gauss–Newton) step:
        how much is left to gain, as far as the model can tell.
    """
    jac_t = np.swapaxes(jac, 1, 2)
    g = np.ascontiguousarray((jac_t @ r[:, :, None])[:, :, 0])
    a = np.ascontiguousarray(jac_t @ jac)
    span = hi - lo
    pinned = ((x <= lo + 1e-9 * span) & (g > 0.0)) | ((x >= hi - 1e-9 * span) & (g < 0.0))
    floor = 1e-12 * np.max(scaling, axis=1, keepdims=True) + 1e-300  # a column the data never felt
    diagonal = np.ascontiguousarray(np.maximum(scaling, floor))
    m, k = x.shape
    steps, gains, clipped, gauss_newton = np.zeros((m, k)), np.zeros(m), np.zeros(m, dtype=np.bool_), np.zeros(m)
    _lm_kernel(a, g, diagonal, np.ascontiguousarray(lam, dtype=float), pinned, np.ascontiguousarray(cap, dtype=float),
               LM_BOX_FACTORS, steps, gains, clipped, gauss_newton)
    return steps, gains, clipped, gauss_newton


@numba.njit(cache=True, nogil=True)
def _solve_small(matrix, rhs, free):
    """Solution of ``matrix[free][:, free] s = rhs[free]`` (zeros elsewhere), by Gaussian
    elimination with partial pivoting; a vanishing pivot leaves its component at zero."""
    k = rhs.size
    index = np.flatnonzero(free)
    n = index.size
    work = np.empty((n, n + 1))
    for i in range(n):
        for j in range(n):
            work[i, j] = matrix[index[i], index[j]]
        work[i, n] = rhs[index[i]]
    scale = 0.0
    for i in range(n):
        scale = max(scale, abs(work[i, i]))
    for col in range(n):
        pivot = col
        for row in range(col + 1, n):
            if abs(work[row, col]) > abs(work[pivot, col]):
                pivot = row
        if pivot != col:
            for j in range(n + 1):
                work[col, j], work[pivot, j] = work[pivot, j], work[col, j]
        if abs(work[col, col]) <= 1e-300 + 1e-15 * scale:
            continue
        for row in range(col + 1, n):
            factor = work[row, col] / work[col, col]
            for j in range(col, n + 1):
                work[row, j] -= factor * work[col, j]
    solution = np.zeros(n)
    for i in range(n - 1, -1, -1):
        if abs(work[i, i]) <= 1e-300 + 1e-15 * scale:
            continue
        total = work[i, n]
        for j in range(i + 1, n):
            total -= work[i, j] * solution[j]
        solution[i] = total / work[i, i]
    out = np.zeros(k)
    for i in range(n):
        out[index[i]] = solution[i] if np.isfinite(solution[i]) else 0.0
    return out


@numba.njit(cache=True, nogil=True)
def _model_gain(a, g, step):
    """Decrease of ½|r + J s|² from s = 0 for the normal equations ``a = JᵀJ``, ``g = Jᵀr``."""
    k = g.size
    total = 0.0
    for i in range(k):
        quadratic = 0.0
        for j in range(k):
            quadratic += a[i, j] * step[j]
        total -= g[i] * step[i] + 0.5 * step[i] * quadratic
    return total


@numba.njit(cache=True, nogil=True)
def _lm_kernel(a, g, diagonal, lam, pinned, cap, factors, steps, gains, clipped, gauss_newton):
    """The work of :func:`_lm_steps`, start by start."""
    m, k = g.shape
    system = np.empty((k, k))
    for i in range(m):
        free = ~pinned[i]
        rhs = -g[i]
        for damping_index in range(factors.size + 1):
            damping = 1e-12 if damping_index == 0 else factors[damping_index - 1] * lam[i]
            for p in range(k):
                for q in range(k):
                    system[p, q] = a[i, p, q]
                system[p, p] += damping * diagonal[i, p]
            step = _solve_small(system, rhs, free)
            if damping_index == 0:
                gauss_newton[i] = _model_gain(a[i], g[i], step)
                continue
            excess = 0.0
            for p in range(k):
                excess = max(excess, abs(step[p]) / cap[i, p])
            if excess <= 1.0 or damping_index == factors.size:
                if excess > 1.0:
                    step = step / excess
                clipped[i] = damping_index > 1 or excess > 1.0
                steps[i] = step
                gains[i] = _model_gain(a[i], g[i], step)
                break


def levenberg_marquardt(
    problem: Problem, starts: np.ndarray, *, max_iterations: int = LM_MAX_ITERATIONS, tolerance: float = LM_TOLERANCE,
    continuation: bool = True, race: tuple[int, int] | None = None,
) -> LmResult:
    """Lock-step Levenberg–Marquardt from several starts (see the module notes).

    Parameters
    ----------
    problem : Problem
        The calibration problem.
    starts : ndarray, shape (m, ndim)
        Starting points in internal coordinates (noise columns are re-estimated).
    max_iterations : int
        Cap on lock-step iterations.
    tolerance : float
        Decrease of the negative log posterior (nats) left by the Gauss–Newton model at which a
        start has converged.
    continuation : bool
        Whether a start still improving after ``max_iterations`` continues alone (trust region);
        False for a screening of many starts by a few iterations.
    race : (iterations, kept) or None
        A race among many starts (successive halving): after ``iterations`` lock-step
        iterations every start not among the ``kept`` best (log posterior; converged ones
        included) is dropped, and only those go on.

    Returns
    -------
    LmResult
    """
    objective = _Objective(problem)
    lo, hi = objective.lo[objective.model_index], objective.hi[objective.model_index]
    margin = 1e-9 * np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    unit = np.minimum(1.0, objective.scale[objective.model_index])
    z = np.atleast_2d(np.asarray(starts, dtype=float)).copy()
    m = z.shape[0]
    x = np.clip(z[:, objective.model_index], lo + margin, hi - margin)
    z, lp, r, jac = objective.evaluate(x, z)
    lam = np.full(m, 1e-3)
    nu = np.full(m, 2.0)
    radius = np.full(m, LM_RADIUS)
    scaling = np.zeros((m, objective.k))
    converged = np.zeros(m, dtype=bool)
    dropped = np.zeros(m, dtype=bool)
    predicted = np.full(m, np.inf)
    iterations = 0
    for iterations in range(1, max_iterations + 1):
        active = ~converged & ~dropped & np.isfinite(lp)
        if not np.any(active):
            break
        index = np.flatnonzero(active)
        report(f"MAP search: iteration {iterations}, {index.size} of {m} starts going")
        scaling[index] = np.maximum(scaling[index], np.sum(jac[index] ** 2, axis=1))  # Moré: running maximum
        steps, step_gain, clipped, predicted[index] = _lm_steps(r[index], jac[index], lam[index], x[index], lo, hi,
                                                                scaling[index], radius[index, None] * unit)
        converged |= active & (predicted < tolerance)
        _drop_worse_basins(lp, predicted, converged, dropped)
        _drop_duplicates(x, lp, jac, converged, dropped, unit)
        keep = ~converged[index] & ~dropped[index]
        if not np.any(keep):
            break
        index, steps, step_gain, clipped = index[keep], steps[keep], step_gain[keep], clipped[keep]
        trial = np.clip(x[index] + steps, lo + margin, hi - margin)
        z_t, lp_t, r_t, jac_t = objective.evaluate(trial, z[index])
        gain = lp_t - lp[index]
        better = gain > 0.0
        accepted, rejected = index[better], index[~better]
        rho = np.minimum(gain[better] / np.maximum(step_gain[better], 1e-300), 1.0)
        lam[accepted] *= np.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
        nu[accepted] = 2.0
        grow = accepted[clipped[better] & (rho > 0.75)]
        radius[grow] = np.minimum(2.0 * radius[grow], LM_MAX_RADIUS)
        x[accepted], z[accepted], lp[accepted] = trial[better], z_t[better], lp_t[better]
        r[accepted], jac[accepted] = r_t[better], jac_t[better]
        lam[rejected] *= nu[rejected]
        nu[rejected] *= 2.0
        shrink = rejected[clipped[~better]]
        radius[shrink] = np.maximum(0.5 * radius[shrink], LM_MIN_RADIUS)
        converged[rejected[lam[rejected] > 1e12]] = True  # no descent left at the Jacobian's accuracy
        if race is not None and iterations == race[0]:
            _drop_all_but_best(lp, dropped, race[1])
    # no continuation for those; against the best start, converged or not: its point's log
    # posterior is already reached, whatever its own continuation adds
    _drop_worse_basins(lp, predicted, converged, dropped, settled=np.inf, reference=float(np.max(lp)))
    for i in np.flatnonzero(~converged & ~dropped & np.isfinite(lp) & continuation):  # still improving: trust region
        with reporting(None, f"MAP search: start {i + 1} of {m} continues alone"):
            x[i], z[i], lp[i], jac[i], converged[i] = _trust_region(objective, x[i], z[i], lo + margin, hi - margin)
    return LmResult(z=z, log_posterior=lp, converged=converged & ~dropped, dropped=dropped, iterations=iterations,
                    fd_steps=objective.fisher_steps(jac))


def _trust_region(objective: _Objective, x: np.ndarray, z: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                  max_nfev: int = TRUST_REGION_MAX_NFEV):
    """Continue one start with :func:`scipy.optimize.least_squares` (trust-region reflective,
    Moré's scaling; the noise parameters held at ``z``'s, then re-estimated): the search of
    :func:`beam.inference.find_map`, for a start that is still improving after the lock-step
    iterations (a long, curved valley, e.g. stiffness against a tip mass)."""
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
    evaluations = [0]

    def residuals_and_jacobian(point: np.ndarray):
        key = point.tobytes()
        if key not in cache:
            cache.clear()
            evaluations[0] += 1
            report(f"evaluation {evaluations[0]} of at most {max_nfev}")
            _, _, r, jac = objective.evaluate(point[None, :], z[None, :], profile=False)
            r, jac = r[0], jac[0]
            if not np.all(np.isfinite(r)):
                r = np.where(np.isfinite(r), r, 1e150)
                jac = np.nan_to_num(jac, nan=0.0, posinf=0.0, neginf=0.0)
            cache[key] = (r, jac)
        return cache[key]

    solution = optimize.least_squares(lambda p: residuals_and_jacobian(p)[0], np.clip(x, lo, hi),
                                      jac=lambda p: residuals_and_jacobian(p)[1], bounds=(lo, hi), method="trf",
                                      x_scale="jac", max_nfev=max_nfev)
    z_new, lp, _, jac = objective.evaluate(solution.x[None, :], z[None, :])
    return solution.x, z_new[0], lp[0], jac[0], bool(solution.success)


def _drop_worse_basins(lp: np.ndarray, predicted: np.ndarray, converged: np.ndarray, dropped: np.ndarray, *,
                       margin: float = LM_DROP_MARGIN, factor: float = 0.1, settled: float = LM_DROP_SETTLED,
                       reference: float | None = None) -> None:
    """Mark the active starts that cannot catch up with the best converged start (or with the log
    posterior ``reference`` already reached, when given): more than ``margin`` nats behind it and
    expected (Gauss–Newton) to gain less than ``factor`` x the gap and less than ``settled`` nats.

    Why: two starts 4,400 nats behind the best had each gone on to a 0.17 s trust-region
    continuation and ended where they were (``docs/decisions.md``, calibration engine)."""
    if reference is None:
        if not np.any(converged):
            return
        reference = float(np.max(lp[converged]))
    if not np.isfinite(reference):
        return
    gap = reference - lp
    hopeless = ~converged & ~dropped & (gap > margin) & (predicted < np.minimum(factor * gap, settled))
    dropped[hopeless] = True


def _drop_all_but_best(lp: np.ndarray, dropped: np.ndarray, kept: int) -> None:
    """Mark every start not among the ``kept`` best by log posterior (a race's cut)."""
    alive = np.flatnonzero(~dropped & np.isfinite(lp))
    if alive.size > kept:
        dropped[alive[np.argsort(-lp[alive], kind="stable")[kept:]]] = True


def _drop_duplicates(x: np.ndarray, lp: np.ndarray, jac: np.ndarray, converged: np.ndarray, dropped: np.ndarray,
                     unit: np.ndarray) -> None:
    """Mark the active starts that have come within :data:`LM_SAME_POINT` (internal units,
    every coordinate) and :data:`LM_SAME_BASIN` nats (Gauss–Newton metric) of a better start:
    the same basin, searched once. Both are needed: along a direction the data do not feel
    (an effect barely switched on) the metric is blind, yet a start there may be on its way to
    a far better optimum."""
    alive = np.flatnonzero(~dropped & np.isfinite(lp))
    if alive.size < 2:
        return
    order = alive[np.argsort(-lp[alive], kind="stable")]  # best first
    points = x[order]
    # every pair within LM_SAME_POINT in every coordinate, found at once (the pairs' loop below
    # then visits only those: 0.4 s of Python over a diagnosis's fits before)
    near = np.tril(np.all(np.abs(points[:, None, :] - points[None, :, :]) <= LM_SAME_POINT * unit, axis=2), -1)
    for position in np.flatnonzero(near.any(axis=1)):
        i = order[position]
        if converged[i]:
            continue
        for j in order[:position][near[position, :position]]:
            if dropped[j]:
                continue
            delta = jac[j] @ (x[i] - x[j])
            if 0.5 * float(delta @ delta) < LM_SAME_BASIN:
                dropped[i] = True
                break


def internal_starts(problem: Problem, guesses: Sequence[Mapping[str, float]]) -> np.ndarray:
    """Internal vectors (m, ndim) of guesses in natural units; a missing physical parameter
    starts at its prior centre, the noise parameters are estimated by the search."""
    rows = []
    lo, hi = problem.internal_bounds
    scale = np.array([p.prior.internal_scale for p in problem.parameters])
    for guess in guesses:
        z = np.empty(problem.ndim)
        for i, p in enumerate(problem.parameters):
            if p.name in guess and np.isfinite(guess[p.name]):
                z[i] = p.prior.to_internal(float(guess[p.name]))
            else:
                z[i] = p.prior.internal_centre()
        margin = 1e-6 * scale
        rows.append(np.clip(np.nan_to_num(z, nan=0.0), lo + margin, hi - margin))
    return np.array(rows, dtype=float).reshape(len(rows), problem.ndim)


def newton_polish(
    problem: Problem, z: np.ndarray, h: np.ndarray, *, max_iterations: int = 30, tolerance: float = 1e-7
) -> MapResult:
    """Newton iteration on the log posterior from ``z`` with finite-difference derivatives.

    The iteration of :func:`beam.inference.find_map` (:func:`beam.inference.optimize.newton_iterations`)
    with its stall rule on: a step from a point whose decrement is below
    :data:`POLISH_STALL_DECREMENT` nats (within ~0.1 posterior sd of the mode) that gains less
    than :data:`POLISH_STALL_GAIN` nats ends the search. Either the iteration converges
    quadratically and the new point is at the mode to ~1e-3 sd, or it crawls along a nearly
    flat, non-quadratic direction (two damping mechanisms trading off, correlation -0.997,
    curvatures spanning nine decades) where the finite-difference Hessian cannot do better
    (the search without this rule spent 30 iterations gaining 2e-3 nats on lab_run_5).

    Parameters
    ----------
    problem : Problem
        The calibration problem.
    z : ndarray, shape (ndim,)
        Starting point, internal coordinates (close to the MAP).
    h : ndarray, shape (ndim,)
        First finite-difference steps, internal coordinates.
    max_iterations : int
        Newton iteration cap.
    tolerance : float
        Newton decrement (expected log-posterior gain, nats) at which to stop.

    Returns
    -------
    MapResult
        With ``n_starts = 1``; ``hessian`` is the one the Laplace approximation uses.
    """
    out = newton_iterations(problem, z, h, max_iterations=max_iterations, tolerance=tolerance,
                            stall_decrement=POLISH_STALL_DECREMENT, stall_gain=POLISH_STALL_GAIN)
    return _map_result(problem, out.z, out.gradient, out.hessian, out.hessian_point, out.converged, out.message,
                       out.iterations, out.steps)


def _map_result(problem: Problem, z, grad, hess, zc, converged: bool, message: str, iterations: int,
                h: np.ndarray) -> MapResult:
    """A :class:`MapResult` at ``z`` (bounds reached within two finite-difference steps)."""
    lo, hi = problem.internal_bounds
    scale = np.array([p.prior.internal_scale for p in problem.parameters])
    h = steps_from_hessian(np.diag(hess), h, scale)
    at_bound = tuple(n for i, n in enumerate(problem.names) if z[i] <= lo[i] + 2 * h[i] or z[i] >= hi[i] - 2 * h[i])
    lp = float(problem.log_posterior(z)[0])
    values = {n: float(v[0]) for n, v in problem.from_internal(z).items()}
    return MapResult(z=z, values=values, log_posterior=lp, gradient=grad, hessian=hess, hessian_point=zc,
                     converged=converged, message=message, n_starts=1, start_log_posteriors=[lp],
                     at_bound=at_bound, n_iterations=iterations)


def fast_map(problem: Problem, guesses: Sequence[Mapping[str, float]]) -> MapResult:
    """MAP of ``problem`` from ``guesses``: lock-step Levenberg–Marquardt, then the Newton polish
    of :func:`beam.inference.find_map` from the best start.

    Parameters
    ----------
    problem : Problem
        The calibration problem.
    guesses : sequence of mapping
        Starting points in natural units (partial keys allowed, see :func:`internal_starts`).

    Returns
    -------
    MapResult
        As from :func:`beam.inference.find_map`; ``n_starts`` and ``start_log_posteriors``
        describe all the starts (log posterior where each start's search ended).
    """
    guesses = list(guesses)
    if not guesses:
        raise ValueError("fast_map needs at least one initial guess")
    lm = levenberg_marquardt(problem, internal_starts(problem, guesses))
    if not np.isfinite(lm.log_posterior[lm.best]):
        raise ValueError("no starting point has a finite log posterior")
    best = lm.best
    polished = newton_polish(problem, lm.z[best], lm.fd_steps[best])
    return replace(polished, n_starts=len(guesses), start_log_posteriors=[float(v) for v in lm.log_posterior])
