"""Envelope and instantaneous frequency of one mode in the free decay: backbone and decay law.

For a linear, viscously damped beam each mode rings down as A e^{−sigma t} cos(omega_d t + phi):
its frequency does not depend on its amplitude, and its log-envelope is a straight line of slope
−sigma = −zeta omega_n. A hardening spring (the ``tip_cubic_spring`` effect) raises the frequency
at large amplitude; amplitude-dependent damping bends the log-envelope.

:func:`mode_envelope` isolates one mode of the free decay with a zero-phase Butterworth
band-pass (:func:`scipy.signal.sosfiltfilt`) around its frequency and takes the analytic signal
(:func:`scipy.signal.hilbert`): envelope |a(t)| (m) and instantaneous frequency d arg a / dt / 2pi
(Hz), both smoothed over a few periods. The decay is first continued at both ends by linear
prediction, which keeps the filter's and the Hilbert transform's edge transients out of the
record (they otherwise bend the log-envelope by several % over the first and last periods).
:func:`backbone` bins the instantaneous frequency by amplitude and fits its slope (Hz/m);
:func:`decay_law` fits the log-envelope against time (decay rate, R², curvature) and gives the
damping ratio per amplitude bin. :func:`analyse_mode` does all three.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.ndimage
import scipy.signal
import scipy.stats

from beam.errors import BeamInputError
from beam.residuals.common import check_signals, integer, jsonable, positive
from beam.residuals.modal_id import free_decay_start

__all__ = [
    "Backbone",
    "DecayLaw",
    "ModeAnalysis",
    "ModeEnvelope",
    "analyse_mode",
    "backbone",
    "check_backbone",
    "spectral_drift",
    "decay_frequency_drift",
    "decay_law",
    "extrapolate",
    "mode_envelope",
]

#: Fewest envelope samples (after trimming) the analyses accept.
MIN_ENVELOPE_SAMPLES = 32
#: |relative frequency change| over the amplitude range below which a backbone counts as flat.
FLAT_BACKBONE = 2e-3
#: Fewest cycles of the mode the envelope must span for its backbone to be read at all (four in each
#: third of the spectral check, :func:`spectral_drift`).
MIN_BACKBONE_CYCLES = 12
#: Drifts (relative) below which neither the backbone nor the spectral check resolves one: the two
#: then agree when both are below it.
DRIFT_FLOOR = 1e-3
#: Largest ratio between the backbone's shift and the spectral drift (either way) that still agrees.
DRIFT_AGREEMENT = 2.0
#: A free decay whose dominant mode's frequency rises by more than this (relative, from the first
#: third of the decay to the last; :func:`decay_frequency_drift`) softens at large amplitude: ten
#: times what the quadratic drag alone, whose frequency shift is of second order, leaves on a
#: simulated strip decay (``docs/decisions.md``).
RISING_DRIFT = 2e-4


@dataclass(frozen=True, eq=False)
class ModeEnvelope:
    """Envelope and instantaneous frequency of one band-passed mode in the free decay.

    Parameters
    ----------
    time_s : ndarray
        Sample times kept (s): the decay less the trimmed edges, down to the amplitude cut-off.
    envelope_m : ndarray
        Smoothed envelope |a(t)| (m).
    frequency_Hz : ndarray
        Smoothed instantaneous frequency (Hz).
    centre_frequency_Hz : float
        Frequency the band is centred on (Hz).
    band_Hz : tuple of float
        Pass band (Hz).
    start_s : float
        Start of the free decay (s).
    """

    time_s: np.ndarray = field(repr=False)
    envelope_m: np.ndarray = field(repr=False)
    frequency_Hz: np.ndarray = field(repr=False)
    centre_frequency_Hz: float
    band_Hz: tuple[float, float]
    start_s: float

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        return jsonable(self, arrays)


@dataclass(frozen=True, eq=False)
class Backbone:
    """Instantaneous frequency against amplitude.

    Parameters
    ----------
    amplitude_m, frequency_Hz, frequency_std_Hz, counts : ndarray
        Per amplitude bin: mean envelope (m), mean and standard deviation of the
        instantaneous frequency (Hz), samples.
    slope_Hz_per_m, slope_stderr_Hz_per_m : float
        Slope of a straight-line fit of frequency against amplitude through the bins, and its
        standard error.
    intercept_Hz : float
        The straight-line fit at zero amplitude (Hz).
    frequency_at_zero_amplitude_Hz, duffing_Hz_per_m2 : float
        f0 and c of the fit f = f0 + c A² through the bins, the form of a cubic spring's
        backbone (f0: the linear natural frequency; c > 0 hardening).
    relative_shift : float
        (f(A_max) − f(A_min)) / f(A_min) along the fit: the fractional frequency change over the
        amplitude range seen (> 0 hardening).
    verdict : str
        ``"hardening"``, ``"softening"`` or ``"linear"`` (|relative_shift| < threshold or a slope
        within two standard errors of zero).
    """

    amplitude_m: np.ndarray
    frequency_Hz: np.ndarray
    frequency_std_Hz: np.ndarray
    counts: np.ndarray
    slope_Hz_per_m: float
    slope_stderr_Hz_per_m: float
    intercept_Hz: float
    frequency_at_zero_amplitude_Hz: float
    duffing_Hz_per_m2: float
    relative_shift: float
    verdict: str
    #: (f_early − f_late) / f_late of the mode's spectral peak in the first and last stretches of
    #: the envelope (:func:`spectral_drift`), NaN when not measured.
    spectral_drift: float = float("nan")
    #: Whether the backbone can be trusted (:func:`check_backbone`); when not, ``unreliable``
    #: says why and the shift must be read as unknown.
    reliable: bool = True
    unreliable: str = ""

    def to_dict(self, arrays: bool = True) -> dict[str, Any]:
        return jsonable(self, arrays)


@dataclass(frozen=True, eq=False)
class DecayLaw:
    """Log-envelope against time, and damping against amplitude.

    Parameters
    ----------
    decay_rate_1_s : float
        sigma of the straight-line fit ln A = c − sigma t (1/s).
    damping_ratio : float
        sigma / omega of that fit (omega from the mean instantaneous frequency).
    r_squared : float
        R² of the straight-line fit (1 for exponential decay; less is either noise or a bent
        log-envelope — see ``decay_rate_change``).
    rms_log_residual : float
        RMS of ln A about the straight line (nepers; 0.01 is a 1 % wobble of the envelope).
    quadratic_1_s2 : float
        c2 of the fit ln A = c0 + c1 t + c2 t² (1/s²).
    decay_rate_change : float
        (sigma_end − sigma_start) / sigma of the quadratic fit: 0 for viscous damping, > 0 when
        the decay speeds up as the amplitude falls (friction-like), < 0 when it slows down
        (damping that grows with amplitude).
    amplitude_m, damping_ratio_by_amplitude : ndarray
        Per amplitude bin: mean envelope (m) and the damping ratio from the local slope of the
        log-envelope.
    """

    decay_rate_1_s: float
    damping_ratio: float
    r_squared: float
    rms_log_residual: float
    quadratic_1_s2: float
    decay_rate_change: float
    amplitude_m: np.ndarray
    damping_ratio_by_amplitude: np.ndarray

    def to_dict(self, arrays: bool = True) -> dict[str, Any]:
        return jsonable(self, arrays)


@dataclass(frozen=True, eq=False)
class ModeAnalysis:
    """Envelope, backbone and decay law of one mode."""

    envelope: ModeEnvelope
    backbone: Backbone
    decay: DecayLaw

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        return {
            "envelope": self.envelope.to_dict(arrays),
            "backbone": self.backbone.to_dict(arrays),
            "decay": self.decay.to_dict(arrays),
        }


def extrapolate(x: np.ndarray, count: int, order: int = 32, fit_samples: int | None = None) -> np.ndarray:
    """Continue a series by ``count`` samples by least-squares linear prediction.

    An AR(order) predictor x[k] = sum_j a_j x[k − j] is fitted by least squares on the last
    ``fit_samples`` samples (default all) and run on (the zero-input response of the all-pole
    filter, :func:`scipy.signal.lfilter`); poles outside the unit circle are moved onto it, so
    the continuation never grows. A sum of damped sinusoids is continued exactly; this is what
    keeps the band-pass filter and the Hilbert transform free of edge effects.

    Parameters
    ----------
    x : array (n,)
        The series, n > 2 order.
    count : int
        Samples to add.
    order : int
        Order of the predictor (default 32: enough for several modes in noise).
    fit_samples : int, optional
        Fit on the last this many samples.

    Returns
    -------
    ndarray (count,)
    """
    segment = x if fit_samples is None else x[-max(fit_samples, 2 * order + 1):]
    order = min(order, (segment.size - 1) // 2)
    rows = np.lib.stride_tricks.sliding_window_view(segment, order + 1)
    coefficients = np.linalg.lstsq(rows[:, :-1][:, ::-1], rows[:, -1], rcond=None)[0]  # a_1 ... a_p
    denominator = np.concatenate([[1.0], -coefficients])
    roots = np.roots(denominator)
    outside = np.abs(roots) > 1
    if outside.any():
        roots[outside] /= np.abs(roots[outside])
        denominator = np.real(np.poly(roots))
    state = scipy.signal.lfiltic([1.0], denominator, segment[::-1][:order])
    return scipy.signal.lfilter([1.0], denominator, np.zeros(count), zi=state)[0]


def mode_envelope(
    time_s: np.ndarray,
    displacement_m: np.ndarray,
    frequency_Hz: float,
    voltage_V: np.ndarray | None = None,
    *,
    start_s: float | None = None,
    threshold_V: float = 0.0,
    relative_bandwidth: float = 0.25,
    filter_order: int = 4,
    smoothing_periods: float = 2.0,
    pad_periods: float = 8.0,
    trim_periods: float = 1.0,
    min_relative_envelope: float = 0.05,
) -> ModeEnvelope:
    """Band-pass one mode of the free decay and take its envelope and instantaneous frequency.

    The decay is first continued at both ends by linear prediction (:func:`extrapolate`), so
    that the filter's and the Hilbert transform's edge transients fall outside the record.

    Parameters
    ----------
    time_s, displacement_m : array (n,)
        Uniform sample times (s) and displacement (m).
    frequency_Hz : float
        Frequency of the mode (Hz), e.g. identified by :func:`beam.residuals.identify_modes`.
    voltage_V : array (n,), optional
        Piezo voltage (V): the decay starts after its last non-zero sample.
    start_s : float, optional
        Start of the free decay (s), instead of the voltage.
    threshold_V : float
        |V| at or below this counts as off (default 0).
    relative_bandwidth : float
        Pass band [f (1 − b), f (1 + b)] (default b = 0.25); keep it clear of the neighbouring
        modes and wide enough for the frequency's drift with amplitude.
    filter_order : int
        Butterworth order (default 4; doubled by the band-pass, then again by the forward-backward pass).
    smoothing_periods : float
        Moving-average length for envelope and frequency, in periods of the mode (default 2).
    pad_periods : float
        Length of the predicted continuation at each end, in periods (default 8).
    trim_periods : float
        Periods dropped at each end of the result, where the smoothing runs out (default 1).
    min_relative_envelope : float
        The envelope is cut where it first falls below this fraction of its maximum (default
        0.05): the tail is noise.

    Returns
    -------
    ModeEnvelope

    Raises
    ------
    BeamInputError
        Bad arrays, no free decay, a band outside (0, Nyquist), a decay too short.
    """
    time, dt, (y_all,) = check_signals(time_s, displacement_m=displacement_m)
    centre = positive(frequency_Hz, "frequency_Hz")
    bandwidth = positive(relative_bandwidth, "relative_bandwidth")
    filter_order = integer(filter_order, "filter_order", 1, 10)
    nyquist = 0.5 / dt
    low, high = centre * (1 - bandwidth), min(centre * (1 + bandwidth), 0.95 * nyquist)
    if not 0 < low < high:
        raise BeamInputError(
            f"the band {centre * (1 - bandwidth):g}–{centre * (1 + bandwidth):g} Hz around {centre:g} Hz does not fit "
            f"in (0, {nyquist:g}) Hz (Nyquist); check frequency_Hz and relative_bandwidth < 1"
        )
    first = free_decay_start(time, voltage_V, start_s=start_s, threshold_V=threshold_V)
    y = y_all[first:] - y_all[first:].mean()
    period = 1.0 / (centre * dt)  # samples per period
    pad = int(np.ceil(positive(pad_periods, "pad_periods") * period))
    trim = int(np.ceil(float(trim_periods) * period)) if trim_periods > 0 else 0
    width = max(1, round(positive(smoothing_periods, "smoothing_periods") * period))
    if y.size < 2 * trim + MIN_ENVELOPE_SAMPLES or y.size < 3 * period:
        raise BeamInputError(
            f"free decay too short for a {centre:g} Hz envelope: {y.size} samples "
            f"({y.size / period:.1f} periods), at least {max(2 * trim + MIN_ENVELOPE_SAMPLES, int(3 * period) + 1)} needed"
        )
    fit = int(16 * period)
    extended = np.concatenate([extrapolate(y[::-1], pad, fit_samples=fit)[::-1], y, extrapolate(y, pad, fit_samples=fit)])
    sos = scipy.signal.butter(filter_order, [low, high], btype="bandpass", fs=1.0 / dt, output="sos")
    analytic = scipy.signal.hilbert(scipy.signal.sosfiltfilt(sos, extended))
    envelope = scipy.ndimage.uniform_filter1d(np.abs(analytic), width, mode="nearest")
    phase = np.unwrap(np.angle(analytic))
    instantaneous = scipy.ndimage.uniform_filter1d(np.gradient(phase) / (2 * np.pi * dt), width, mode="nearest")
    kept = slice(pad + trim, pad + y.size - trim)
    envelope, instantaneous, t = envelope[kept], instantaneous[kept], time[first + trim : time.size - trim]
    if not envelope.max() > 0:
        raise BeamInputError(f"nothing rings near {centre:g} Hz in the free decay")
    low_envelope = np.flatnonzero(envelope < float(min_relative_envelope) * envelope.max())
    stop = int(low_envelope[0]) if low_envelope.size else envelope.size
    if stop < MIN_ENVELOPE_SAMPLES:
        raise BeamInputError(
            f"the {centre:g} Hz envelope falls below {min_relative_envelope:g} of its peak after {stop} samples; "
            f"at least {MIN_ENVELOPE_SAMPLES} needed"
        )
    return ModeEnvelope(
        time_s=t[:stop], envelope_m=envelope[:stop], frequency_Hz=instantaneous[:stop], centre_frequency_Hz=centre,
        band_Hz=(float(low), float(high)), start_s=float(time[first]),
    )


def _amplitude_bins(envelope: np.ndarray, bins: int) -> list[np.ndarray]:
    """Indices of the samples in each of ``bins`` equal-width amplitude bins (empty ones dropped)."""
    edges = np.linspace(envelope.min(), envelope.max(), bins + 1)
    which = np.clip(np.digitize(envelope, edges[1:-1]), 0, bins - 1)
    groups = [np.flatnonzero(which == b) for b in range(bins)]
    return [g for g in groups if g.size >= 3]


def backbone(envelope: ModeEnvelope, bins: int = 10, *, flat_threshold: float = FLAT_BACKBONE) -> Backbone:
    """Instantaneous frequency against amplitude, its slope and a hardening/softening verdict.

    Parameters
    ----------
    envelope : ModeEnvelope
        From :func:`mode_envelope`.
    bins : int
        Equal-width amplitude bins (default 10).
    flat_threshold : float
        |relative_shift| below this is ``"linear"`` (default 0.002, i.e. 0.2 %).

    Returns
    -------
    Backbone
    """
    bins = integer(bins, "bins", 3)
    groups = _amplitude_bins(envelope.envelope_m, bins)
    if len(groups) < 3:
        raise BeamInputError("the envelope spans too few amplitudes for a backbone (fewer than 3 filled bins)")
    amplitude = np.array([envelope.envelope_m[g].mean() for g in groups])
    frequency = np.array([envelope.frequency_Hz[g].mean() for g in groups])
    spread = np.array([envelope.frequency_Hz[g].std() for g in groups])
    counts = np.array([g.size for g in groups])
    fit = scipy.stats.linregress(amplitude, frequency)
    duffing = scipy.stats.linregress(amplitude**2, frequency)
    f_low = fit.intercept + fit.slope * amplitude.min()
    shift = fit.slope * (amplitude.max() - amplitude.min()) / f_low
    significant = abs(fit.slope) > 2 * fit.stderr
    verdict = "linear"
    if significant and abs(shift) >= flat_threshold:
        verdict = "hardening" if shift > 0 else "softening"
    return Backbone(
        amplitude_m=amplitude, frequency_Hz=frequency, frequency_std_Hz=spread, counts=counts,
        slope_Hz_per_m=float(fit.slope), slope_stderr_Hz_per_m=float(fit.stderr), intercept_Hz=float(fit.intercept),
        frequency_at_zero_amplitude_Hz=float(duffing.intercept), duffing_Hz_per_m2=float(duffing.slope),
        relative_shift=float(shift), verdict=verdict,
    )


def decay_law(envelope: ModeEnvelope, bins: int = 6) -> DecayLaw:
    """Fit the log-envelope against time; damping ratio per amplitude bin.

    Parameters
    ----------
    envelope : ModeEnvelope
        From :func:`mode_envelope`.
    bins : int
        Equal-width amplitude bins for the damping ratio against amplitude (default 6).

    Returns
    -------
    DecayLaw
    """
    bins = integer(bins, "bins", 1)
    t = envelope.time_s - envelope.time_s[0]
    log_envelope = np.log(envelope.envelope_m)
    omega = 2 * np.pi * float(np.mean(envelope.frequency_Hz))
    fit = scipy.stats.linregress(t, log_envelope)
    c2, c1, _ = np.polyfit(t, log_envelope, 2)
    duration = t[-1]
    rate_start, rate_end = -c1, -(c1 + 2 * c2 * duration)
    rate = -fit.slope
    change = (rate_end - rate_start) / rate if rate != 0 else float("nan")
    amplitude, zeta = [], []
    for g in _amplitude_bins(envelope.envelope_m, bins):
        if np.ptp(t[g]) > 0:
            local = scipy.stats.linregress(t[g], log_envelope[g])
            amplitude.append(envelope.envelope_m[g].mean())
            zeta.append(-local.slope / (2 * np.pi * envelope.frequency_Hz[g].mean()))
    return DecayLaw(
        decay_rate_1_s=float(rate), damping_ratio=float(rate / omega), r_squared=float(fit.rvalue**2),
        rms_log_residual=float(np.sqrt(np.mean((log_envelope - fit.intercept - fit.slope * t) ** 2))),
        quadratic_1_s2=float(c2), decay_rate_change=float(change), amplitude_m=np.array(amplitude),
        damping_ratio_by_amplitude=np.array(zeta),
    )


def analyse_mode(
    time_s: np.ndarray,
    displacement_m: np.ndarray,
    frequency_Hz: float,
    voltage_V: np.ndarray | None = None,
    *,
    start_s: float | None = None,
    bins: int = 10,
    **envelope_options: Any,
) -> ModeAnalysis:
    """:func:`mode_envelope`, then :func:`backbone` and :func:`decay_law` on it.

    ``envelope_options`` go to :func:`mode_envelope`; ``bins`` to both fits.
    """
    envelope = mode_envelope(time_s, displacement_m, frequency_Hz, voltage_V, start_s=start_s, **envelope_options)
    shape = check_backbone(backbone(envelope, bins), envelope, time_s, displacement_m)
    return ModeAnalysis(envelope, shape, decay_law(envelope, bins))


def spectral_drift(time_s: np.ndarray, signal: np.ndarray, frequency_Hz: float, start_s: float, stop_s: float,
                   relative_band: float = 0.2) -> tuple[float, float, float]:
    """A short-time spectral estimate of how one mode's frequency drifts over a stretch of a decay.

    The stretch [``start_s``, ``stop_s``] is cut into thirds; in the first and the last third the
    mode's peak is found in the Hann-windowed, 16× zero-padded spectrum within ``relative_band``
    of ``frequency_Hz`` and refined by a parabola through the log magnitudes of the three bins
    around it (Gaussian interpolation). Independent of the Hilbert backbone: no band-pass, no
    instantaneous phase, nothing binned by amplitude.

    Parameters
    ----------
    time_s, signal : ndarray, shape (n,)
        Uniform stamps (s) and samples (any unit).
    frequency_Hz : float
        The mode's frequency (Hz).
    start_s, stop_s : float
        The stretch of the decay (s).
    relative_band : float
        Half-width of the search band, relative to ``frequency_Hz``.

    Returns
    -------
    (float, float, float)
        f_early, f_late (Hz) and the drift (f_early − f_late) / f_late; NaN when a third holds
        fewer than 4 cycles.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(signal, dtype=float)
    dt = float(np.median(np.diff(t)))
    third = (stop_s - start_s) / 3.0
    if third * frequency_Hz < 4:
        return float("nan"), float("nan"), float("nan")
    peaks = []
    for a in (start_s, stop_s - third):
        piece = y[(t >= a) & (t < a + third)]
        piece = scipy.signal.detrend(piece) * np.hanning(piece.size)
        n = 16 * int(2 ** np.ceil(np.log2(piece.size)))
        magnitude = np.abs(np.fft.rfft(piece, n))
        freq = np.fft.rfftfreq(n, dt)
        inside = np.flatnonzero(np.abs(freq - frequency_Hz) <= relative_band * frequency_Hz)
        k = int(inside[np.argmax(magnitude[inside])])
        if 0 < k < magnitude.size - 1:
            la, lb, lc = np.log(magnitude[k - 1: k + 2] + 1e-300)
            offset = 0.5 * (la - lc) / (la - 2 * lb + lc) if la - 2 * lb + lc != 0 else 0.0
        else:
            offset = 0.0
        peaks.append(float(freq[k] + offset * (freq[1] - freq[0])))
    early, late = peaks
    return early, late, (early - late) / late


def decay_frequency_drift(time_s: np.ndarray, signal: np.ndarray) -> float:
    """How the dominant mode's frequency drifts over a free decay: (f_early − f_late) / f_late
    (:func:`spectral_drift`) from the record's largest excursion (the release) to its end,
    resampled onto uniform stamps (a sensor's jittered clock would bias the spectra's frequency
    scale). Negative: the frequency rises as the swing dies. NaN when a third of the decay holds
    fewer than 4 cycles.

    Parameters
    ----------
    time_s, signal : ndarray, shape (n,)
        Increasing stamps (s) and the free decay's samples (any unit).
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(signal, dtype=float)
    if t.size < 16 or t.shape != y.shape or not np.all(np.isfinite(y)):
        return float("nan")
    start = int(np.argmax(np.abs(y - np.median(y))))
    t, y = t[start:], y[start:]
    if t.size < 16 or t[-1] <= t[0]:
        return float("nan")
    uniform = np.linspace(t[0], t[-1], t.size)
    y = np.interp(uniform, t, y)
    dt = float(uniform[1] - uniform[0])
    magnitude = np.abs(np.fft.rfft((y - y.mean()) * np.hanning(y.size)))
    freq = np.fft.rfftfreq(y.size, dt)
    above = freq > 2.0 / (t[-1] - t[0])  # at least two cycles in the decay
    if not np.any(above):
        return float("nan")
    dominant = float(freq[above][np.argmax(magnitude[above])])
    return spectral_drift(uniform, y, dominant, float(uniform[0]), float(uniform[-1]))[2]


def check_backbone(shape: Backbone, envelope: ModeEnvelope, time_s: np.ndarray, signal: np.ndarray) -> Backbone:
    """``shape`` with its reliability judged against the record itself (see :class:`Backbone`).

    Unreliable (its shift is then unknown) when the envelope spans fewer than
    :data:`MIN_BACKBONE_CYCLES` cycles, when an amplitude bin's mean frequency leaves the pass band
    (the envelope follows something else: a harmonic, noise), or when the shift the backbone
    gives between the amplitudes of the first and last thirds of the envelope disagrees with the
    spectral drift between those thirds (:func:`spectral_drift`) by more than a factor
    :data:`DRIFT_AGREEMENT` (both below :data:`DRIFT_FLOOR` agree).
    """
    from dataclasses import replace

    span = float(envelope.time_s[-1] - envelope.time_s[0])
    cycles = span * envelope.centre_frequency_Hz
    low, high = envelope.band_Hz
    if cycles < MIN_BACKBONE_CYCLES:
        return replace(shape, reliable=False, unreliable=f"the mode's envelope spans {cycles:.0f} cycles, fewer than "
                                                         f"the {MIN_BACKBONE_CYCLES} a backbone needs")
    if np.any(shape.frequency_Hz < low) or np.any(shape.frequency_Hz > high):
        return replace(shape, reliable=False, unreliable=f"the tracked frequency leaves the mode's band "
                                                         f"({low:.3g}-{high:.3g} Hz): it follows another peak or noise")
    start, stop = float(envelope.time_s[0]), float(envelope.time_s[-1])
    _, _, drift = spectral_drift(time_s, signal, envelope.centre_frequency_Hz, start, stop)
    third = (stop - start) / 3.0
    t = envelope.time_s
    a_early = float(np.mean(envelope.envelope_m[t < start + third]))
    a_late = float(np.mean(envelope.envelope_m[t >= stop - third]))
    f_late = shape.intercept_Hz + shape.slope_Hz_per_m * a_late
    predicted = shape.slope_Hz_per_m * (a_early - a_late) / f_late
    shape = replace(shape, spectral_drift=float(drift))
    if not np.isfinite(drift):
        return shape
    small = abs(predicted) < DRIFT_FLOOR and abs(drift) < DRIFT_FLOOR
    ratio = predicted / drift if drift != 0 else np.inf
    if small or 1.0 / DRIFT_AGREEMENT <= ratio <= DRIFT_AGREEMENT:
        return shape
    return replace(shape, reliable=False, unreliable=(
        f"between the start and the end of the decay it gives a frequency change of {100 * predicted:+.2f} %, where the "
        f"spectrum of the record gives {100 * drift:+.2f} %"))
