"""Posterior predictive bands on any time grid, and their scores against held-out data.

Given posterior draws ``theta_s`` (from MCMC or from the Laplace Gaussian):

* the **credible band** reflects parameter uncertainty only: pointwise quantiles over ``s``
  of the noise-free model ``f(t; theta_s)``;
* the **prediction band** adds the observation noise: pointwise quantiles of the mixture
  ``(1/S) Σ_s N(f(t; theta_s), noise_sd_s²)``, computed exactly (safeguarded Newton iteration
  on the mixture CDF, no Monte-Carlo noise). For the AR(1) likelihood ``noise_sd`` is the
  marginal standard deviation, so the band is the right one for a single new observation
  (it does not condition on the last calibration residuals).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy import special

from beam.inference.likelihood import NOISE_SD
from beam.inference.problem import Problem

__all__ = ["PredictiveBands", "mixture_normal_quantiles", "predictive_bands"]

_INV_SQRT_2PI = 1.0 / np.sqrt(2.0 * np.pi)


@dataclass
class PredictiveBands:
    """Pointwise posterior predictive summaries on a time grid (all arrays shape (n_t,)).

    Attributes
    ----------
    time_s : ndarray
        Time grid, seconds.
    mean : ndarray
        Posterior mean of the noise-free model, data unit.
    credible_lower, credible_upper : ndarray
        Equal-tailed ``level`` credible band of the noise-free model, data unit.
    prediction_lower, prediction_upper : ndarray
        Equal-tailed ``level`` prediction band of a new observation, data unit.
    level : float
        Probability content of both bands (e.g. 0.95).
    n_draws : int
        Number of posterior draws used.
    """

    time_s: np.ndarray
    mean: np.ndarray
    credible_lower: np.ndarray
    credible_upper: np.ndarray
    prediction_lower: np.ndarray
    prediction_upper: np.ndarray
    level: float
    n_draws: int

    def rmse(self, data: np.ndarray, mask: np.ndarray | None = None) -> float:
        """Root mean square of ``data - mean`` (data unit), optionally over ``mask`` only."""
        r = np.asarray(data, dtype=float) - self.mean
        if mask is not None:
            r = r[mask]
        return float(np.sqrt(np.mean(r * r)))

    def coverage(self, data: np.ndarray, mask: np.ndarray | None = None) -> float:
        """Fraction of ``data`` inside the prediction band (optionally over ``mask`` only)."""
        y = np.asarray(data, dtype=float)
        inside = (y >= self.prediction_lower) & (y <= self.prediction_upper)
        if mask is not None:
            inside = inside[mask]
        return float(np.mean(inside))

    def credible_coverage(self, truth: np.ndarray, mask: np.ndarray | None = None) -> float:
        """Fraction of noise-free ``truth`` values inside the credible band."""
        y = np.asarray(truth, dtype=float)
        inside = (y >= self.credible_lower) & (y <= self.credible_upper)
        if mask is not None:
            inside = inside[mask]
        return float(np.mean(inside))

    def restrict(self, mask: np.ndarray) -> PredictiveBands:
        """The bands on the subset ``mask`` of the grid."""
        return PredictiveBands(
            time_s=self.time_s[mask],
            mean=self.mean[mask],
            credible_lower=self.credible_lower[mask],
            credible_upper=self.credible_upper[mask],
            prediction_lower=self.prediction_lower[mask],
            prediction_upper=self.prediction_upper[mask],
            level=self.level,
            n_draws=self.n_draws,
        )

    def to_dict(self) -> dict[str, list[float] | float | int]:
        """Plain-Python version (lists), for JSON."""
        out: dict[str, list[float] | float | int] = {
            k: np.asarray(getattr(self, k)).tolist()
            for k in ("time_s", "mean", "credible_lower", "credible_upper", "prediction_lower", "prediction_upper")
        }
        out["level"] = float(self.level)
        out["n_draws"] = int(self.n_draws)
        return out


def mixture_normal_quantiles(mu: np.ndarray, sd: np.ndarray, prob: float, *, rtol: float = 1e-8, max_iter: int = 60) -> np.ndarray:
    """Quantile of an equally weighted Gaussian mixture at every column.

    Parameters
    ----------
    mu : ndarray, shape (S, T)
        Component means (one row per draw, one column per time).
    sd : ndarray, shape (S,) or (S, T)
        Component standard deviations, > 0.
    prob : float
        Probability in (0, 1).
    rtol : float
        Relative tolerance on the probability: stop when
        ``|CDF(q) - prob| < rtol * min(prob, 1 - prob)``.
    max_iter : int
        Iteration cap.

    Returns
    -------
    ndarray, shape (T,)
        ``q`` with ``mean_s Phi((q - mu_s) / sd_s) = prob``.
    """
    mu = np.asarray(mu, dtype=float)
    sd = np.broadcast_to(np.asarray(sd, dtype=float).reshape(mu.shape[0], -1), mu.shape)
    inv_sd = 1.0 / sd
    m = mu.mean(axis=0)
    var = mu.var(axis=0) + np.mean(sd * sd, axis=0)
    lo = (mu - 9.0 * sd).min(axis=0)  # CDF < prob at lo, > prob at hi for prob in (1e-19, 1 - 1e-19)
    hi = (mu + 9.0 * sd).max(axis=0)
    if not 0.0 < prob < 1.0:
        raise ValueError(f"prob must lie in (0, 1), got {prob}")
    tol = rtol * min(prob, 1.0 - prob)
    z_p = special.ndtri(prob)
    q = np.clip(m + np.sqrt(var) * z_p, lo, hi)  # moment-matched normal start
    active = np.arange(q.size)  # columns not yet converged
    for _ in range(max_iter):
        mu_a, inv_a, q_a = mu[:, active], inv_sd[:, active], q[active]
        u = (q_a - mu_a) * inv_a
        cdf = special.ndtr(u).mean(axis=0)
        done = np.abs(cdf - prob) < tol
        if np.all(done):
            break
        keep = ~done
        active, u, inv_a, q_a, cdf = active[keep], u[:, keep], inv_a[:, keep], q_a[keep], cdf[keep]
        pdf = (np.exp(-0.5 * u * u) * inv_a).mean(axis=0) * _INV_SQRT_2PI
        lo_a = np.where(cdf < prob, q_a, lo[active])
        hi_a = np.where(cdf > prob, q_a, hi[active])
        lo[active], hi[active] = lo_a, hi_a
        # Newton on the probit scale, ndtri(F(q)) = ndtri(prob): nearly linear for mixtures
        # close to a Gaussian, so it converges in a few steps from the moment-matched start.
        g = special.ndtri(np.clip(cdf, 1e-300, 1.0 - 1e-16))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            q_new = q_a - (g - z_p) * np.exp(-0.5 * g * g) * _INV_SQRT_2PI / pdf
        bad = ~np.isfinite(q_new) | (q_new < lo_a) | (q_new > hi_a)
        q[active] = np.where(bad, 0.5 * (lo_a + hi_a), q_new)
    return q


#: Relative probability tolerance of the prediction band's edges: about 1e-4 of a standard
#: deviation, far below the Monte Carlo error of a few hundred draws (and twice as fast as 1e-8).
BAND_RTOL = 1e-4


def predictive_bands(
    problem: Problem,
    values: Mapping[str, np.ndarray],
    time_s: np.ndarray,
    *,
    level: float = 0.95,
    batch_size: int = 2000,
) -> PredictiveBands:
    """Credible and prediction bands from posterior draws.

    Parameters
    ----------
    problem : Problem
        Supplies the forward model and fixed values.
    values : mapping of str to ndarray, shape (S,)
        Posterior draws of the sampled parameters in natural units (fixed ones optional).
    time_s : ndarray, shape (T,)
        Prediction grid, seconds.
    level : float
        Probability content of the bands.
    batch_size : int
        Draws pushed through the model per call (bounds memory for expensive models).

    Returns
    -------
    PredictiveBands
    """
    time_s = np.asarray(time_s, dtype=float)
    vals = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in values.items()}
    n = max(v.shape[0] for v in vals.values())
    for k, v in problem.fixed.items():
        vals.setdefault(k, np.full(n, v))
    pieces = []
    for start in range(0, n, batch_size):
        part = {k: v[start : start + batch_size] for k, v in vals.items()}
        pieces.append(problem.predict(part, time_s))
    f = np.concatenate(pieces, axis=0)
    alpha = 0.5 * (1.0 - level)
    cred = np.quantile(f, [alpha, 1.0 - alpha], axis=0)
    sd = vals[NOISE_SD]
    return PredictiveBands(
        time_s=time_s,
        mean=f.mean(axis=0),
        credible_lower=cred[0],
        credible_upper=cred[1],
        prediction_lower=mixture_normal_quantiles(f, sd, alpha, rtol=BAND_RTOL),
        prediction_upper=mixture_normal_quantiles(f, sd, 1.0 - alpha, rtol=BAND_RTOL),
        level=float(level),
        n_draws=int(n),
    )
