"""The toy model, its spectral starting points and its inference problem (see :mod:`beam.toy`)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from beam.inference.likelihood import AR1_COEFFICIENT, NOISE_SD
from beam.inference.priors import LogUniform, Uniform
from beam.inference.problem import Parameter, Problem
from beam.toy.scenario import (
    AMPLITUDE_PRIOR,
    AR1_PRIOR,
    FREQUENCY_PRIOR_HZ,
    NOISE_PRIOR,
    wrap_phase,
)


def sine_model(values: Mapping[str, np.ndarray], time_s: np.ndarray) -> np.ndarray:
    """Vectorised model ``A sin(2π f t + φ)``, shape (B, len(time_s)), in du."""
    a = np.asarray(values["amplitude"], dtype=float)[:, None]
    f = np.asarray(values["frequency_Hz"], dtype=float)[:, None]
    phi = np.asarray(values["phase_rad"], dtype=float)[:, None]
    return a * np.sin((2.0 * math.pi) * f * np.asarray(time_s, dtype=float)[None, :] + phi)


def _ls_sine_fit(t: np.ndarray, y: np.ndarray, freqs: np.ndarray):
    """Least-squares ``a sin ωt + b cos ωt`` at each frequency: (a, b, RSS reduction)."""
    w = 2.0 * math.pi * freqs[:, None] * t[None, :]
    s, c = np.sin(w), np.cos(w)
    sy, cy = s @ y, c @ y
    ss, cc, sc = np.einsum("ij,ij->i", s, s), np.einsum("ij,ij->i", c, c), np.einsum("ij,ij->i", s, c)
    det = ss * cc - sc * sc
    det = np.where(det > 1e-12 * ss * cc, det, np.inf)
    a = (cc * sy - sc * cy) / det
    b = (ss * cy - sc * sy) / det
    return a, b, a * sy + b * cy


def spectral_initial_guesses(
    time_s: np.ndarray,
    data: np.ndarray,
    *,
    f_range_Hz: tuple[float, float] = FREQUENCY_PRIOR_HZ,
    n_peaks: int = 3,
    phase_centre_rad: float = 0.0,
) -> list[dict[str, float]]:
    """Starting points from the least-squares (Lomb–Scargle-type) periodogram.

    For every frequency of a grid ten times finer than the Fourier resolution ``1/T`` the
    best ``a sin ωt + b cos ωt`` is fitted by linear least squares; the reduction of the
    residual sum of squares is the profile log likelihood of the frequency. The ``n_peaks``
    highest local maxima are refined by parabolic interpolation and converted to
    ``A = hypot(a, b) > 0`` and ``φ = atan2(b, a)`` on the phase branch. Unlike an FFT peak
    this is exact for windows of only one or two periods.

    Returns
    -------
    list of dict
        ``{"amplitude", "frequency_Hz", "phase_rad"}`` per peak, best first (natural units).
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(data, dtype=float)
    span = max(float(t[-1] - t[0]), 1e-9)
    df = 0.1 / span
    freqs = np.arange(f_range_Hz[0], f_range_Hz[1] + 0.5 * df, df)
    freqs = freqs[freqs <= f_range_Hz[1]]
    _, _, red = _ls_sine_fit(t, y, freqs)
    padded = np.concatenate([[-np.inf], red, [-np.inf]])
    peaks = np.flatnonzero((padded[1:-1] >= padded[:-2]) & (padded[1:-1] >= padded[2:]))
    peaks = peaks[np.argsort(red[peaks])[::-1]][:n_peaks]
    guesses = []
    for k in peaks:
        f = freqs[k]
        if 0 < k < freqs.size - 1:
            y0, y1, y2 = red[k - 1], red[k], red[k + 1]
            curv = y0 - 2.0 * y1 + y2
            if curv < 0.0:
                f = freqs[k] + 0.5 * df * (y0 - y2) / curv
        a, b, _ = _ls_sine_fit(t, y, np.array([f]))
        amp = float(np.clip(math.hypot(a[0], b[0]), AMPLITUDE_PRIOR[0], AMPLITUDE_PRIOR[1]))
        guesses.append(
            {"amplitude": amp, "frequency_Hz": float(f), "phase_rad": float(wrap_phase(math.atan2(b[0], a[0]), phase_centre_rad))}
        )
    return guesses


def phase_branch_centre(time_s: np.ndarray, data: np.ndarray) -> float:
    """Centre of the phase branch: 0, or π when the spectral phase estimate is near ±π."""
    best = spectral_initial_guesses(time_s, data, n_peaks=1)[0]
    return math.pi if abs(best["phase_rad"]) > 0.5 * math.pi else 0.0


def toy_problem(
    time_s: np.ndarray,
    data: np.ndarray,
    *,
    likelihood: str = "iid",
    fixed: Mapping[str, float] | None = None,
    phase_centre_rad: float = 0.0,
) -> Problem:
    """The toy calibration problem on one window of data.

    Parameters
    ----------
    time_s, data : ndarray, shape (n,)
        Calibration samples (uniform grid; seconds and du).
    likelihood : {"iid", "ar1"}
        Noise model.
    fixed : mapping, optional
        Parameters held at known values (e.g. ``{"frequency_Hz": 1, "phase_rad": 0.3}``).
    phase_centre_rad : float
        Centre of the phase branch (see the module docstring).

    Returns
    -------
    Problem
        Priors as in the module docstring; initial guesses from
        :func:`spectral_initial_guesses`.
    """
    fixed = dict(fixed or {})
    params = [
        Parameter("amplitude", LogUniform(*AMPLITUDE_PRIOR), "du", "amplitude A of the sine"),
        Parameter("frequency_Hz", Uniform(*FREQUENCY_PRIOR_HZ), "Hz", "frequency f"),
        Parameter("phase_rad", Uniform(phase_centre_rad - math.pi, phase_centre_rad + math.pi), "rad", "phase φ at t = 0"),
        Parameter(NOISE_SD, LogUniform(*NOISE_PRIOR), "du", "noise standard deviation (estimated)"),
    ]
    if likelihood == "ar1":
        params.append(Parameter(AR1_COEFFICIENT, Uniform(*AR1_PRIOR, coordinate="logit"), "1", "lag-one correlation of the residuals"))
    params = [p for p in params if p.name not in fixed]

    def guesses(problem: Problem) -> list[dict[str, float]]:
        if "frequency_Hz" in problem.fixed:  # linear in the rest: one start is enough
            return [{}]
        return spectral_initial_guesses(problem.time_s, problem.data, phase_centre_rad=phase_centre_rad)

    return Problem(
        parameters=params,
        model=sine_model,
        time_s=time_s,
        data=data,
        likelihood=likelihood,
        fixed=fixed,
        initial_guesses=guesses,
        name="toy sine",
        data_unit="du",
    )
