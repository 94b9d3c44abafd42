"""The sensor's noise floor, estimated from a record without any model: one estimator for the
command line, the beam view and the diagnosis.

A calibrated model that misses physics estimates a noise sd far above the sensor's (the
discrepancy is absorbed as noise), so the model cannot be asked how noisy the record is. Here the
noise floor comes from the record alone, as the **lower of two model-free upper bounds** (signal
only ever adds to either):

* **spectrum**: the Welch power spectral density of the output, split into sub-bands between
  10 % and 80 % of the Nyquist frequency, the median level of each sub-band (robust to the few
  bins a mode or a harmonic occupies), and the **quietest** sub-band taken as white noise:
  sd = sqrt(level × f_Nyquist) (one-sided density). The bands stop short of the Nyquist
  frequency, where anti-alias and sensor low-pass filters roll the noise off. It needs uniform
  stamps: on irregular ones (treated as uniform at the median step) the smooth signal sampled at
  jittered times leaks over the whole band;
* **differences**: the 4th divided difference of five consecutive samples at their **own** time
  stamps (weights that annihilate every cubic through them, scaled to unit norm, so white noise
  of sd sigma gives values of sd sigma whatever the spacing), sd = 1.4826 × their median absolute
  deviation (robust to the few windows that straddle a logger's gap). It is blind to stamp
  jitter but not to signal near the Nyquist frequency, where the spectrum bound is the lower.

:func:`record_noise_floor` is what every part of the application shows and compares with: the
floor of the record **as calibrated** (``result.setup.measurement``: decimated when over-long,
the samples the calibration's errors are computed on), all of it, at its recorded stamps: not
interpolated onto a grid (linear interpolation averages neighbouring samples and lowers the noise),
not cut at a release (the record before a release is noise too).

Irregular stamps are treated as uniform at the median step by the spectrum bound only. When the
noise is coloured the estimate is the level of the quietest band, or the sd of the noise's
fourth differences, whichever is lower.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from beam.errors import BeamInputError

__all__ = ["NoiseFloor", "noise_floor", "record_noise_floor", "difference_noise_sd", "fourth_differences"]

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
        The quietest sub-band of the spectrum bound.
    levels : tuple of float
        The sd each sub-band's median level would give, lowest frequency first.
    method : str
        Which bound gave ``sd``: ``"spectrum"`` (the quietest sub-band) or ``"differences"``
        (the 4th divided differences at the recorded stamps).
    """

    sd: float
    band_Hz: tuple[float, float]
    levels: tuple[float, ...]
    method: str = "spectrum"


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
    spectrum_sd, band = levels[quietest], (float(edges[quietest]), float(edges[quietest + 1]))
    differences_sd = difference_noise_sd(t, y)
    if differences_sd < spectrum_sd:
        return NoiseFloor(differences_sd, band, tuple(levels), "differences")
    return NoiseFloor(spectrum_sd, band, tuple(levels), "spectrum")


def difference_noise_sd(time_s: np.ndarray, output: np.ndarray) -> float:
    """The differences bound of the noise sd (see the module notes): 1.4826 × the median absolute
    deviation of the unit-norm 4th divided differences of five consecutive samples.

    The divided difference's weights on samples t_0 … t_4 are w_i = 1 / prod_{j != i} (t_i - t_j):
    they annihilate every cubic in t (whatever the spacing); scaled by 1 / ||w|| a white noise of
    sd sigma gives differences of sd sigma. Hand-written (numpy): a closed form, vectorised.

    Parameters
    ----------
    time_s, output : ndarray, shape (n,), n >= 5
        Increasing stamps (s) and samples (any unit).

    Returns
    -------
    float
        The noise sd (the output's unit).
    """
    differences = fourth_differences(time_s, output)
    return float(1.4826 * np.median(np.abs(differences - np.median(differences))))


def fourth_differences(time_s: np.ndarray, output: np.ndarray) -> np.ndarray:
    """The unit-norm 4th divided differences of each five consecutive samples at their own stamps
    (:func:`difference_noise_sd`): (n - 4,) values, the k-th centred on sample k + 2; white noise
    of sd sigma gives differences of sd sigma, any cubic through the five samples gives 0.

    Parameters
    ----------
    time_s, output : ndarray, shape (n,), n >= 5
        Increasing stamps (s) and samples (any unit).
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(output, dtype=float)
    scale = float(np.median(np.diff(t)))
    windows = np.lib.stride_tricks.sliding_window_view(t / scale, 5)
    weights = np.ones_like(windows)
    for i in range(5):
        for j in range(5):
            if i != j:
                weights[:, i] /= windows[:, i] - windows[:, j]
    weights /= np.linalg.norm(weights, axis=1, keepdims=True)
    return np.einsum("ij,ij->i", weights, np.lib.stride_tricks.sliding_window_view(y, 5))


def record_noise_floor(measurement) -> NoiseFloor:
    """The noise floor of a record, as every part of the application shows it (see the module notes).

    Parameters
    ----------
    measurement : beam.io.measurement.Measurement
        The record **as calibrated** (``CalibrationResult.setup.measurement``), all its samples at
        their recorded stamps.

    Returns
    -------
    NoiseFloor
        In the output's unit (m, m/s or m/s²).

    Raises
    ------
    BeamInputError
        Fewer than 64 samples, or non-finite values.
    """
    return noise_floor(measurement.time_s, measurement.output)
