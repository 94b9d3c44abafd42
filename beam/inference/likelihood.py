"""Gaussian likelihoods of model residuals, vectorised over a batch of parameter sets.

Two noise models are available, by name (:data:`LIKELIHOODS`):

``"iid"``
    Independent Gaussian errors with standard deviation ``noise_sd`` (the assumption under
    which a model with missing physics is over-confident, Kennedy & O'Hagan 2001).
``"ar1"``
    Stationary first-order autoregressive errors, ``e_1 ~ N(0, s²)`` and
    ``e_t = rho e_{t-1} + u_t`` with ``u_t ~ N(0, s² (1 - rho²))``, where ``s = noise_sd`` is the
    *marginal* standard deviation of every residual and ``rho = ar1_coefficient`` in ``(-1, 1)``
    is the lag-one correlation between consecutive samples. The likelihood is exact (the first
    sample is included with its stationary variance), equal to that of a zero-mean Gaussian
    with covariance ``s² rho^|i-j|``. The lag is one *sample*: the time grid is assumed to be
    uniformly spaced. A correlated error model is the simplest stand-in for a structured model
    discrepancy (Brynjarsdóttir & O'Hagan 2014).

Residuals are ``data - prediction`` with shape ``(B, n)``; noise parameters are arrays of shape
``(B,)``. Every function here returns one value per row.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

__all__ = [
    "AR1_COEFFICIENT",
    "LIKELIHOODS",
    "NOISE_SD",
    "estimate_noise_parameters",
    "log_likelihood",
    "log_normaliser",
    "whiten",
]

#: Name of the marginal noise standard deviation parameter (data unit).
NOISE_SD = "noise_sd"
#: Name of the lag-one autocorrelation of the AR(1) residuals (dimensionless, in (-1, 1)).
AR1_COEFFICIENT = "ar1_coefficient"

#: Likelihood kinds and the noise parameters each one needs.
LIKELIHOODS: dict[str, tuple[str, ...]] = {
    "iid": (NOISE_SD,),
    "ar1": (NOISE_SD, AR1_COEFFICIENT),
}

_LOG_2PI = math.log(2.0 * math.pi)


def _check_kind(kind: str) -> None:
    if kind not in LIKELIHOODS:
        raise ValueError(f"unknown likelihood {kind!r}; expected one of {', '.join(LIKELIHOODS)}")


def whiten(kind: str, residuals: np.ndarray, noise: Mapping[str, np.ndarray]) -> np.ndarray:
    """Whitened residuals ``w`` with ``log L = -½ Σ w² + log_normaliser``.

    Parameters
    ----------
    kind : {"iid", "ar1"}
        Likelihood kind.
    residuals : ndarray, shape (B, n)
        ``data - prediction``, in the data unit.
    noise : mapping of str to ndarray, shape (B,)
        ``noise_sd`` (data unit) and, for ``"ar1"``, ``ar1_coefficient``.

    Returns
    -------
    ndarray, shape (B, n)
        Dimensionless residuals that are i.i.d. standard normal under the noise model.
    """
    _check_kind(kind)
    r = np.asarray(residuals, dtype=float)
    sd = np.asarray(noise[NOISE_SD], dtype=float)[:, None]
    if kind == "iid":
        return r / sd
    rho = np.asarray(noise[AR1_COEFFICIENT], dtype=float)[:, None]
    w = np.empty_like(r)
    w[:, :1] = r[:, :1] / sd
    w[:, 1:] = (r[:, 1:] - rho * r[:, :-1]) / (sd * np.sqrt(1.0 - rho * rho))
    return w


def log_normaliser(kind: str, n: int, noise: Mapping[str, np.ndarray]) -> np.ndarray:
    """The residual-independent part of the log likelihood, shape (B,).

    ``-n/2 log 2π - n log s`` for ``"iid"``, plus ``-(n-1)/2 log(1 - rho²)`` for ``"ar1"``
    (the log determinant of the AR(1) covariance is ``2 n log s + (n-1) log(1 - rho²)``).
    """
    _check_kind(kind)
    sd = np.asarray(noise[NOISE_SD], dtype=float)
    out = -0.5 * n * _LOG_2PI - n * np.log(sd)
    if kind == "ar1":
        rho = np.asarray(noise[AR1_COEFFICIENT], dtype=float)
        out = out - 0.5 * (n - 1) * np.log1p(-rho * rho)
    return out


def log_likelihood(kind: str, residuals: np.ndarray, noise: Mapping[str, np.ndarray]) -> np.ndarray:
    """Exact Gaussian log likelihood of each row of residuals, shape (B,).

    Parameters
    ----------
    kind : {"iid", "ar1"}
        Likelihood kind (see the module docstring).
    residuals : ndarray, shape (B, n)
        ``data - prediction``, in the data unit.
    noise : mapping of str to ndarray, shape (B,)
        ``noise_sd`` > 0 (data unit) and, for ``"ar1"``, ``ar1_coefficient`` in (-1, 1).

    Returns
    -------
    ndarray, shape (B,)
        ``log p(data | parameters)`` in nats.
    """
    r = np.asarray(residuals, dtype=float)
    n = r.shape[1]
    sd = np.asarray(noise[NOISE_SD], dtype=float)
    if kind == "iid":  # inline the common case
        return -0.5 * np.einsum("ij,ij->i", r, r) / (sd * sd) - n * np.log(sd) - 0.5 * n * _LOG_2PI
    _check_kind(kind)
    rho = np.asarray(noise[AR1_COEFFICIENT], dtype=float)
    one_m_rho2 = 1.0 - rho * rho
    innov = r[:, 1:] - rho[:, None] * r[:, :-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        q = r[:, 0] * r[:, 0] + np.einsum("ij,ij->i", innov, innov) / one_m_rho2
        out = -0.5 * q / (sd * sd) - n * np.log(sd) - 0.5 * (n - 1) * np.log(one_m_rho2) - 0.5 * n * _LOG_2PI
    return np.where(one_m_rho2 > 0.0, out, -np.inf)  # |rho| >= 1 is not a stationary AR(1)


def estimate_noise_parameters(kind: str, residuals: np.ndarray) -> dict[str, float]:
    """Moment estimates of the noise parameters from one row of residuals.

    Used to start the MAP search: ``noise_sd`` is the root mean square residual and
    ``ar1_coefficient`` the lag-one sample autocorrelation (about zero mean).

    Parameters
    ----------
    kind : {"iid", "ar1"}
        Likelihood kind.
    residuals : ndarray, shape (n,)
        ``data - prediction`` at a candidate parameter set, in the data unit.

    Returns
    -------
    dict
        ``{"noise_sd": float}`` plus ``"ar1_coefficient"`` for ``"ar1"``.
    """
    _check_kind(kind)
    r = np.asarray(residuals, dtype=float).ravel()
    out = {NOISE_SD: float(np.sqrt(np.mean(r * r)))}
    if kind == "ar1":
        denom = float(np.dot(r[:-1], r[:-1]))
        rho = float(np.dot(r[1:], r[:-1]) / denom) if denom > 0.0 else 0.0
        out[AR1_COEFFICIENT] = float(np.clip(rho, -0.98, 0.98))
    return out
