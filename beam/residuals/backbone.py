"""Amplitude-resolved modal identification of a free decay: per mode, its amplitude A(t), its
frequency against amplitude (the backbone ω(A)) and its damping ratio against amplitude (the
damping curve ζ(A)), each with its standard error.

A free decay of a strip is a few modes whose amplitude and phase evolve slowly,
dA/dt = −ζ(A) ω(A) A, dφ/dt = ω(A); every amplitude-dependent effect of the catalogue leaves its
own signature on these two curves (a viscous damping a constant ζ, the air drag a ζ growing
∝ A, a slipping clamp a frequency that rises as the swing dies, a cubic spring ω ∝ A²).

Method: sliding-block damped-sinusoid fits
------------------------------------------
The record (at its own stamps: irregular phone stamps are never interpolated) is cut, for each
spectral line found, into overlapping blocks of :attr:`BackboneSettings.cycles_per_block` cycles
of that line (fewer when its amplitude would fall by more than a factor e^0.7 inside one). In each
block b one weighted linear least squares fits

    y(t) = Σ_j Re[(Z_j + U_j u) e^{s_j τ}] + c_0 + c_1 u + c_2 u²,   τ = t − t_b,  u = τ / h_b,

over every line j at once (h_b the half-length of the block, s_j = −σ_j + iω_j): the line
followed and the others (its neighbours, mains hum, other modes) each with four columns
(e^{−σ_j τ} cos ω_j τ, −e^{−σ_j τ} sin ω_j τ and the same times u), the offset and a quadratic
drift with three. U_j is Z_j times the first-order correction of s_j (the derivative of e^{sτ}
with respect to s is τ e^{sτ}), so that the followed line's s is updated by
ε = U / (Z h_b): a Gauss–Newton step in variable-projection form, whose every iteration is one
batched linear solve over all blocks (no per-block Python loop, no scipy.optimize call). The
four columns of the other lines absorb their own first-order frequency and decay errors. Four
iterations from the spectral peak converge to 1e-6 of the frequency; each line is then refitted
once with the other lines' (σ_j, ω_j) read at the block's time from their own first fits.

Per block: the amplitude A = |Z| (the mode's amplitude at the sensor at the block's centre, in
the record's unit), the natural frequency |s| / 2π and the damping ratio σ / |s| (the
conventions of :func:`beam.residuals.identify_modes`). Their standard errors are those of the
linear least squares with the residual's variance (Gauss–Newton covariance, the delta method
through ε = U / Z), times the variance ratio of the residual's AR(1) spectrum at the line's
frequency to white noise (residuals of neighbouring samples are correlated when the noise is
coloured or the block model misses something). The linear-decay test checks that the block
estimates scatter within these errors.

Robustness: samples marked clipped (given, or :func:`beam.io.measurement.clipped_samples`) and
spikes (a centred 4th divided difference more than :attr:`BackboneSettings.spike_sd` robust sd
away, on records sampled finely enough for it; in every block, residuals more than that many
robust sd) are left out of every fit; the offset and the drift are fitted in each block; a
record sampled far above its highest line is first averaged over bins of q consecutive samples
(at least :attr:`BackboneSettings.samples_per_period` bins per period of the highest line; the
amplitudes are corrected for the bins' Dirichlet gain), which keeps the cost linear in the
samples and small. A jump of the envelope (a tap, a second pluck) starts a new segment: blocks
never straddle one, and each block carries its segment's number (the taps of one record give
one backbone at several amplitudes).

What is not a mode: a line at a mains harmonic (k × 50 or k × 60 Hz, within
:attr:`BackboneSettings.mains_tolerance`) whose amplitude does not decay while the beam's does
(``"hum"``); a line at an integer multiple of a stronger line that decays faster than it (a
harmonic of a nonlinear response, ``"harmonic"``). Both stay in every block's fit (so they do
not leak into the modes) and are reported apart in :attr:`FreeDecayBackbone.lines`. A mode is
*resolved* when at least :attr:`BackboneSettings.min_blocks` of its blocks are at least
:attr:`BackboneSettings.min_block_snr_db` above the noise (matched-filter SNR of the block); a
mode asked for (``frequencies_Hz``) that the record does not show — a sensor at its node, a
mode above the Nyquist frequency — is returned unresolved with the reason, never invented.

Why this method (measured, ``docs/decisions.md``): on phone records (100–500 Hz, jittered
stamps, a few samples per period of mode 2) a band-pass + Hilbert envelope needs uniform
samples (interpolation across jitter and clipped runs) and a band narrow enough to exclude the
neighbours, whose edge transients span several periods of short blocks; a fit at the stamps
needs neither. Hand-written numerics (the batched normal equations) because scipy's least
squares solves one problem per call: the ~40 blocks × ~5 lines × 5 iterations of a record would
be ~1000 calls, where one batched solve per iteration costs a few ms.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.ndimage
import scipy.signal

from beam.errors import BeamInputError
from beam.io.anchor import refine_peak, uniform_grid
from beam.io.measurement import clipped_samples
from beam.residuals.common import jsonable
from beam.residuals.modal_id import compare_modes
from beam.residuals.noise import difference_noise_sd

__all__ = [
    "BackboneSettings",
    "CurveLaw",
    "FreeDecayBackbone",
    "ModeBackbone",
    "SpectralLine",
    "identify_backbone",
    "record_backbone",
]

#: Orders of the time derivative of the displacement each output kind is (strain: 0).
OUTPUT_ORDERS = {"displacement": 0, "velocity": 1, "acceleration": 2, "strain": 0}


@dataclass(frozen=True)
class BackboneSettings:
    """How :func:`identify_backbone` cuts and fits a free decay (one settings object in).

    Attributes
    ----------
    cycles_per_block : float
        Cycles of a line per block (8: its frequency to ~1e-4 at 20 dB, its amplitude changing
        little inside a block of a lightly damped strip).
    min_cycles_per_block : float
        Fewest cycles per block when a fast decay shortens it.
    max_decay_per_block : float
        Largest σ T of a block (its amplitude falls at most by e^{σT} inside it).
    overlap : float
        Overlap of consecutive blocks (fraction of a block).
    max_blocks : int
        Most blocks per line and segment (the hop grows on a long decay).
    max_lines : int
        Most spectral lines followed (modes, hum and harmonics).
    min_prominence_db : float
        Least prominence of a spectral peak to be followed (dB).
    min_block_snr_db : float
        A block resolves its line when the line's energy in it is at least this far above the
        noise variance (matched-filter SNR, dB; 20 dB as :data:`beam.residuals.modal_id.MIN_MODE_SNR`).
    min_blocks : int
        Fewest resolved blocks of a resolved mode.
    spike_sd : float
        Samples this many robust sd from the block's fit (or from the local cubic) are spikes.
    drift_order : int
        Degree of the polynomial offset + drift fitted in each block.
    iterations : int
        Gauss–Newton iterations per line and sweep.
    samples_per_period : float
        Records sampled finer than this many samples per period of their highest line are
        averaged over bins down to it.
    mains_Hz : tuple of float
        Mains frequencies whose harmonics are hum candidates.
    mains_tolerance : float
        Relative distance of a hum line to k × mains.
    persistent_fall : float
        A line whose amplitude falls by less than this share over its resolved blocks, while
        the strongest mode falls by more than twice as much, does not decay (hum).
    harmonic_tolerance : float
        Relative distance of a harmonic to n × its fundamental.
    hint_tolerance : float
        Largest |log(f_line / f_asked)| of a line matched to an asked mode.
    """

    cycles_per_block: float = 8.0
    min_cycles_per_block: float = 3.0
    max_decay_per_block: float = 0.7
    overlap: float = 0.5
    max_blocks: int = 40
    max_lines: int = 8
    min_prominence_db: float = 10.0
    min_block_snr_db: float = 20.0
    min_blocks: int = 3
    spike_sd: float = 6.0
    drift_order: int = 2
    iterations: int = 4
    samples_per_period: float = 16.0
    mains_Hz: tuple[float, ...] = (50.0, 60.0)
    mains_tolerance: float = 5e-3
    persistent_fall: float = 0.1
    harmonic_tolerance: float = 2e-3
    hint_tolerance: float = 0.3


@dataclass(frozen=True)
class CurveLaw:
    """A weighted least-squares law through a curve: value = Σ_p c_p A^p.

    Attributes
    ----------
    powers : tuple of float
        The powers p of the amplitude.
    coefficients : ndarray (k,)
        c_p (the curve's unit over the amplitude's unit to the power p).
    covariance : ndarray (k, k)
        Their covariance from the blocks' standard errors (scaled by the reduced χ² when it is
        above 1: the law then misses something and its errors widen).
    chi2 : float
        Σ ((value − law) / sd)² over the blocks.
    dof : int
        Blocks less coefficients.
    """

    powers: tuple[float, ...]
    coefficients: np.ndarray
    covariance: np.ndarray
    chi2: float
    dof: int

    @property
    def stderr(self) -> np.ndarray:
        """Standard errors of the coefficients."""
        return np.sqrt(np.maximum(np.diag(self.covariance), 0.0))

    def __call__(self, amplitude: np.ndarray | float) -> np.ndarray:
        a = np.asarray(amplitude, dtype=float)
        return sum(c * a**p for c, p in zip(self.coefficients, self.powers))

    def to_dict(self) -> dict[str, Any]:
        return jsonable({"powers": self.powers, "coefficients": self.coefficients, "stderr": self.stderr,
                         "chi2": self.chi2, "dof": self.dof})


@dataclass(frozen=True, eq=False)
class ModeBackbone:
    """One mode's amplitude, backbone and damping curve, block by block.

    Attributes
    ----------
    number : int
        The mode's number: that of the asked frequency it matched (``frequencies_Hz``), else its
        rank by frequency among the record's modes (1-based).
    peak_frequency_Hz : float
        The spectral peak followed (Hz); the asked frequency when none matched.
    resolved : bool
        At least :attr:`BackboneSettings.min_blocks` blocks resolve the mode.
    note : str
        Why it is not resolved ("" when it is).
    time_s : ndarray (b,)
        Block centres (s), resolved blocks only, in time order.
    amplitude, amplitude_sd : ndarray (b,)
        The mode's amplitude at the sensor at the block's centre and its standard error (the
        record's unit: m, m/s, m/s² or strain).
    frequency_Hz, frequency_sd_Hz : ndarray (b,)
        Natural frequency |s| / 2π and its standard error (Hz).
    damping_ratio, damping_ratio_sd : ndarray (b,)
        σ / |s| and its standard error.
    snr_db : ndarray (b,)
        Matched-filter SNR of the block (dB).
    segment : ndarray (b,) of int
        The segment (decay after a release or tap, :attr:`FreeDecayBackbone.segments_s`) of
        each block.
    output_order : int
        0 for a displacement or strain, 1 velocity, 2 acceleration: the amplitude of the
        displacement is amplitude / (2π f)^order.
    """

    number: int
    peak_frequency_Hz: float
    resolved: bool
    note: str
    time_s: np.ndarray = field(repr=False)
    amplitude: np.ndarray = field(repr=False)
    amplitude_sd: np.ndarray = field(repr=False)
    frequency_Hz: np.ndarray = field(repr=False)
    frequency_sd_Hz: np.ndarray = field(repr=False)
    damping_ratio: np.ndarray = field(repr=False)
    damping_ratio_sd: np.ndarray = field(repr=False)
    snr_db: np.ndarray = field(repr=False)
    segment: np.ndarray = field(repr=False)
    output_order: int = 0

    @property
    def displacement_amplitude(self) -> np.ndarray:
        """The amplitude as a displacement at the sensor (m): amplitude / ω^order (a strain stays a strain)."""
        return self.amplitude / (2 * np.pi * self.frequency_Hz) ** self.output_order

    def law(self, quantity: str = "damping_ratio", powers: Sequence[float] = (0, 1), *,
            displacement: bool = False) -> CurveLaw:
        """Weighted least squares of ``quantity`` (``"damping_ratio"`` or ``"frequency_Hz"``)
        against the amplitude to the ``powers`` (the displacement amplitude with
        ``displacement``), weights 1 / sd². E.g. (0, 1) for the drag's ζ = ζ0 + c A, (0, 2)
        for a cubic spring's f = f0 + c A².

        Raises
        ------
        BeamInputError
            An unresolved mode, or fewer blocks than coefficients.
        """
        if quantity not in ("damping_ratio", "frequency_Hz"):
            raise BeamInputError(f"quantity must be 'damping_ratio' or 'frequency_Hz', got {quantity!r}")
        powers = tuple(float(p) for p in powers)
        if not self.resolved or self.time_s.size <= len(powers):
            raise BeamInputError(f"mode {self.number} has too few resolved blocks for a law of {len(powers)} terms")
        value = getattr(self, quantity)
        sd = getattr(self, "damping_ratio_sd" if quantity == "damping_ratio" else "frequency_sd_Hz")
        a = self.displacement_amplitude if displacement else self.amplitude
        design = np.stack([a**p for p in powers], axis=1) / sd[:, None]
        target = value / sd
        coefficients, *_ = np.linalg.lstsq(design, target, rcond=None)
        chi2 = float(np.sum((target - design @ coefficients) ** 2))
        dof = int(value.size - len(powers))
        covariance = np.linalg.pinv(design.T @ design) * max(chi2 / dof, 1.0)
        return CurveLaw(powers, coefficients, covariance, chi2, dof)

    def to_dict(self, arrays: bool = True) -> dict[str, Any]:
        return jsonable(self, arrays)


@dataclass(frozen=True)
class SpectralLine:
    """A spectral line of the record that is not a mode of the beam.

    Attributes
    ----------
    frequency_Hz : float
        Its frequency over the blocks (Hz).
    kind : str
        ``"hum"`` (a mains harmonic of constant amplitude), ``"harmonic"`` (n × a stronger
        line, decaying faster than it) or ``"unmatched"`` (a decaying line none of the asked
        modes matched).
    amplitude : float
        Its median amplitude over its blocks (the record's unit).
    note : str
        What it is, in words.
    """

    frequency_Hz: float
    kind: str
    amplitude: float
    note: str


@dataclass(frozen=True, eq=False)
class FreeDecayBackbone:
    """The amplitude-resolved identification of one free decay.

    Attributes
    ----------
    modes : tuple of ModeBackbone
        The modes, by number (asked ones first when ``frequencies_Hz`` was given).
    lines : tuple of SpectralLine
        Lines followed that are not modes (hum, harmonics, unmatched).
    output_kind : str
        What the record measures.
    segments_s : tuple of (float, float)
        The decays found (start, stop) in s: one for a single release, one more per tap.
    clipped_count, spike_count : int
        Samples left out as clipped and as spikes.
    sample_rate_Hz : float
        1 / median step of the record.
    fit_rate_Hz : float
        The rate the blocks were fitted at (the record's, or its bins').
    noise_sd : float
        Median residual sd of the blocks of the strongest mode (the record's unit).
    """

    modes: tuple[ModeBackbone, ...]
    lines: tuple[SpectralLine, ...]
    output_kind: str
    segments_s: tuple[tuple[float, float], ...]
    clipped_count: int
    spike_count: int
    sample_rate_Hz: float
    fit_rate_Hz: float
    noise_sd: float

    def mode(self, number: int) -> ModeBackbone:
        """The mode of that number (BeamInputError when there is none)."""
        for m in self.modes:
            if m.number == number:
                return m
        raise BeamInputError(f"no mode {number} in the identification (modes {[m.number for m in self.modes]})")

    @property
    def resolved(self) -> tuple[ModeBackbone, ...]:
        """The resolved modes."""
        return tuple(m for m in self.modes if m.resolved)

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        out = jsonable(self, arrays=False)
        out["modes"] = [m.to_dict(arrays) for m in self.modes]
        return out


# ---------------------------------------------------------------------------------------------
# preparation


@dataclass
class _Record:
    """The samples the blocks are fitted to (after spikes, clipping and binning)."""

    t: np.ndarray
    y: np.ndarray
    valid: np.ndarray
    bin_samples: int
    bin_step_s: float


#: Samples over which the local scale of the 4th differences is taken (:func:`_spikes`).
SPIKE_WINDOW = 65


def _spikes(t: np.ndarray, y: np.ndarray, valid: np.ndarray, threshold: float) -> np.ndarray:
    """Spikes: samples whose centred 4th divided difference (weights annihilating any cubic
    through five consecutive valid samples, unit norm) is a local maximum more than
    ``threshold`` times the local robust scale of the differences (1.4826 × their running
    median absolute value over :data:`SPIKE_WINDOW` samples) and than their global one. A
    sampled sinusoid's differences peak at about their own scale, so the signal, however
    coarsely sampled, is never taken for a spike; a spike of size S moves its centred
    difference by 0.72 S."""
    index = np.flatnonzero(valid)
    found = np.zeros(t.size, dtype=bool)
    if index.size < SPIKE_WINDOW:
        return found
    tv, yv = t[index], y[index]
    scale = float(np.median(np.diff(tv)))
    windows = np.lib.stride_tricks.sliding_window_view(tv / scale, 5)
    weights = np.ones_like(windows)
    for i in range(5):
        for j in range(5):
            if i != j:
                weights[:, i] /= windows[:, i] - windows[:, j]
    weights /= np.linalg.norm(weights, axis=1, keepdims=True)
    d = np.abs(np.einsum("ij,ij->i", weights, np.lib.stride_tricks.sliding_window_view(yv, 5)))
    local = 1.4826 * scipy.ndimage.median_filter(d, SPIKE_WINDOW, mode="nearest")
    sd = np.maximum(local, 1.4826 * float(np.median(d)))
    if not np.all(sd > 0):
        return found
    peak = (d > threshold * sd) & (d >= np.concatenate([[0.0], d[:-1]])) & (d >= np.concatenate([d[1:], [0.0]]))
    found[index[np.flatnonzero(peak) + 2]] = True
    return found


def _binned(t: np.ndarray, y: np.ndarray, valid: np.ndarray, q: int) -> _Record:
    """Means of the valid samples over bins of ``q`` consecutive samples, at their mean stamps;
    bins less than three quarters valid are left out."""
    n = (t.size // q) * q
    w = valid[:n].reshape(-1, q).astype(float)
    count = w.sum(axis=1)
    keep = count >= 0.75 * q
    safe = np.where(count > 0, count, 1.0)
    tb = (t[:n].reshape(-1, q) * w).sum(axis=1) / safe
    yb = (y[:n].reshape(-1, q) * w).sum(axis=1) / safe
    step = float(np.median(np.diff(t)))
    return _Record(tb[keep], yb[keep], np.ones(int(keep.sum()), dtype=bool), q, step)


def _dirichlet(frequency_Hz: float, q: int, step_s: float) -> float:
    """Gain of the mean of q samples spaced ``step_s`` at ``frequency_Hz``."""
    if q <= 1:
        return 1.0
    x = math.pi * frequency_Hz * step_s
    return abs(math.sin(q * x) / (q * math.sin(x))) if math.sin(x) != 0 else 1.0


#: Bands per decade of the spectrum's noise floor (:func:`_spectral_lines`): ±12 % around a line ...
FLOOR_BANDS_PER_DECADE = 10
#: ... and the percentile of the log-PSD in each band taken as the floor (a line's own skirt over
#: less than three quarters of its band does not raise it).
FLOOR_PERCENTILE = 25
#: Least prominence of a peak over its neighbouring dips (dB): a wiggle of the noise on the skirt
#: of a strong line stands high above the floor but not above the skirt.
MIN_PEAK_PROMINENCE_DB = 6.0
#: Half-width of the Blackman–Harris window's main lobe in resolution bins (fs / segment): a
#: peak closer than this to a higher one is that one's lobe.
MAIN_LOBE_BINS = 5.0
#: Welch segments are zero-padded to this many times their length.
ZERO_PADDING = 4


def _spectral_lines(t: np.ndarray, y: np.ndarray, settings: BackboneSettings) -> list[tuple[float, float]]:
    """(frequency (Hz), height over the floor (dB)) of the highest peaks of the record's Welch
    spectrum, highest first.

    The valid samples are put on a uniform grid at their median step
    (:func:`beam.io.anchor.uniform_grid`), a cubic trend removed, and their Welch PSD taken with
    a 4-term Blackman–Harris window (sidelobes −92 dB, so that a line 60 dB above the noise
    puts no false peak beside it; segments the largest power of two ≤ n / 2, 50 % overlap,
    zero-padded :data:`ZERO_PADDING` ×). A peak counts when it stands
    :attr:`BackboneSettings.min_prominence_db` above the spectrum's floor — the
    :data:`FLOOR_PERCENTILE` th percentile of the log-PSD in bands of
    1/:data:`FLOOR_BANDS_PER_DECADE` decade, interpolated in log frequency (a Welch spectrum of a
    few segments has dips 20 dB deep in white noise: prominences alone pick noise) — and
    :data:`MIN_PEAK_PROMINENCE_DB` above its own dips, outside the main lobe of a higher peak;
    between 8 cycles of the record and 0.9 × Nyquist.
    """
    detrended = y - np.polyval(np.polyfit(t - t[0], y, 3), t - t[0])
    if detrended.size < 256:
        return []
    grid, step = uniform_grid(t, detrended)
    nperseg = int(2 ** int(np.floor(np.log2(max(grid.size / 2, 16)))))
    frequency, density = scipy.signal.welch(grid, fs=1.0 / step, window="blackmanharris", nperseg=nperseg,
                                            noverlap=nperseg // 2, nfft=ZERO_PADDING * nperseg, detrend="constant")
    resolution = 1.0 / (nperseg * step)
    low = max(8.0 / (grid.size * step), MAIN_LOBE_BINS * resolution)
    high = 0.45 / step
    log_psd = 10 * np.log10(np.maximum(density, max(float(density.max()), 1e-300) * 1e-30))
    positive = frequency > 0
    decades = np.log10(frequency[positive])
    band = np.floor(decades * FLOOR_BANDS_PER_DECADE).astype(int)
    labels, start = np.unique(band, return_index=True)
    floors = np.array([np.percentile(part, FLOOR_PERCENTILE) for part in np.split(log_psd[positive], start[1:])])
    centres = (labels + 0.5) / FLOOR_BANDS_PER_DECADE
    floor = np.full(frequency.size, floors[0])
    floor[positive] = np.interp(decades, centres, floors)
    peaks, _ = scipy.signal.find_peaks(log_psd, prominence=MIN_PEAK_PROMINENCE_DB)
    height = log_psd[peaks] - floor[peaks]
    keep = (frequency[peaks] >= low) & (frequency[peaks] <= high) & (height >= settings.min_prominence_db)
    peaks, height = peaks[keep], height[keep]
    accepted: list[tuple[float, float]] = []
    for i in np.argsort(height)[::-1]:
        f = refine_peak(frequency, log_psd, int(peaks[i]))
        if all(abs(f - g) > MAIN_LOBE_BINS * resolution for g, _ in accepted):
            accepted.append((f, float(height[i])))
        if len(accepted) == settings.max_lines:
            break
    return accepted


def _segments(t: np.ndarray, y: np.ndarray, valid: np.ndarray, period_s: float, start: int) -> list[tuple[int, int]]:
    """Index ranges of the decays: one from the release, one more from each jump of the envelope
    (its maximum over two periods of the lowest line more than twice the smaller of the two
    windows before it, and above a tenth of the record's largest)."""
    tv, yv = t[start:], y[start:] - np.median(y[start:][valid[start:]])
    window = 2.0 * period_s
    edges = np.arange(tv[0], tv[-1] + window, window)
    which = np.clip(np.searchsorted(edges, tv, side="right") - 1, 0, edges.size - 1)
    envelope = np.zeros(edges.size)
    np.maximum.at(envelope, which[valid[start:]], np.abs(yv[valid[start:]]))
    largest = float(envelope.max())
    if not largest > 0:
        return [(start, t.size)]
    starts = []
    if envelope[0] >= 0.1 * largest:
        starts.append(start)
    for m in range(1, envelope.size):
        before = envelope[max(m - 2, 0): m].min()
        if envelope[m] > 0.1 * largest and envelope[m] > 2.0 * before:
            if starts and tv[np.searchsorted(tv, edges[m])] - t[starts[-1]] < 2 * window:
                continue
            # the decay starts at the largest excursion of this window and the next
            lo, hi = np.searchsorted(tv, edges[m]), np.searchsorted(tv, edges[m] + 2 * window)
            inside = np.flatnonzero(valid[start + lo: start + hi])
            k = lo + (int(inside[np.argmax(np.abs(yv[lo:hi][inside]))]) if inside.size else 0)
            starts.append(start + k)
    if not starts:
        k = int(np.flatnonzero(valid[start:])[np.argmax(np.abs(yv[valid[start:]]))])
        starts = [start + k]
    bounds = starts + [t.size]
    return [(bounds[i], bounds[i + 1]) for i in range(len(starts))]


# ---------------------------------------------------------------------------------------------
# the block fits


@dataclass
class _Fit:
    """Per block results of one line (all blocks, resolved or not)."""

    centre: np.ndarray
    half: np.ndarray
    segment: np.ndarray
    s: np.ndarray  # complex s = -sigma + i omega (1/s)
    z: np.ndarray  # complex amplitude at the centre
    amplitude_sd: np.ndarray
    omega_sd: np.ndarray
    sigma_sd: np.ndarray
    snr_db: np.ndarray
    residual_sd: np.ndarray
    resolved: np.ndarray


def _place_blocks(t: np.ndarray, segments: list[tuple[int, int]], length_s: float,
                  settings: BackboneSettings) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres (s), half-lengths (s) and segment numbers of the blocks of one line."""
    centres, halves, owner = [], [], []
    for number, (a, b) in enumerate(segments):
        t0, t1 = t[a], t[b - 1]
        span = t1 - t0
        if span < length_s:
            continue
        hop = max(length_s * (1.0 - settings.overlap), (span - length_s) / max(settings.max_blocks - 1, 1))
        count = int(math.floor((span - length_s) / hop)) + 1
        c = t0 + 0.5 * length_s + hop * np.arange(count)
        centres.append(c)
        halves.append(np.full(count, 0.5 * length_s))
        owner.append(np.full(count, number))
    if not centres:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=int)
    return np.concatenate(centres), np.concatenate(halves), np.concatenate(owner)


def _gather(record: _Record, centres: np.ndarray, halves: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(tau (B, n), y (B, n), weight (B, n)) of the samples of each block, padded with weight 0."""
    lo = np.searchsorted(record.t, centres - halves, side="left")
    hi = np.searchsorted(record.t, centres + halves, side="right")
    width = int(max((hi - lo).max(), 1))
    index = lo[:, None] + np.arange(width)[None, :]
    inside = index < hi[:, None]
    index = np.minimum(index, record.t.size - 1)
    tau = record.t[index] - centres[:, None]
    weight = (inside & record.valid[index]).astype(float)
    return np.where(inside, tau, 0.0), record.y[index] * weight, weight


def _line_columns(tau: np.ndarray, u: np.ndarray, s: np.ndarray, powers: int = 2) -> np.ndarray:
    """(B, n, 2 powers): e^{−σ τ} cos ω τ, −e^{−σ τ} sin ω τ, and both times u, u², ...
    (``powers`` pairs), for s (B,) per block."""
    phase = s[:, None] * tau  # complex (B, n)
    e = np.exp(np.clip(phase.real, -50.0, 50.0))
    c, sn = e * np.cos(phase.imag), -e * np.sin(phase.imag)
    pairs = [c, sn]
    for _ in range(powers - 1):
        pairs += [pairs[-2] * u, pairs[-1] * u]
    return np.stack(pairs, axis=2)


#: Column pairs of the followed line in its blocks: (Z + U u + W u²) e^{sτ}. The quadratic term
#: takes the curvature of the envelope inside a block (a damping that changes with the
#: amplitude), so that Z and U are the envelope and its slope at the centre: on the drag's
#: 50 cm strip decay (C_d = 15) the first block's ζ was 3.5 % low without it.
TARGET_POWERS = 3


def _solve(columns: np.ndarray, y: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least squares of every block at once: coefficients (B, p) and (X^T W X)^-1 (B, p, p)."""
    xw = columns * weight[:, :, None]
    gram = np.matmul(np.swapaxes(xw, 1, 2), columns)
    rhs = np.einsum("bnp,bn->bp", xw, y)
    scale = np.sqrt(np.maximum(np.einsum("bpp->bp", gram), 1e-300))
    normal = gram / (scale[:, :, None] * scale[:, None, :]) + 1e-12 * np.eye(gram.shape[1])[None]
    inverse = np.linalg.inv(normal) / (scale[:, :, None] * scale[:, None, :])
    return np.einsum("bpq,bq->bp", inverse, rhs), inverse


def _fit_line(record: _Record, centres: np.ndarray, halves: np.ndarray, owner: np.ndarray, s0: complex,
              others: list[tuple[np.ndarray, np.ndarray]], settings: BackboneSettings) -> _Fit:
    """The blocks of one line: Gauss–Newton on its s in each block, the other lines (their s at
    each block, ``others``: (block times, s) to interpolate) and the drift as linear columns."""
    tau, y, weight = _gather(record, centres, halves)
    u = tau / halves[:, None]
    drift = np.stack([u**k for k in range(settings.drift_order + 1)], axis=2)
    nuisance = [drift]
    for times, s_other in others:
        s_at = (np.interp(centres, times, s_other.real) + 1j * np.interp(centres, times, s_other.imag)
                if times.size else np.full(centres.size, s_other))
        nuisance.append(_line_columns(tau, u, s_at))
    fixed = np.concatenate(nuisance, axis=2)
    s = np.full(centres.size, complex(s0))
    omega_limit = 0.05 * abs(s0.imag)
    for iteration in range(settings.iterations + 1):
        columns = np.concatenate([_line_columns(tau, u, s, TARGET_POWERS), fixed], axis=2)
        coefficients, inverse = _solve(columns, y, weight)
        residual = (y - np.einsum("bnp,bp->bn", columns, coefficients)) * weight
        if iteration == 1:  # spikes: residuals beyond spike_sd robust sd leave the block
            absolute = np.where(weight > 0, np.abs(residual), np.nan)
            robust = 1.4826 * np.nanmedian(absolute, axis=1)
            outlier = absolute > settings.spike_sd * robust[:, None]
            weight = np.where(outlier, 0.0, weight)
            y = y * (weight > 0)
        z = coefficients[:, 0] + 1j * coefficients[:, 1]
        v = coefficients[:, 2] + 1j * coefficients[:, 3]
        if iteration == settings.iterations:
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(np.abs(z) > 0, v / (z * halves), 0.0)
        step = np.clip(step.real, -omega_limit, omega_limit) + 1j * np.clip(step.imag, -omega_limit, omega_limit)
        s = s + np.nan_to_num(step)
    # final: covariance of (Z, U) scaled by the residual variance and its AR(1) colour at the line
    count = weight.sum(axis=1)
    p = columns.shape[2]
    variance = (residual**2).sum(axis=1) / np.maximum(count - p, 1.0)
    lagged = (residual[:, 1:] * residual[:, :-1]).sum(axis=1)
    rho = np.clip(lagged / np.maximum((residual**2).sum(axis=1), 1e-300), -0.95, 0.95)
    dt = np.maximum(np.nanmedian(np.where(weight[:, 1:] > 0, np.diff(tau, axis=1), np.nan), axis=1), 1e-300)
    colour = (1 - rho**2) / (1 - 2 * rho * np.cos(s.imag * dt) + rho**2)
    variance = variance * np.maximum(colour, 1.0)
    cov = inverse[:, :4, :4] * variance[:, None, None]
    magnitude = np.abs(z)
    unit = np.where(magnitude[:, None] > 0, np.stack([z.real, z.imag], axis=1) / np.maximum(magnitude, 1e-300)[:, None], 0)
    # amplitude sd along Z; the step's sd: U / (Z h) rotated by -arg Z
    amplitude_sd = np.sqrt(np.maximum(np.einsum("bi,bij,bj->b", unit, cov[:, :2, :2], unit), 0.0))
    rotation = np.stack([np.stack([unit[:, 0], unit[:, 1]], 1), np.stack([-unit[:, 1], unit[:, 0]], 1)], 1)
    step_cov = np.einsum("bij,bjk,blk->bil", rotation, cov[:, 2:, 2:], rotation) / (
        np.maximum(magnitude, 1e-300) * halves)[:, None, None] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = 10 * np.log10(magnitude**2 * count / (2 * np.maximum(variance, 1e-300)))
    sigma_sd, omega_sd = np.sqrt(np.maximum(step_cov[:, 0, 0], 0)), np.sqrt(np.maximum(step_cov[:, 1, 1], 0))
    resolved = (snr >= settings.min_block_snr_db) & np.isfinite(snr) & (omega_sd < 0.02 * np.abs(s.imag)) & (
        count > p + 4)
    return _Fit(centres, halves, owner, s, z, amplitude_sd, omega_sd, sigma_sd, snr, np.sqrt(variance), resolved)


#: Cycles of the difference frequency a block spans at least, so that two lines are told apart in it.
SEPARATION_CYCLES = 2.0


#: Fewest samples per fitted column in a block.
SAMPLES_PER_COLUMN = 3.0


def _block_length(frequency_Hz: float, sigma: float, separation_Hz: float, shortest_s: float,
                  settings: BackboneSettings) -> float:
    """The block length (s) for a line: :attr:`BackboneSettings.cycles_per_block` periods, or
    :data:`SEPARATION_CYCLES` periods of its distance to the nearest other line, or
    ``shortest_s`` (:data:`SAMPLES_PER_COLUMN` samples per column) if longer; shortened to
    max_decay_per_block / sigma, and at least min_cycles_per_block periods and ``shortest_s``."""
    length = max(settings.cycles_per_block / frequency_Hz, shortest_s)
    if separation_Hz > 0:
        length = max(length, SEPARATION_CYCLES / separation_Hz)
    if sigma > 0:
        length = min(length, settings.max_decay_per_block / sigma)
    return max(length, settings.min_cycles_per_block / frequency_Hz, shortest_s)


def _summary_s(fit: _Fit) -> complex:
    """The median s over a line's resolved blocks."""
    ok = fit.s[fit.resolved]
    return complex(np.median(ok.real), np.median(ok.imag))


def _follow(record: _Record, segments: list[tuple[int, int]], lines: list[float], heights: list[float],
            settings: BackboneSettings) -> list[_Fit | None]:
    """Block fits of every line in two sweeps, the second with the other lines' s read from the
    first at each block; a line without a resolved block in the first sweep (noise) or that the
    blocks cannot tell from a stronger one (closer than one cycle of their difference per block)
    (the lower spectral peak, ``heights`` in dB) is dropped (None) and leaves the others' fits."""
    fits: list[_Fit | None] = [None] * len(lines)
    active = list(range(len(lines)))
    step = float(np.median(np.diff(record.t)))
    s_now = [complex(0.0, 2 * np.pi * f) for f in lines]
    for sweep in range(2):
        for k in list(active):
            others = []
            for j in active:
                if j == k:
                    continue
                previous = fits[j]
                if previous is not None and previous.resolved.any():
                    ok = previous.resolved
                    others.append((previous.centre[ok], previous.s[ok]))
                else:
                    others.append((np.zeros(0), np.array(s_now[j])))
            f = abs(s_now[k]) / (2 * np.pi)
            separation = min((abs(abs(s_now[j]) - abs(s_now[k])) / (2 * np.pi) for j in active if j != k), default=0.0)
            sigma = max(-s_now[k].real, 0.0)
            columns = 2 * TARGET_POWERS + settings.drift_order + 1 + 4 * (len(active) - 1)
            shortest = SAMPLES_PER_COLUMN * columns * step
            length = _block_length(f, sigma, separation, shortest, settings)
            centres, halves, owner = _place_blocks(record.t, segments, length, settings)
            if centres.size == 0:
                fits[k] = None
                continue
            fit = _fit_line(record, centres, halves, owner, s_now[k], others, settings)
            if sweep == 0 and fit.resolved.any():
                # a decay faster than the blocks allow: shorten them and fit again
                shorter = _block_length(f, max(-_summary_s(fit).real, 0.0), separation, shortest, settings)
                if shorter < 0.8 * length:
                    centres, halves, owner = _place_blocks(record.t, segments, shorter, settings)
                    if centres.size:
                        fit = _fit_line(record, centres, halves, owner, s_now[k], others, settings)
            fits[k] = fit
            if fit.resolved.any():
                s_now[k] = _summary_s(fit)
        if sweep == 0:
            active = [k for k in active if fits[k] is not None and fits[k].resolved.any()]
            for k in sorted(active, key=lambda k: heights[k]):
                length = 2 * float(np.median(fits[k].half))
                close = [j for j in active if j != k and abs(abs(s_now[j]) - abs(s_now[k])) / (2 * np.pi) * length < 1.0]
                if close:  # the lower spectral peak of two lines the blocks cannot tell apart
                    active.remove(k)
            fits = [fits[k] if k in active else None for k in range(len(lines))]
    return fits


# ---------------------------------------------------------------------------------------------
# classification and results


def _mains_harmonic(frequency_Hz: float, settings: BackboneSettings) -> float | None:
    """The mains frequency of which ``frequency_Hz`` is a harmonic (within the tolerance), or None."""
    for mains in settings.mains_Hz:
        k = round(frequency_Hz / mains)
        if k >= 1 and abs(frequency_Hz - k * mains) <= settings.mains_tolerance * k * mains:
            return mains
    return None


def _fall(fit: _Fit) -> float:
    """Share of its amplitude a line loses over its resolved blocks of its first segment, from a
    weighted straight line through their log-amplitudes (weights (A / sd_A)²)."""
    ok = fit.resolved & (fit.segment == fit.segment[fit.resolved][0])
    a, sd, t = np.abs(fit.z[ok]), fit.amplitude_sd[ok], fit.centre[ok]
    if a.size < 2 or not np.all(a > 0):
        return 0.0
    weight = (a / np.maximum(sd, 1e-300)) ** 2
    slope = np.polyfit(t - t[0], np.log(a), 1, w=np.sqrt(weight))[0]
    return float(1.0 - math.exp(min(slope * (t[-1] - t[0]), 50.0)))


def _clean_stretch(valid: np.ndarray, clipped: np.ndarray) -> slice:
    """The longest stretch without a clipped sample, when it holds at least a quarter of the
    valid samples (a spectrum there has no distortion from the clipped runs), else everything."""
    bad = np.flatnonzero(clipped)
    if bad.size == 0:
        return slice(0, valid.size)
    bounds = np.concatenate([[-1], bad, [valid.size]])
    longest = int(np.argmax(np.diff(bounds)))
    a, b = int(bounds[longest]) + 1, int(bounds[longest + 1])
    return slice(a, b) if np.count_nonzero(valid[a:b]) >= 0.25 * np.count_nonzero(valid) else slice(0, valid.size)


#: The note of a line followed in no block: its blocks resolved it nowhere, or it merged with a higher peak.
DROPPED = ("not resolved: its spectral peak is resolved in no block of the decay (noise, a decay shorter than a "
           "block, or a higher peak the blocks cannot tell it from)")


def _empty_mode(number: int, frequency_Hz: float, note: str, order: int) -> ModeBackbone:
    empty = np.zeros(0)
    return ModeBackbone(number, float(frequency_Hz), False, note, empty, empty, empty, empty, empty, empty, empty,
                        empty, np.zeros(0, dtype=int), order)


def _mode_of(fit: _Fit, number: int, peak_Hz: float, gain: float, order: int, settings: BackboneSettings) -> ModeBackbone:
    ok = fit.resolved
    if ok.sum() < settings.min_blocks:
        best = float(np.nanmax(fit.snr_db)) if fit.snr_db.size and np.isfinite(fit.snr_db).any() else float("nan")
        note = (f"not resolved: {int(ok.sum())} of its blocks are {settings.min_block_snr_db:g} dB above the noise "
                f"({settings.min_blocks} needed; the best is {best:.0f} dB)")
        return _empty_mode(number, peak_Hz, note, order)
    s = fit.s[ok]
    magnitude = np.abs(s)
    omega_sd, sigma_sd = fit.omega_sd[ok], fit.sigma_sd[ok]
    return ModeBackbone(
        number=number, peak_frequency_Hz=float(peak_Hz), resolved=True, note="", time_s=fit.centre[ok],
        amplitude=np.abs(fit.z[ok]) / gain, amplitude_sd=fit.amplitude_sd[ok] / gain,
        frequency_Hz=magnitude / (2 * np.pi), frequency_sd_Hz=np.hypot(omega_sd * s.imag, sigma_sd * s.real) / (
            magnitude * 2 * np.pi),
        damping_ratio=-s.real / magnitude, damping_ratio_sd=np.hypot(sigma_sd * s.imag**2, omega_sd * s.real * s.imag) / (
            magnitude**3),
        snr_db=fit.snr_db[ok], segment=fit.segment[ok], output_order=order,
    )


def identify_backbone(
    time_s: np.ndarray,
    signal: np.ndarray,
    *,
    output: str = "displacement",
    frequencies_Hz: Sequence[float] | None = None,
    clipped: np.ndarray | None = None,
    sensor_range: float | None = None,
    start_s: float | None = None,
    settings: BackboneSettings | None = None,
) -> FreeDecayBackbone:
    """Per mode of a free decay: amplitude, backbone ω(A) and damping curve ζ(A) with their errors.

    Parameters
    ----------
    time_s : array (n,)
        Strictly increasing stamps (s), irregular allowed.
    signal : array (n,)
        The sensor's samples (m, m/s, m/s² or strain); NaN samples are left out.
    output : {"displacement", "velocity", "acceleration", "strain"}
        What the sensor measures (sets :attr:`ModeBackbone.output_order`).
    frequencies_Hz : sequence of float, optional
        The modes to look for (e.g. a model's natural frequencies, Hz): each gets a
        :class:`ModeBackbone` numbered as its position (1-based), unresolved with the reason when
        the record does not show it. Default: every decaying line the record shows, numbered by
        frequency.
    clipped : bool array (n,), optional
        Samples to leave out (a saturated sensor); default those
        :func:`beam.io.measurement.clipped_samples` finds (with ``sensor_range``).
    sensor_range : float, optional
        The sensor's full scale (the record's unit), for the default clipping mask.
    start_s : float, optional
        Where the free decay starts (s); default the record's start (a decay that starts later,
        after a pluck from rest, is found as the envelope's first jump).
    settings : BackboneSettings, optional
        How blocks are cut and fitted (default :class:`BackboneSettings`).

    Returns
    -------
    FreeDecayBackbone

    Raises
    ------
    BeamInputError
        Stamps not finite and increasing, arrays of different lengths, fewer than 64 valid
        samples, an unknown output.
    """
    settings = BackboneSettings() if settings is None else settings
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(signal, dtype=float)
    if t.ndim != 1 or t.shape != y.shape:
        raise BeamInputError("time_s and signal must be 1-d arrays of one length")
    if output not in OUTPUT_ORDERS:
        raise BeamInputError(f"output must be one of {', '.join(OUTPUT_ORDERS)}, got {output!r}")
    if t.size < 64 or not np.all(np.isfinite(t)) or not np.all(np.diff(t) > 0):
        raise BeamInputError("time_s must hold at least 64 finite, strictly increasing stamps")
    order = OUTPUT_ORDERS[output]
    valid = np.isfinite(y)
    y = np.where(valid, y, 0.0)
    mask = clipped_samples(y, sensor_range) if clipped is None else np.asarray(clipped, dtype=bool)
    if mask.shape != t.shape:
        raise BeamInputError(f"clipped must have one flag per sample ({t.size}), got shape {mask.shape}")
    clipped_count = int(np.count_nonzero(mask & valid))
    valid &= ~mask
    first = 0 if start_s is None else int(np.searchsorted(t, float(start_s)))
    valid[:first] = False
    if np.count_nonzero(valid) < 64:
        raise BeamInputError(f"the free decay has {int(np.count_nonzero(valid))} valid samples; at least 64 needed")
    step = float(np.median(np.diff(t)))
    rate = 1.0 / step
    spikes = _spikes(t, y, valid, settings.spike_sd)
    valid &= ~spikes
    clean = _clean_stretch(valid, mask)
    found = _spectral_lines(t[clean][valid[clean]], y[clean][valid[clean]], settings)
    asked = None if frequencies_Hz is None else np.asarray(frequencies_Hz, dtype=float)
    if asked is not None and (asked.ndim != 1 or not np.all(np.isfinite(asked)) or np.any(asked <= 0)):
        raise BeamInputError("frequencies_Hz must be positive finite frequencies (Hz)")
    if not found:
        modes = tuple(_empty_mode(i + 1, f, "not resolved: the record shows no spectral peak", order)
                      for i, f in enumerate(asked if asked is not None else []))
        return FreeDecayBackbone(modes, (), output, (), clipped_count, 0, rate, rate, float("nan"))
    found = sorted(found)
    lines = [f for f, _ in found]
    heights = [h for _, h in found]
    q = int(rate / (settings.samples_per_period * max(lines)))
    segments = _segments(t, y, valid, 1.0 / min(lines), first)
    if q >= 2:
        record = _binned(t, y, valid, q)
        cut = [int(np.searchsorted(record.t, t[a])) for a, _ in segments] + [record.t.size]
        fit_segments = [(cut[i], cut[i + 1]) for i in range(len(segments))]
    else:
        record = _Record(t, y, valid.copy(), 1, step)
        fit_segments = segments
    fits = _follow(record, fit_segments, lines, heights, settings)
    segments_s = tuple((float(t[a]), float(t[b - 1])) for a, b in segments)

    # what each line is
    strength = [float(np.max(np.abs(f.z[f.resolved]))) if f is not None and f.resolved.any() else 0.0 for f in fits]
    strongest = int(np.argmax(strength))
    beam_fall = _fall(fits[strongest]) if strength[strongest] > 0 else 0.0
    kinds: list[str | None] = [None] * len(lines)
    notes: list[str] = [""] * len(lines)
    for k, (f, fit) in enumerate(zip(lines, fits)):
        if fit is None or not fit.resolved.any():
            continue
        frequency = float(np.median(np.abs(fit.s[fit.resolved]))) / (2 * np.pi)
        mains = _mains_harmonic(frequency, settings)
        if mains is not None and _fall(fit) < settings.persistent_fall and beam_fall > 2 * settings.persistent_fall:
            kinds[k] = "hum"
            notes[k] = (f"mains hum: {frequency:.2f} Hz = {round(frequency / mains)} x {mains:g} Hz, its amplitude "
                        f"constant while the beam's falls by {100 * beam_fall:.0f} %")
            continue
        for j, (g, other) in enumerate(zip(lines, fits)):
            if j == k or other is None or not other.resolved.any() or strength[j] <= strength[k]:
                continue
            n = round(f / g)
            sigma_k, sigma_j = (float(np.median(-x.s[x.resolved].real)) for x in (fit, other))
            if n >= 2 and abs(f - n * g) <= settings.harmonic_tolerance * n * g and sigma_k > 1.5 * max(sigma_j, 0.0):
                kinds[k] = "harmonic"
                notes[k] = f"harmonic {n} of the {g:.4g} Hz line (decays {sigma_k / max(sigma_j, 1e-300):.1f}x faster)"
                break
    gains = [_dirichlet(f, record.bin_samples, record.bin_step_s) for f in lines]
    candidates = [k for k in range(len(lines)) if kinds[k] is None]
    modes: list[ModeBackbone] = []
    matched: set[int] = set()
    if asked is not None:
        matches = compare_modes((np.array([lines[k] for k in candidates]), np.zeros(len(candidates))), asked,
                                np.zeros(asked.size), tolerance=settings.hint_tolerance) if candidates else []
        by_frequency = {lines[k]: k for k in candidates}
        for number, f_asked in enumerate(asked, start=1):
            match = next((m for m in matches if m.mode == number and m.matched), None)
            if f_asked >= 0.5 * rate:
                modes.append(_empty_mode(number, f_asked, f"not resolved: above the record's Nyquist frequency "
                                                          f"({0.5 * rate:.4g} Hz)", order))
            elif match is None:
                modes.append(_empty_mode(number, f_asked, f"not resolved: no spectral peak within "
                                                          f"{100 * (math.exp(settings.hint_tolerance) - 1):.0f} % of "
                                                          f"{f_asked:.4g} Hz rises {settings.min_prominence_db:g} dB "
                                                          "above the noise", order))
            else:
                k = by_frequency[match.frequency_data_Hz]
                matched.add(k)
                fit = fits[k]
                mode = (_mode_of(fit, number, lines[k], gains[k], order, settings) if fit is not None else
                        _empty_mode(number, lines[k], DROPPED, order))
                modes.append(mode)
    else:
        for number, k in enumerate(candidates, start=1):
            fit = fits[k]
            modes.append(_mode_of(fit, number, lines[k], gains[k], order, settings) if fit is not None else
                         _empty_mode(number, lines[k], DROPPED, order))
        matched = set(candidates)
    excluded = []
    for k, f in enumerate(lines):
        fit = fits[k]
        amplitude = float(np.median(np.abs(fit.z[fit.resolved]))) / gains[k] if fit is not None and fit.resolved.any() else 0.0
        if kinds[k] is not None:
            excluded.append(SpectralLine(float(f), kinds[k], amplitude, notes[k]))
        elif k not in matched and fit is not None and fit.resolved.sum() >= settings.min_blocks:
            excluded.append(SpectralLine(float(f), "unmatched", amplitude,
                                         "a decaying line that none of the asked modes matches"))
    noise = float(np.median(fits[strongest].residual_sd)) if fits[strongest] is not None else float("nan")
    return FreeDecayBackbone(
        modes=tuple(modes), lines=tuple(excluded), output_kind=output, segments_s=segments_s,
        clipped_count=clipped_count, spike_count=int(np.count_nonzero(spikes)), sample_rate_Hz=rate,
        fit_rate_Hz=rate / record.bin_samples, noise_sd=noise,
    )


def record_backbone(measurement, frequencies_Hz: Sequence[float] | None = None,
                    settings: BackboneSettings | None = None) -> FreeDecayBackbone:
    """:func:`identify_backbone` of a :class:`beam.io.measurement.Measurement`: its output kind,
    its clipping mask, and for a driven record the free decay after its input stops."""
    start = None
    if measurement.input is not None:
        on = np.flatnonzero(np.abs(measurement.input) > 0)
        if on.size:
            if on[-1] + 1 >= measurement.time_s.size:
                raise BeamInputError("no free decay: the input is on up to the last sample")
            start = float(measurement.time_s[on[-1] + 1])
    return identify_backbone(measurement.time_s, measurement.output, output=measurement.output_kind,
                             frequencies_Hz=frequencies_Hz, clipped=measurement.clipped, start_s=start,
                             settings=settings)
