"""Residual autocorrelation and the Ljung–Box test of whiteness.

If the model and the noise model are right, the residuals are white noise: their sample
autocorrelation r_k stays inside ±1.96/sqrt(n) at about 95 % of lags, and the Ljung–Box
statistic

    Q = n (n + 2) sum_{k=1}^{L} r_k² / (n − k)

follows a chi-square distribution with L − p degrees of freedom (p: parameters fitted to the
series, usually 0 here; Ljung & Box 1978). A small p-value means structure is left in the
residuals: missing physics, or coloured noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.signal
import scipy.stats

from beam.errors import BeamInputError
from beam.residuals.common import as_signal, integer, jsonable

__all__ = ["Whiteness", "autocorrelation", "default_max_lag", "ljung_box", "residual_whiteness"]

#: Fewest samples the whiteness test accepts.
MIN_SAMPLES = 20


def default_max_lag(n_samples: int) -> int:
    """Default largest lag: min(10 log10 n, n / 5), at least 1 (27 lags for 500 samples, 40 for 10,000)."""
    return max(1, min(int(10 * math.log10(n_samples)), n_samples // 5))


def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Sample autocorrelation r_0 ... r_L of a series (r_0 = 1).

    The biased estimator r_k = sum_t (x_t − m)(x_{t+k} − m) / sum_t (x_t − m)², computed by FFT.

    Parameters
    ----------
    x : array (n,)
        The series, finite, not constant.
    max_lag : int
        Largest lag L, 1 <= L < n.

    Returns
    -------
    ndarray (L + 1,)
    """
    series = as_signal(x, "series", min_samples=3)
    max_lag = integer(max_lag, "max_lag", 1, series.size - 1)
    centred = series - series.mean()
    variance = float(centred @ centred)
    if not variance > 0:
        raise BeamInputError("the series is constant: its autocorrelation is undefined")
    full = scipy.signal.correlate(centred, centred, mode="full", method="fft")
    return full[series.size - 1 : series.size + max_lag] / variance


def ljung_box(x: np.ndarray, lags: int, fitted_parameters: int = 0) -> tuple[float, float]:
    """Ljung–Box statistic Q and its p-value.

    Parameters
    ----------
    x : array (n,)
        The series.
    lags : int
        Number L of autocorrelations summed.
    fitted_parameters : int
        Parameters p fitted to the series; the reference is chi-square with L − p degrees of
        freedom (default 0).

    Returns
    -------
    (float, float)
        Q and P(chi2_{L−p} > Q).
    """
    n = np.asarray(x).size
    fitted_parameters = integer(fitted_parameters, "fitted_parameters", 0)
    lags = integer(lags, "lags", fitted_parameters + 1, max(n - 1, fitted_parameters + 1))
    q = _q_statistic(autocorrelation(x, lags)[1:], n)
    return q, float(scipy.stats.chi2.sf(q, lags - fitted_parameters))


def _q_statistic(acf: np.ndarray, n: int) -> float:
    """Q = n (n + 2) sum_k r_k² / (n − k) from r_1 ... r_L."""
    k = np.arange(1, acf.size + 1)
    return float(n * (n + 2) * np.sum(acf**2 / (n - k)))


@dataclass(frozen=True, eq=False)
class Whiteness:
    """Autocorrelation of the residuals and the Ljung–Box test.

    Parameters
    ----------
    lags : ndarray (L,)
        Lags 1 ... L (samples).
    lag_s : ndarray (L,)
        The same lags in seconds (NaN without a sample interval).
    acf : ndarray (L,)
        Sample autocorrelation at those lags.
    band : float
        Half-width 1.96 / sqrt(n) of the 95 % band of a white series.
    fraction_outside : float
        Fraction of lags with |r_k| > band (about 0.05 for white noise).
    q_statistic : float
        Ljung–Box Q.
    degrees_of_freedom : int
        L − fitted parameters.
    p_value : float
        P(chi2 > Q).
    alpha : float
        Level of the test.
    white : bool
        True when p_value >= alpha (whiteness not rejected).
    n_samples : int
        Length n of the series.
    """

    lags: np.ndarray = field(repr=False)
    lag_s: np.ndarray = field(repr=False)
    acf: np.ndarray = field(repr=False)
    band: float
    fraction_outside: float
    q_statistic: float
    degrees_of_freedom: int
    p_value: float
    alpha: float
    white: bool
    n_samples: int

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        return jsonable(self, arrays)


def residual_whiteness(
    residual_m: np.ndarray,
    max_lag: int | None = None,
    *,
    sample_interval_s: float | None = None,
    alpha: float = 0.05,
    fitted_parameters: int = 0,
) -> Whiteness:
    """ACF with its ±1.96/sqrt(n) band and the Ljung–Box test over lags 1 ... L.

    Parameters
    ----------
    residual_m : array (n,)
        Residuals (m), n >= 20.
    max_lag : int, optional
        L; default :func:`default_max_lag`.
    sample_interval_s : float, optional
        Sample interval (s), to give the lags in seconds too.
    alpha : float
        Level of the test (default 0.05).
    fitted_parameters : int
        Degrees of freedom to subtract (default 0).

    Returns
    -------
    Whiteness

    Raises
    ------
    BeamInputError
        Fewer than 20 samples, NaN, a constant series, a lag out of range.
    """
    series = as_signal(residual_m, "residual_m", min_samples=MIN_SAMPLES)
    n = series.size
    lags = default_max_lag(n) if max_lag is None else integer(max_lag, "max_lag", 1, n - 1)
    if not 0 < alpha < 1:
        raise BeamInputError(f"alpha must lie in (0, 1), got {alpha}")
    fitted_parameters = integer(fitted_parameters, "fitted_parameters", 0, lags - 1)
    acf = autocorrelation(series, lags)[1:]
    q = _q_statistic(acf, n)
    p = float(scipy.stats.chi2.sf(q, lags - fitted_parameters))
    band = 1.96 / math.sqrt(n)
    k = np.arange(1, lags + 1)
    dt = float("nan") if sample_interval_s is None else float(sample_interval_s)
    return Whiteness(
        lags=k, lag_s=k * dt, acf=acf, band=band, fraction_outside=float(np.mean(np.abs(acf) > band)),
        q_statistic=q, degrees_of_freedom=lags - fitted_parameters, p_value=p, alpha=float(alpha),
        white=bool(p >= alpha), n_samples=n,
    )
