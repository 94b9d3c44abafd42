"""Predictive bands of a calibration, computed in one batched model call and one compiled pass.

The bands are those of :func:`beam.inference.predictive_bands` (same definitions, same draws):

* **mean** — the posterior mean of the noise-free model, ``mean_s f_s(t)``;
* **credible band** — the equal-tailed quantiles of ``f_s(t)`` over the draws, with numpy's
  default ('linear') interpolation between order statistics (the same numbers as
  :func:`numpy.quantile`);
* **prediction band** — the quantiles of the Gaussian mixture ``(1/S) Σ_s N(f_s(t), sd_s²)``
  solved to the relative probability tolerance
  :data:`beam.inference.predictive.BAND_RTOL`.

Hand-written because :func:`beam.inference.predictive_bands` spends most of its time in the
mixture quantiles (``scipy.special.ndtr`` over every draw and sample) and in
:func:`numpy.quantile`: 0.33 s against 0.039 s here for 400 draws of a 4,700-sample record
(``docs/benchmarks.md``). One compiled loop over the samples does, per sample (its draws
gathered into a contiguous buffer):

1. the mixture's first four moments (one pass over the draws), for a Cornish–Fisher starting
   point of each edge, which for the nearly Gaussian mixtures of a calibrated model is already
   close to the root;
2. the credible band's order statistics: the draws beyond two cuts placed from the moments
   (a few times the tail needed) are gathered without branches and the order statistics
   needed insertion-sorted in front (:func:`_smallest_sorted`), with
   quickselect as the fall-back when a cut holds too few or too many;
3. the mixture CDF and its first two derivatives at both edges in one pass over the draws,
   with the normal CDF from a table (cubic Hermite interpolation of Φ with φ as slopes, step
   1/64: error <= 2e-10, far below the tolerance), branch-free;
4. Halley steps, bracketed (bisection when a step leaves the bracket), until the CDF is within
   the tolerance — or until a Taylor bound on the error of the last Newton step is below half
   of it, which saves the final pass (usually one pass per edge is all it takes).

Tested against :func:`numpy.quantile` and the exact mixture CDF on hard mixtures (bimodal,
skewed, spreads from 1 % to 30 x the noise) and against :func:`beam.inference.predictive_bands`
on a calibration (tests/test_calibration_preview.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple

import numba
import numpy as np
from scipy import special

from beam.inference import NOISE_SD, PredictiveBands, Problem
from beam.inference.predictive import BAND_RTOL

__all__ = ["BandRows", "fast_predictive_bands", "mixture_bands"]

#: Half-width of the tabulated normal CDF (standard deviations); beyond it Φ is 0 or 1
#: (Φ(-9) = 1.1e-19).
_TABLE_HALF_WIDTH = 9.0
#: Nodes per unit of the table.
_TABLE_DENSITY = 64.0


def _normal_cdf_table() -> np.ndarray:
    """Cubic coefficients (rows, 4) of Φ on each table interval, in t in [0, 1): the Hermite
    interpolant of Φ with slopes φ (error at most h^4 max|φ'''| / 384 = 2e-10). Row 0 is Φ = 0
    (below -9) and the last row Φ = 1 (above 9), so that a lookup needs no branch."""
    nodes = np.linspace(-_TABLE_HALF_WIDTH, _TABLE_HALF_WIDTH, int(2 * _TABLE_HALF_WIDTH * _TABLE_DENSITY) + 1)
    cdf = special.ndtr(nodes)
    slope = np.exp(-0.5 * nodes**2) / math.sqrt(2.0 * math.pi) / _TABLE_DENSITY  # dΦ/dt
    c0, c1, d0, d1 = cdf[:-1], cdf[1:], slope[:-1], slope[1:]
    inner = np.column_stack([c0, d0, 3.0 * (c1 - c0) - 2.0 * d0 - d1, 2.0 * (c0 - c1) + d0 + d1])
    return np.ascontiguousarray(np.vstack([np.zeros((1, 4)), inner, [[1.0, 0.0, 0.0, 0.0]]]))


_CDF_TABLE = _normal_cdf_table()
#: Largest table position (just below the constant last row's end).
_TABLE_TOP = _CDF_TABLE.shape[0] - 1e-9
#: Iteration cap of the quantile search (bisection halves the bracket when Halley fails).
_MAX_ITERATIONS = 80


@numba.njit(cache=True, nogil=True, fastmath=True, inline="always")
def _phi(u, table):
    """Φ(u) and dΦ/dt (t = 64 u) from the table, without branches."""
    x = min(max((u + _TABLE_HALF_WIDTH) * _TABLE_DENSITY + 1.0, 0.0), _TABLE_TOP)
    k = int(x)
    t = x - k
    a0, a1, a2, a3 = table[k, 0], table[k, 1], table[k, 2], table[k, 3]
    return a0 + t * (a1 + t * (a2 + t * a3)), a1 + t * (2.0 * a2 + t * 3.0 * a3)


@numba.njit(cache=True, nogil=True, fastmath=True)
def _mixture_cdf(q, mu, inv_sd, table):
    """Mixture CDF F(q), its density F'(q) and F''(q) (equal weights)."""
    cdf = 0.0
    pdf = 0.0
    dpdf = 0.0
    for s in range(mu.size):
        u = (q - mu[s]) * inv_sd[s]
        c, slope = _phi(u, table)
        slope *= inv_sd[s]
        cdf += c
        pdf += slope
        dpdf -= u * slope * inv_sd[s]
    n = mu.size
    return cdf / n, pdf * _TABLE_DENSITY / n, dpdf * _TABLE_DENSITY / n


@numba.njit(cache=True, nogil=True, fastmath=True)
def _mixture_cdf_pair(q1, q2, mu, inv_sd, table):
    """:func:`_mixture_cdf` at two points in one pass over the draws."""
    c1 = p1 = d1 = c2 = p2 = d2 = 0.0
    for s in range(mu.size):
        m, inv = mu[s], inv_sd[s]
        u = (q1 - m) * inv
        c, slope = _phi(u, table)
        slope *= inv
        c1 += c
        p1 += slope
        d1 -= u * slope * inv
        u = (q2 - m) * inv
        c, slope = _phi(u, table)
        slope *= inv
        c2 += c
        p2 += slope
        d2 -= u * slope * inv
    n = mu.size
    scale = _TABLE_DENSITY / n
    return c1 / n, p1 * scale, d1 * scale, c2 / n, p2 * scale, d2 * scale


@numba.njit(cache=True, nogil=True)
def _halley_update(q, lo, hi, cdf, pdf, dpdf, prob, tol, max_inv_sd):
    """One bracketed Halley step of ``F(q) = prob`` from the values at ``q``.

    Returns the next point, the bracket and whether the search is done: the CDF was within
    ``tol``, or a bound on the error of the Newton step Δ is below ``tol / 2``, so that the step
    (Halley's is more accurate still) lands within the tolerance without another pass. The
    bound is Taylor's, |F''(q)| Δ² / 2 + max|F'''| |Δ|³ / 6 with |F'''| <= max|φ''| / sd³ =
    1.38 / min(sd)³: the curvature at q alone misleads near an inflection of the mixture.
    """
    residual = cdf - prob
    if abs(residual) < tol:
        return q, lo, hi, True
    if residual < 0.0:
        lo = q
    else:
        hi = q
    if pdf > 0.0:
        step = -residual / pdf
        reach = abs(step) * max_inv_sd
        newton_error = 0.5 * abs(dpdf) * step * step + 0.23 * reach * reach * reach
        denominator = pdf + 0.5 * dpdf * step
        if denominator > 0.5 * pdf:
            step = -residual / denominator
        q_new = q + step
        if lo < q_new < hi:
            return q_new, lo, hi, newton_error < 0.5 * tol
    return 0.5 * (lo + hi), lo, hi, False


@numba.njit(cache=True, nogil=True)
def _cornish_fisher(z, mean, var, skew, kurt, lo, hi):
    """Quantile start at standard-normal quantile ``z``: Cornish-Fisher (third order) when the
    skewness and excess kurtosis are moderate, else moment-matched, inside (lo, hi)."""
    if abs(skew) < 1.0 and abs(kurt) < 3.0:
        w = (z + (z * z - 1.0) * skew / 6.0 + (z**3 - 3.0 * z) * kurt / 24.0
             - (2.0 * z**3 - 5.0 * z) * skew * skew / 36.0)
        q = mean + math.sqrt(var) * w
        if lo < q < hi:
            return q
    q = mean + math.sqrt(var) * z
    if lo < q < hi:
        return q
    return 0.5 * (lo + hi)


@numba.njit(cache=True, nogil=True)
def _prediction_quantiles(mu, inv_sd, alpha, z_alpha, moments, lo, hi, tol, table):
    """The ``alpha`` and ``1 - alpha`` quantiles of the mixture (both searches share the passes
    over the draws while both run)."""
    mean, var, skew, kurt = moments
    max_inv_sd = inv_sd.max()
    q1 = _cornish_fisher(z_alpha, mean, var, skew, kurt, lo, hi)
    q2 = _cornish_fisher(-z_alpha, mean, var, skew, kurt, lo, hi)
    lo1, hi1, lo2, hi2 = lo, hi, lo, hi
    done1 = done2 = False
    for _ in range(_MAX_ITERATIONS):
        if done1 and done2:
            break
        if not done1 and not done2:
            c1, p1, d1, c2, p2, d2 = _mixture_cdf_pair(q1, q2, mu, inv_sd, table)
            q1, lo1, hi1, done1 = _halley_update(q1, lo1, hi1, c1, p1, d1, alpha, tol, max_inv_sd)
            q2, lo2, hi2, done2 = _halley_update(q2, lo2, hi2, c2, p2, d2, 1.0 - alpha, tol, max_inv_sd)
        elif not done1:
            c1, p1, d1 = _mixture_cdf(q1, mu, inv_sd, table)
            q1, lo1, hi1, done1 = _halley_update(q1, lo1, hi1, c1, p1, d1, alpha, tol, max_inv_sd)
        else:
            c2, p2, d2 = _mixture_cdf(q2, mu, inv_sd, table)
            q2, lo2, hi2, done2 = _halley_update(q2, lo2, hi2, c2, p2, d2, 1.0 - alpha, tol, max_inv_sd)
    return q1, q2


@numba.njit(cache=True, nogil=True)
def _select(a, lo, hi, k):
    """Partially order ``a[lo:hi + 1]`` in place so that ``a[k]`` is its order statistic k
    (everything left of k is <= a[k] <= everything right of it); Hoare quickselect."""
    while hi > lo:
        mid = (lo + hi) // 2  # median of three as pivot
        if a[mid] < a[lo]:
            a[mid], a[lo] = a[lo], a[mid]
        if a[hi] < a[lo]:
            a[hi], a[lo] = a[lo], a[hi]
        if a[hi] < a[mid]:
            a[hi], a[mid] = a[mid], a[hi]
        pivot = a[mid]
        i, j = lo, hi
        while i <= j:
            while a[i] < pivot:
                i += 1
            while a[j] > pivot:
                j -= 1
            if i <= j:
                a[i], a[j] = a[j], a[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return


@numba.njit(cache=True, nogil=True)
def _lerp(lower, upper, gamma):
    """numpy's interpolation between neighbouring order statistics (its ``_lerp``)."""
    diff = upper - lower
    if gamma >= 0.5:
        return upper - diff * (1.0 - gamma)
    return lower + diff * gamma


@numba.njit(cache=True, nogil=True)
def _linear_quantile(a, virtual):
    """numpy's 'linear' quantile of ``a`` at virtual index ``virtual`` (reorders ``a``)."""
    n = a.size
    below = math.floor(virtual)
    if below >= n - 1:
        _select(a, 0, n - 1, n - 1)
        return a[n - 1]
    _select(a, 0, n - 1, below)
    upper = a[below + 1]
    for i in range(below + 2, n):
        upper = min(upper, a[i])
    return _lerp(a[below], upper, virtual - below)


@numba.njit(cache=True, nogil=True)
def _insertion_sort(a, n):
    """Sort ``a[:n]`` in place (n small)."""
    for i in range(1, n):
        x = a[i]
        j = i - 1
        while j >= 0 and a[j] > x:
            a[j + 1] = a[j]
            j -= 1
        a[j + 1] = x


@numba.njit(cache=True, nogil=True)
def _smallest_sorted(a, n, k):
    """Reorder ``a[:n]`` so that ``a[:k]`` holds its k smallest values in increasing order (the
    rest of ``a[:n]`` is left undefined): an insertion sort of the first k, then each later value
    inserted only when it is below the k-th. The credible band needs the 11th and 12th of ~30
    values beyond a cut; a full insertion sort of the 30 moved ~2.5 x as many values."""
    k = min(k, n)
    if k <= 0:
        return
    _insertion_sort(a, k)
    for i in range(k, n):
        x = a[i]
        if x < a[k - 1]:
            j = k - 2
            while j >= 0 and a[j] > x:
                a[j + 1] = a[j]
                j -= 1
            a[j + 1] = x


@numba.njit(cache=True, nogil=True)
def _credible_quantiles(mu, low_virtual, high_virtual, low_cut, high_cut, low_buf, high_buf, scratch):
    """numpy's 'linear' quantiles of ``mu`` at two virtual indices, one in each tail.

    The values below ``low_cut`` and above ``high_cut`` (cuts expected to hold a few times the
    order statistics needed) are gathered without branches and the order statistics needed sorted in front
    (:func:`_smallest_sorted`); when a cut holds too few
    or too many, quickselect on a copy decides.
    """
    n = mu.size
    low_below = math.floor(low_virtual)
    high_below = math.floor(high_virtual)
    need_low = low_below + 2  # order statistics low_below and low_below + 1
    need_high = n - high_below  # high_below and high_below + 1, counted from the top
    n_low = 0
    n_high = 0
    for s in range(n):
        x = mu[s]
        low_buf[n_low] = x
        n_low += x <= low_cut
        high_buf[n_high] = -x
        n_high += x >= high_cut
    limit = 4 * max(need_low, need_high) + 32
    if need_low <= n_low <= limit and need_high <= n_high <= limit and need_high >= 2 and high_below < n - 1:
        _smallest_sorted(low_buf, n_low, need_low)
        _smallest_sorted(high_buf, n_high, need_high)
        low = _lerp(low_buf[need_low - 2], low_buf[need_low - 1], low_virtual - low_below)
        high = _lerp(-high_buf[need_high - 1], -high_buf[need_high - 2], high_virtual - high_below)
        return low, high
    scratch[:] = mu
    return _linear_quantile(scratch, low_virtual), _linear_quantile(scratch, high_virtual)


@numba.njit(cache=True, nogil=True, fastmath=True)
def _column_moments(mu, sd2):
    """Mean, variance, skewness and excess kurtosis (without the 3 E[sd⁴] term) of the mixture
    (1/S) Σ N(mu_s, sd2_s) and the spread of ``mu`` alone (one pass, moments about mu[0]).

    No minimum or maximum here: with them the loop did not vectorise (9 ms against 1 ms for the
    strip's 19,400 samples of 400 draws); :func:`_bands_kernel` takes them while it gathers.
    """
    n = mu.size
    origin = mu[0]
    s1 = s2 = s3 = s4 = t0 = t1 = t2 = 0.0
    for s in range(n):
        d = mu[s] - origin
        d2 = d * d
        v = sd2[s]
        s1 += d
        s2 += d2
        s3 += d2 * d
        s4 += d2 * d2
        t0 += v
        t1 += d * v
        t2 += d2 * v
    a = s1 / n  # mean - origin
    m2 = max(s2 / n - a * a, 0.0)
    m3 = s3 / n - 3.0 * a * s2 / n + 2.0 * a**3
    m4 = s4 / n - 4.0 * a * s3 / n + 6.0 * a * a * s2 / n - 3.0 * a**4
    v0, v1, v2 = t0 / n, t1 / n - a * t0 / n, t2 / n - 2.0 * a * t1 / n + a * a * t0 / n
    var = m2 + v0
    skew = (m3 + 3.0 * v1) / var**1.5
    return origin + a, var, skew, (m4 + 6.0 * v2) / (var * var) - 3.0, math.sqrt(m2)


@numba.njit(cache=True, nogil=True)
def _bands_kernel(f, sd, alpha, z_alpha, z_cut_low, z_cut_high, rtol, table, out):
    """Mean, credible and prediction bands of draws ``f`` (S, T) into ``out`` (5, T); returns the
    number of samples with a draw that is not finite (their five rows NaN)."""
    n_draws, n_times = f.shape
    inv_sd = 1.0 / sd
    sd2 = sd * sd
    mean_sd4 = 0.0
    max_sd = 0.0
    for s in range(n_draws):
        mean_sd4 += sd2[s] * sd2[s] / n_draws
        max_sd = max(max_sd, sd[s])
    tol = rtol * min(alpha, 1.0 - alpha)
    low_index = (n_draws - 1) * alpha
    high_index = (n_draws - 1) * (1.0 - alpha)
    mu = np.empty(n_draws)
    low_buf = np.empty(n_draws + 1)
    high_buf = np.empty(n_draws + 1)
    scratch = np.empty(n_draws)
    not_finite = 0
    for t in range(n_times):
        low = high = f[0, t]
        check = 0.0  # 0 for finite draws, NaN once one is inf or NaN
        for s in range(n_draws):  # the sample's draws, contiguous (consecutive samples share cache lines)
            x = f[s, t]
            mu[s] = x
            low = min(low, x)
            high = max(high, x)
            check += x * 0.0
        if check != 0.0:
            not_finite += 1
            for row in range(5):
                out[row, t] = np.nan
            continue
        mean, var, skew, kurt, spread = _column_moments(mu, sd2)
        kurt += 3.0 * mean_sd4 / (var * var)
        out[0, t] = mean
        out[1, t], out[2, t] = _credible_quantiles(mu, low_index, high_index, mean + z_cut_low * spread,
                                                   mean + z_cut_high * spread, low_buf, high_buf, scratch)
        bracket_low = low - _TABLE_HALF_WIDTH * max_sd
        bracket_high = high + _TABLE_HALF_WIDTH * max_sd
        out[3, t], out[4, t] = _prediction_quantiles(mu, inv_sd, alpha, z_alpha, (mean, var, skew, kurt),
                                                     bracket_low, bracket_high, tol, table)
    return not_finite


class BandRows(NamedTuple):
    """Mean and band edges of :func:`mixture_bands`, each of shape (T,) in the data unit."""

    mean: np.ndarray
    credible_lower: np.ndarray
    credible_upper: np.ndarray
    prediction_lower: np.ndarray
    prediction_upper: np.ndarray


def mixture_bands(f: np.ndarray, sd: np.ndarray, level: float = 0.95, *, rtol: float = BAND_RTOL) -> BandRows:
    """Mean, credible band and prediction band of model draws.

    Parameters
    ----------
    f : ndarray, shape (S, T)
        Noise-free model output of ``S`` posterior draws at ``T`` times (data unit, e.g. m).
    sd : ndarray, shape (S,)
        Noise standard deviation of each draw (data unit), > 0.
    level : float
        Probability content of both bands, in (0, 1).
    rtol : float
        Relative probability tolerance of the prediction band's edges (see
        :func:`beam.inference.predictive.mixture_normal_quantiles`).

    Returns
    -------
    BandRows
        Mean, credible lower and upper, prediction lower and upper, each of shape (T,) (data
        unit); NaN at a time where a draw is not finite.
    """
    return _mixture_bands(f, sd, level, rtol)[0]


def _mixture_bands(f: np.ndarray, sd: np.ndarray, level: float, rtol: float) -> tuple[BandRows, int]:
    """:func:`mixture_bands` and the number of times at which a draw is not finite (found while
    the kernel gathers the draws: a separate ``numpy.isfinite`` over the 400 x 19,400 draws of
    the strip's preview took 2.5-4 ms)."""
    f = np.ascontiguousarray(f, dtype=float)
    sd = np.ascontiguousarray(np.broadcast_to(np.asarray(sd, dtype=float), (f.shape[0],)))
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    if f.ndim != 2 or f.shape[0] < 1:
        raise ValueError("f must have shape (draws, times)")
    if not (np.all(sd > 0.0) and np.all(np.isfinite(sd))):
        raise ValueError("noise standard deviations must be finite and positive")
    alpha = 0.5 * (1.0 - level)
    n = f.shape[0]
    tail = (2.0 * (math.floor(alpha * (n - 1)) + 2) + 8.0) / n  # share of draws each cut should hold
    z_cut = float(special.ndtri(min(tail, 0.5)))
    out = np.empty((5, f.shape[1]))
    not_finite = _bands_kernel(f, sd, alpha, float(special.ndtri(alpha)), z_cut, -z_cut, float(rtol), _CDF_TABLE, out)
    return BandRows(*out), int(not_finite)


def fast_predictive_bands(
    problem: Problem, values: Mapping[str, np.ndarray], time_s: np.ndarray, *, level: float = 0.95
) -> PredictiveBands:
    """:func:`beam.inference.predictive_bands` in one batched model call and one compiled pass.

    Parameters
    ----------
    problem : Problem
        Supplies the forward model and fixed values.
    values : mapping of str to ndarray, shape (S,)
        Posterior draws of the sampled parameters in natural units (``noise_sd`` in the data
        unit, m for the beam).
    time_s : ndarray, shape (T,)
        Prediction grid (s).
    level : float
        Probability content of the bands.

    Returns
    -------
    PredictiveBands
        Bands in the data unit (m).
    """
    time_s = np.asarray(time_s, dtype=float)
    draws = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in values.items()}
    f = problem.predict(draws, time_s)
    rows, not_finite = _mixture_bands(f, draws[NOISE_SD], level, BAND_RTOL)
    if not_finite:
        raise ValueError("the model is not finite at some posterior draws")
    return PredictiveBands(
        time_s=time_s,
        **rows._asdict(),
        level=float(level),
        n_draws=int(f.shape[0]),
    )
