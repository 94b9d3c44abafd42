"""The sensor's noise floor, estimated from a record without any model.

A calibrated model that misses physics estimates a noise sd far above the sensor's (the
discrepancy is absorbed as noise), so the model cannot be asked how noisy the record is. Here the
noise floor comes from the record alone: the Welch power spectral density of the output, split
into sub-bands between 10 % and 80 % of the Nyquist frequency, the median level of each sub-band
(robust to the few bins a mode or a harmonic occupies), and the **quietest** sub-band taken as
white noise: sd = sqrt(level × f_Nyquist) (one-sided density). Signal only adds power, so the
quietest band is the closest to the noise alone; the bands stop short of the Nyquist frequency,
where anti-alias and sensor low-pass filters roll the noise off.

Measured on the five bundled records (true noise 5–20 µm, 800–1500 samples/s, modes up to a
few hundred Hz): 0.93–1.05 × the true sd (``tests/test_noise_floor.py`` checks fresh random
records). When the signal fills the whole band (a broadband input sampled barely above its
content) the estimate is an upper bound; when the noise is coloured it is the level of the
quietest band. Irregular time stamps are treated as uniform at the median step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from beam.errors import BeamInputError

__all__ = ["NoiseFloor", "noise_floor"]

#: Sub-bands of the spectrum searched for the quietest level, and their span (fractions of Nyquist).
SUB_BANDS = 8
BAND_SPAN = (0.1, 0.8)


@dataclass(frozen=True)
class NoiseFloor:
    """A model-free estimate of the white-noise sd of a record.

    Attributes
    ----------
    sd : float
        Noise standard deviation (the output's unit, e.g. m).
    band_Hz : (float, float)
        The quietest sub-band, whose level gave ``sd``.
    levels : tuple of float
        The sd each sub-band's median level would give, lowest frequency first.
    """

    sd: float
    band_Hz: tuple[float, float]
    levels: tuple[float, ...]


def noise_floor(time_s: np.ndarray, output: np.ndarray) -> NoiseFloor:
    """Estimate the sensor's noise sd from a record alone (see the module notes).

    Parameters
    ----------
    time_s : ndarray, shape (n,)
        Increasing time stamps (s); the median step sets the sampling frequency.
    output : ndarray, shape (n,)
        The measured output (any unit).

    Returns
    -------
    NoiseFloor

    Raises
    ------
    BeamInputError
        Fewer than 64 samples, or non-finite values.
    """
    from scipy import signal  # slow import, only when asked

    t = np.asarray(time_s, dtype=float)
    y = np.asarray(output, dtype=float)
    if y.size < 64 or t.size != y.size:
        raise BeamInputError(f"a noise floor needs at least 64 samples with their time stamps, got {y.size}")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(t))):
        raise BeamInputError("a noise floor needs finite samples")
    step = float(np.median(np.diff(t)))
    if not step > 0:
        raise BeamInputError("a noise floor needs increasing time stamps")
    fs = 1.0 / step
    nperseg = int(min(256, y.size // 8))
    freq, psd = signal.welch(y - np.median(y), fs=fs, nperseg=nperseg, detrend="linear")
    nyquist = 0.5 * fs
    edges = np.linspace(BAND_SPAN[0] * nyquist, BAND_SPAN[1] * nyquist, SUB_BANDS + 1)
    levels = []
    for low, high in zip(edges[:-1], edges[1:]):
        inside = psd[(freq >= low) & (freq < high)]
        levels.append(float(np.sqrt(np.median(inside) * nyquist)) if inside.size else np.inf)
    quietest = int(np.argmin(levels))
    return NoiseFloor(levels[quietest], (float(edges[quietest]), float(edges[quietest + 1])), tuple(levels))
