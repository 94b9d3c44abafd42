"""Residual spectrum: at which frequencies the model fails.

Welch power spectral densities (:func:`scipy.signal.welch`, Hann window, 50 % overlap, mean
removed) of the residual data − prediction and of the data, with the same settings. The largest
residual peaks are picked by prominence (in dB) and located to a fraction of a bin by a
parabola through the log-PSD; for each model mode the residual-to-data power ratio in a band
around it says whether the model explains the response there (ratio << 1) or not (ratio ~ 1).

PSDs are one-sided, in m²/Hz.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.signal

from beam.errors import BeamInputError
from beam.io.anchor import refine_peak as _refine
from beam.residuals.common import check_signals, integer, jsonable, positive

__all__ = ["ModePower", "ResidualSpectrum", "SpectralPeak", "default_nperseg", "residual_spectrum"]

#: Fewest samples a spectrum accepts.
MIN_SAMPLES = 64


def default_nperseg(n_samples: int) -> int:
    """Welch segment length for a record of n samples.

    The largest power of two <= n / 4 (about seven half-overlapping segments), at least 256 and
    at most n: 256 for 500 samples, 1024 for 4,700, 2048 for 10,000.
    """
    power = 2 ** int(np.floor(np.log2(max(n_samples / 4, 1))))
    return int(min(n_samples, max(256, power)))


@dataclass(frozen=True)
class SpectralPeak:
    """A peak of the residual PSD.

    Parameters
    ----------
    frequency_Hz : float
        Peak frequency, refined between bins (Hz).
    psd_m2_Hz : float
        Residual PSD at the peak bin (m²/Hz).
    prominence_db : float
        Prominence of the peak over its surroundings (dB).
    nearest_mode : int
        Model mode (1-based) nearest in frequency; 0 without model frequencies.
    offset_from_mode : float
        frequency / nearest mode frequency − 1 (NaN without model frequencies).
    """

    frequency_Hz: float
    psd_m2_Hz: float
    prominence_db: float
    nearest_mode: int
    offset_from_mode: float


@dataclass(frozen=True)
class ModePower:
    """Residual and data power in a band around one model mode.

    ``ratio`` = residual power / data power in [frequency_Hz ± halfwidth_Hz]: << 1 when the
    model explains the response near this mode, ~1 or more when it misses it.
    """

    mode: int
    frequency_Hz: float
    halfwidth_Hz: float
    residual_power_m2: float
    data_power_m2: float
    ratio: float


@dataclass(frozen=True, eq=False)
class ResidualSpectrum:
    """Welch PSDs of the residual and the data, peaks and per-mode power ratios.

    Parameters
    ----------
    frequency_Hz : ndarray
        Frequencies of the PSD bins (Hz).
    residual_psd_m2_Hz, data_psd_m2_Hz : ndarray
        One-sided PSDs (m²/Hz).
    model_frequencies_Hz : ndarray
        Model natural frequencies passed in, for marking (Hz).
    nperseg : int
        Welch segment length (samples).
    resolution_Hz : float
        Bin spacing (Hz).
    peaks : tuple of SpectralPeak
        Largest residual peaks, largest first.
    modes : tuple of ModePower
        One per model frequency below the Nyquist frequency.
    residual_power_fraction : float
        Residual variance / data variance.
    """

    frequency_Hz: np.ndarray = field(repr=False)
    residual_psd_m2_Hz: np.ndarray = field(repr=False)
    data_psd_m2_Hz: np.ndarray = field(repr=False)
    model_frequencies_Hz: np.ndarray
    nperseg: int
    resolution_Hz: float
    peaks: tuple[SpectralPeak, ...]
    modes: tuple[ModePower, ...]
    residual_power_fraction: float

    @property
    def peak_frequencies_Hz(self) -> np.ndarray:
        """Frequencies of the residual peaks, largest peak first (Hz)."""
        return np.array([p.frequency_Hz for p in self.peaks])

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        return jsonable(self, arrays)


def residual_spectrum(
    time_s: np.ndarray,
    data_m: np.ndarray,
    prediction_m: np.ndarray,
    model_frequencies_Hz: Sequence[float] | np.ndarray = (),
    *,
    nperseg: int | None = None,
    max_peaks: int = 5,
    prominence_db: float = 6.0,
    mode_halfwidth: float = 0.1,
) -> ResidualSpectrum:
    """Welch PSD of the residual and of the data, residual peaks and per-mode power ratios.

    Parameters
    ----------
    time_s : array (n,)
        Uniform sample times (s), n >= 64.
    data_m, prediction_m : array (n,)
        Measured displacement and model prediction (m).
    model_frequencies_Hz : sequence of float
        Natural frequencies of the model (Hz), lowest first, e.g. from
        :meth:`beam.physics.model.BeamModel.natural_modes`.
    nperseg : int, optional
        Welch segment length; default :func:`default_nperseg`.
    max_peaks : int
        Number of residual peaks reported (default 5).
    prominence_db : float
        Smallest prominence of a reported peak (dB, default 6).
    mode_halfwidth : float
        Half-width of the band around each mode, relative to its frequency (default 0.1); at
        least two bins.

    Returns
    -------
    ResidualSpectrum

    Raises
    ------
    BeamInputError
        Fewer than 64 samples, NaN, mismatched lengths, a data record of zero power.
    """
    time, dt, (data, prediction) = check_signals(time_s, MIN_SAMPLES, data_m=data_m, prediction_m=prediction_m)
    n = time.size
    nperseg = default_nperseg(n) if nperseg is None else integer(nperseg, "nperseg", 16, n)
    max_peaks = integer(max_peaks, "max_peaks", 0)
    mode_halfwidth = positive(mode_halfwidth, "mode_halfwidth")
    model_frequencies = np.atleast_1d(np.asarray(model_frequencies_Hz, dtype=float))
    if model_frequencies.ndim != 1 or not np.all(np.isfinite(model_frequencies)) or np.any(model_frequencies < 0):
        raise BeamInputError("model_frequencies_Hz must be finite frequencies >= 0 (Hz)")
    residual = data - prediction
    if not np.var(data) > 0:
        raise BeamInputError("data_m is constant: its spectrum is empty")
    settings = {"fs": 1.0 / dt, "window": "hann", "nperseg": nperseg, "noverlap": nperseg // 2, "detrend": "constant"}
    frequency, residual_psd = scipy.signal.welch(residual, **settings)
    _, data_psd = scipy.signal.welch(data, **settings)
    resolution = float(frequency[1] - frequency[0])

    # peaks of the residual PSD by prominence in dB (the DC and Nyquist bins are never peaks)
    floor = max(residual_psd.max(), np.finfo(float).tiny) * 1e-30
    log_psd = 10 * np.log10(np.maximum(residual_psd, floor))
    indices, properties = scipy.signal.find_peaks(log_psd, prominence=prominence_db)
    order = np.argsort(residual_psd[indices])[::-1][:max_peaks]
    peaks = []
    for j in order:
        i = int(indices[j])
        f_peak = _refine(frequency, log_psd, i)
        if model_frequencies.size:
            nearest = int(np.argmin(np.abs(model_frequencies - f_peak)))
            offset = f_peak / model_frequencies[nearest] - 1 if model_frequencies[nearest] > 0 else float("nan")
            mode = nearest + 1
        else:
            mode, offset = 0, float("nan")
        peaks.append(SpectralPeak(f_peak, float(residual_psd[i]), float(properties["prominences"][j]), mode, float(offset)))

    modes = []
    nyquist = 0.5 / dt
    for k, f_mode in enumerate(model_frequencies):
        if not 0 < f_mode < nyquist:
            continue
        halfwidth = max(mode_halfwidth * f_mode, 2 * resolution)
        band = np.abs(frequency - f_mode) <= halfwidth
        residual_power = float(residual_psd[band].sum() * resolution)
        data_power = float(data_psd[band].sum() * resolution)
        ratio = residual_power / data_power if data_power > 0 else float("nan")
        modes.append(ModePower(k + 1, float(f_mode), float(halfwidth), residual_power, data_power, ratio))

    return ResidualSpectrum(
        frequency_Hz=frequency, residual_psd_m2_Hz=residual_psd, data_psd_m2_Hz=data_psd,
        model_frequencies_Hz=model_frequencies, nperseg=nperseg, resolution_Hz=resolution, peaks=tuple(peaks),
        modes=tuple(modes), residual_power_fraction=float(np.var(residual) / np.var(data)),
    )
