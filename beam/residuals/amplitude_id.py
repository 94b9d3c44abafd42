"""Amplitude-resolved modal identification of a free decay: per mode, its amplitude A(t), its
frequency against amplitude (the backbone ω(A)) and its damping ratio against amplitude (the
damping curve ζ(A)), each with its standard error.

A free decay of a strip is a few modes whose amplitude and phase evolve slowly,
dA/dt = −ζ(A) ω(A) A, dφ/dt = ω(A); every amplitude-dependent effect of the catalogue leaves its
own signature on these two curves (a viscous damping a constant ζ, the air drag a ζ growing
∝ A, a slipping clamp a frequency that rises as the swing dies, a cubic spring ω ∝ A²).

Method: sliding-block damped-sinusoid fits
------------------------------------------
The spectral lines of the record are found first (:func:`_spectral_lines`: a Blackman–Harris
Welch spectrum and a one-sided periodogram of the release, peaks judged against the spectrum's
floor; searched again in what the first fits leave). Each line is then followed, highest
frequency first, in overlapping blocks of :attr:`BackboneSettings.cycles_per_block` of its
cycles (fewer when its amplitude would fall by more than e^0.7 inside one, more when a
neighbour must be told apart), at the record's own stamps (irregular phone stamps are never
interpolated for the fits). For a line, the lines above it are subtracted (their fits
reconstructed between blocks with a cubic Hermite phase), and the rest is averaged over bins of
q consecutive samples, at least :attr:`BackboneSettings.samples_per_period` per period of the
line (the amplitude corrected for the bins' Dirichlet gain): the cost stays linear in the
samples and small. In each block b one weighted linear least squares fits

    y(t) = Re[(Z + U u + W u²) e^{s τ}] + Σ_j Re[(Z_j + U_j u) e^{s_j τ}] + c_0 + c_1 u + c_2 u²,

τ = t − t_b, u = τ / h_b (h_b the half-length of the block), s = −σ + iω the followed line's,
s_j the lines below it (their s read at the block's time from their own fits; their four
columns absorb their first-order frequency and decay errors), an offset and a quadratic drift.
U is Z times the first-order correction of s (the derivative of e^{sτ} with respect to s is
τ e^{sτ}), so s is updated by ε = U / (Z h_b): a Gauss–Newton step in variable-projection form,
every iteration one batched solve over all blocks; W takes the curvature of the envelope inside
the block, so that Z and U are the envelope and its slope at the centre. Four iterations
from the spectral peak converge; the lines are followed twice (the second sweep with the
others' first fits).

Per block: the amplitude A = |Z| (the mode's amplitude at the sensor at the block's centre, in
the record's unit), the natural frequency |s| / 2π and the damping ratio σ / |s| (the
conventions of :func:`beam.residuals.identify_modes`); for a velocity or an acceleration the
damping is the displacement's, σ + order d ln ω / dt (the output's amplitude is ω^order times
the displacement's). Their standard errors are those of the linear least squares with the
residual's variance (the delta method through ε = U / Z), times the variance ratio of the
residual's AR(1) spectrum at the line's frequency to white noise. The linear-decay tests check
that the block estimates scatter within these errors.

Robustness: samples marked clipped (given, or :func:`beam.io.measurement.clipped_samples`) and
spikes (a centred 4th divided difference many times its local scale; in every block, residuals
more than :attr:`BackboneSettings.spike_sd` robust sd) are left out of every fit; the offset
and the drift are fitted in each block. A jump of the envelope (a tap, a second pluck) or a
peak of the blocks' residuals located by a linear predictor (a second pluck that does not raise
the swing) starts a new segment: blocks never straddle one, and each carries its segment's
number (the taps of one record give one backbone at several amplitudes).

What is not a mode: a line at a mains harmonic (k × 50 or k × 60 Hz, within
:attr:`BackboneSettings.mains_tolerance`) whose amplitude does not decay while the beam's does
(``"hum"``, fitted in blocks of a second); a decaying line on a harmonic of the hum the record
holds (``"mixed"``: a mode there cannot be told from the hum); a line at 2-5 times a stronger
line that follows its backbone and decays faster (a harmonic of a nonlinear response,
``"harmonic"``). They stay in the fits (so they do not leak into the modes) and are reported
apart in :attr:`FreeDecayBackbone.lines`. A block resolves its line when its amplitude is
:attr:`BackboneSettings.min_block_snr_db` above its standard error; a mode is *resolved* when at
least :attr:`BackboneSettings.min_blocks` blocks are; a mode asked for (``frequencies_Hz``) that
the record does not show — a sensor at its node, a mode above the Nyquist frequency, a mode on
the hum — is returned unresolved with the reason, never invented.

Why this method (measured, ``docs/decisions.md``): judged by the describing functions of the
simulated families (``tests/benchmarks/bench_backbone.py``), mode 1's damping curve from the
band-pass + Hilbert envelope of :mod:`beam.residuals.envelope` (on the record put on a uniform
grid) agreed on 52 of 150 records, the block fits' on all 150; the Hilbert envelope needs
uniform samples and a band narrow enough to exclude the neighbours, whose edge transients span
several periods, and phones give neither. Hand-written numerics (the batched normal equations)
because scipy's least squares solves one problem per call: the ~40 blocks × ~5 lines × 5
iterations of a record would be ~1000 calls, where one batched solve per iteration costs a few ms.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.interpolate
import scipy.ndimage
import scipy.signal

from beam.errors import BeamInputError
from beam.io.anchor import refine_peak, uniform_grid
from beam.io.measurement import clipped_samples
from beam.residuals.common import jsonable
from beam.residuals.modal_id import compare_modes
from beam.residuals.noise import fourth_differences

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
        A block resolves its line when the line's amplitude in it is at least this far above its
        standard error (20 log10 (A / sd_A), dB; 20 dB: A ten times its error; for a block alone
        on white noise this is the matched-filter SNR of :data:`beam.residuals.modal_id.MIN_MODE_SNR`).
    min_blocks : int
        Fewest resolved blocks of a resolved mode.
    spike_sd : float
        Samples this many robust sd from the block's fit (or from the local cubic) are spikes.
    drift_order : int
        Degree of the polynomial offset + drift fitted in each block.
    iterations : int
        Gauss–Newton iterations per line and sweep.
    samples_per_period : float
        Each line is fitted on the record (less the lines above it) averaged over bins of as
        many samples as leave at least this many per period of the line.
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
        20 log10 (amplitude / its standard error) of the block (dB).
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
        ``"hum"`` (a mains harmonic of constant amplitude), ``"mixed"`` (a decaying line on a
        harmonic of the hum the record holds: a mode and the hum in one), ``"harmonic"`` (n × a
        stronger line, decaying faster than it), ``"unmatched"`` (a decaying line none of the asked
        modes matched) or ``"unresolved"`` (a spectral peak too few blocks resolve; a peak no
        block can use at all is not reported).
    amplitude : float
        Its median amplitude over its usable blocks (the record's unit; 0 when none is).
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
        The lowest rate a line was fitted at (its bins'; the record's when nothing was binned).
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
    d = np.abs(fourth_differences(t[index], y[index]))
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
    return _Record(tb[keep], yb[keep], np.ones(int(keep.sum()), dtype=bool))


def _prepared(t: np.ndarray, y: np.ndarray, valid: np.ndarray, segments: list[tuple[int, int]],
              q: int) -> tuple[_Record, list[tuple[int, int]]]:
    """The record binned by ``q`` (:func:`_binned`; as it is for q = 1) and its segments' index ranges in it."""
    record = _binned(t, y, valid, q) if q > 1 else _Record(t, y, valid.copy())
    cut = [int(np.searchsorted(record.t, t[a])) for a, _ in segments] + [record.t.size]
    return record, [(cut[i], max(cut[i + 1], cut[i])) for i in range(len(segments))]


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


#: Highest harmonic a line can be of a stronger one: the drag, a cubic spring, a slipping clamp and
#: clipping make odd ones (3, 5), a sensor's nonlinearity 2 and 3; a cantilever's mode 2 is 6.3
#: times its mode 1 (more with a tip mass or a compliant clamp), and must not be taken for one.
MAX_HARMONIC = 5
#: A line found in what the first lines leave is new when further than this (relative) from each of them.
HIDDEN_SEPARATION = 0.03
#: Least height over the floor of a peak of the one-sided periodogram of the release (dB): one
#: segment, no averaging, so white noise reaches 10 dB over its 25th percentile in 5 % of the
#: bins and 17 dB in 5e-7 of them.
RELEASE_HEIGHT_DB = 17.0


def _floor(frequency: np.ndarray, log_psd: np.ndarray, resolution_Hz: float) -> np.ndarray:
    """The spectrum's floor (dB): the :data:`FLOOR_PERCENTILE` th percentile of the log-PSD in bands
    of 1/:data:`FLOOR_BANDS_PER_DECADE` decade of f + 40 resolution bins (logarithmic above
    that, about 10 resolution bins wide below it, so that a low mode's own peak does not fill its
    band), interpolated between the bands' centres."""
    shifted = np.log10(frequency + 40.0 * resolution_Hz)
    band = np.floor(shifted * FLOOR_BANDS_PER_DECADE).astype(int)
    labels, start = np.unique(band, return_index=True)
    floors = np.array([np.percentile(part, FLOOR_PERCENTILE) for part in np.split(log_psd, start[1:])])
    return np.interp(shifted, (labels + 0.5) / FLOOR_BANDS_PER_DECADE, floors)


def _peaks(frequency: np.ndarray, density: np.ndarray, low: float, high: float, min_height_db: float,
           resolution_Hz: float) -> list[tuple[float, float]]:
    """(frequency (Hz), height over :func:`_floor` (dB)) of the peaks of a PSD at least
    :data:`MIN_PEAK_PROMINENCE_DB` above their dips and ``min_height_db`` above the floor, in
    [low, high] Hz."""
    log_psd = 10 * np.log10(np.maximum(density, max(float(density.max()), 1e-300) * 1e-30))
    floor = _floor(frequency, log_psd, resolution_Hz)
    peaks, _ = scipy.signal.find_peaks(log_psd, prominence=MIN_PEAK_PROMINENCE_DB)
    height = log_psd[peaks] - floor[peaks]
    keep = (frequency[peaks] >= low) & (frequency[peaks] <= high) & (height >= min_height_db)
    return [(refine_peak(frequency, log_psd, int(i)), float(h)) for i, h in zip(peaks[keep], height[keep])]


def _spectral_lines(t: np.ndarray, y: np.ndarray, settings: BackboneSettings) -> list[tuple[float, float]]:
    """(frequency (Hz), height over the floor (dB)) of the highest peaks of the record's spectra,
    highest first.

    The valid samples are put on a uniform grid at their median step
    (:func:`beam.io.anchor.uniform_grid`) and a cubic trend removed. Two spectra, with the
    4-term Blackman–Harris window (sidelobes −92 dB, so that a line 60 dB above the noise puts
    no false peak beside it), segments of the largest power of two ≤ n / 2 zero-padded
    :data:`ZERO_PADDING` ×:

    * the Welch PSD (50 % overlap): lines that last;
    * the periodogram of one segment from the release (the record's largest excursion in its
      first half) under the window's descending half: a tapered window hides what decays
      within its rising flank — a 215 Hz strip mode (ζ = 0.005) gone in 0.3 s did not show in
      the Welch PSD.

    A peak counts when it stands :attr:`BackboneSettings.min_prominence_db` (the Welch PSD) or
    :data:`RELEASE_HEIGHT_DB` (the release's) above the spectrum's floor (:func:`_floor`; a
    Welch spectrum of a few segments has dips 20 dB deep in white noise: prominences alone pick
    noise) and :data:`MIN_PEAK_PROMINENCE_DB` above its own dips, outside the main lobe of a
    higher peak; between 8 cycles of the record and 0.9 × Nyquist.
    """
    detrended = y - np.polyval(np.polyfit(t - t[0], y, 3), t - t[0])
    if detrended.size < 256:
        return []
    grid, step = uniform_grid(t, detrended)
    nperseg = int(2 ** int(np.floor(np.log2(max(grid.size / 2, 16)))))
    resolution = 1.0 / (nperseg * step)
    low = max(8.0 / (grid.size * step), MAIN_LOBE_BINS * resolution)
    high = 0.45 / step
    frequency, density = scipy.signal.welch(grid, fs=1.0 / step, window="blackmanharris", nperseg=nperseg,
                                            noverlap=nperseg // 2, nfft=ZERO_PADDING * nperseg, detrend="constant")
    found = _peaks(frequency, density, low, high, settings.min_prominence_db, resolution)
    release = int(np.argmax(np.abs(grid[: grid.size // 2])))
    segment = grid[release: release + nperseg]
    half = scipy.signal.get_window("blackmanharris", 2 * segment.size, fftbins=False)[segment.size:]
    frequency, density = scipy.signal.periodogram(segment, fs=1.0 / step, window=half,
                                                  nfft=ZERO_PADDING * nperseg, detrend="constant")
    found += _peaks(frequency, density, low, high, RELEASE_HEIGHT_DB, resolution)
    accepted: list[tuple[float, float]] = []
    for f, h in sorted(found, key=lambda p: -p[1]):
        if all(abs(f - g) > max(MAIN_LOBE_BINS * resolution, _inseparable(f, g, settings, hg - h)) for g, hg in accepted):
            accepted.append((f, h))
        if len(accepted) == settings.max_lines:
            break
    return accepted


def _longest_block(frequency_Hz: float, settings: BackboneSettings) -> float:
    """The longest block (s) a line's fits may take: :data:`LONGEST_BLOCK` × cycles_per_block of
    its periods, or :data:`HUM_BLOCK_S`."""
    return max(LONGEST_BLOCK * settings.cycles_per_block / frequency_Hz, HUM_BLOCK_S)


def _inseparable(f: float, g: float, settings: BackboneSettings, below_db: float = 0.0) -> float:
    """Below this distance (Hz) a line at f cannot be told from one at g (:data:`SEPARATION_CYCLES`
    cycles of their difference per block): in the longest block of the higher one, or, when f's
    peak is :data:`DOMINANCE_DB` or more below g's (``below_db``), in g's own block (a line that
    weak would stretch g's blocks for little: it is left to g's fit, where it moves g's amplitude
    by a few % at most); a mains harmonic's own block is HUM_BLOCK_S."""
    if below_db >= DOMINANCE_DB and _mains_harmonic(g, settings) is None:
        return SEPARATION_CYCLES * g / settings.cycles_per_block
    return SEPARATION_CYCLES / _longest_block(max(f, g), settings)


def _merged(first: list[tuple[float, float]], second: list[tuple[float, float]], apart_Hz: float,
            settings: BackboneSettings) -> list[tuple[float, float]]:
    """``first`` and the lines of ``second`` further than HIDDEN_SEPARATION (relative) and
    ``apart_Hz`` from each of them, and separable from them (:func:`_inseparable`)."""
    return first + [(f, h) for f, h in second
                    if all(abs(f - g) > max(HIDDEN_SEPARATION * g, apart_Hz, _inseparable(f, g, settings, hg - h))
                           for g, hg in first)]


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
    #: Blocks determined well enough to subtract the line and to judge what it is (>= USABLE_DB).
    usable: np.ndarray


def _place_blocks(t: np.ndarray, segments: list[tuple[int, int]], length_s: float, settings: BackboneSettings,
                  ends_s: list[float] | None = None, most: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres (s), half-lengths (s) and segment numbers of the blocks of one line: from each
    segment's start to its end (or ``ends_s``, where the line falls below the noise), a hop of
    (1 − overlap) blocks or longer to keep at most ``most`` (default max_blocks) per segment."""
    most = settings.max_blocks if most is None else most
    centres, halves, owner = [], [], []
    for number, (a, b) in enumerate(segments):
        if b <= a:
            continue
        t0, t1 = t[a], t[b - 1]
        if ends_s is not None:
            t1 = min(t1, ends_s[number])
        span = t1 - t0
        if span < length_s:
            continue
        hop = max(length_s * (1.0 - settings.overlap), (span - length_s) / max(most - 1, 1))
        count = int(math.floor((span - length_s) / hop)) + 1
        c = t0 + 0.5 * length_s + hop * np.arange(count)
        centres.append(c)
        halves.append(np.full(count, 0.5 * length_s))
        owner.append(np.full(count, number))
    if not centres:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=int)
    return np.concatenate(centres), np.concatenate(halves), np.concatenate(owner)


def _life(fit: _Fit, segments_s: list[tuple[float, float]], settings: BackboneSettings) -> list[float]:
    """Where the line falls below the noise in each segment (s): after the longest run of
    consecutive usable blocks (a decaying line's usable blocks follow each other from the
    release; a lone usable block elsewhere is noise), by the time its median decay rate takes to
    bring the run's last amplitude z-score down to :data:`USABLE_DB`, plus two half-blocks; the
    segment's end when no block of it is usable or the line does not decay (median σ ≤ 0)."""
    floor = 10 ** (USABLE_DB / 20)
    ends = []
    for number, (_, stop) in enumerate(segments_s):
        index = np.flatnonzero(fit.segment == number)
        ok = fit.usable[index]
        if not ok.any():
            ends.append(stop)
            continue
        edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(np.int8), [0]])))
        starts, stops = edges[0::2], edges[1::2]
        longest = int(np.argmax(stops - starts))
        run = index[starts[longest]: stops[longest]]
        sigma = float(np.median(-fit.s.real[run]))
        if sigma <= 0:
            ends.append(stop)
            continue
        last = run[-1]
        z = abs(fit.z[last]) / max(float(fit.amplitude_sd[last]), 1e-300)
        ends.append(float(min(stop, fit.centre[last] + math.log(max(z / floor, 1.0)) / sigma + 2 * fit.half[last])))
    return ends


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


#: A block's frequency stays within this share of its line's (and within half the distance to the
#: nearest other line): beyond, in a block of noise, the fit wanders to where two nearly collinear
#: lines cancel with large amplitudes.
REACH = 0.1
#: A block whose amplitude is at least this far above its standard error (dB) is used to subtract
#: its line from the others' blocks and to judge what the line is, though it is not shown on the
#: curves below min_block_snr_db: a line the spectrum shows but no block resolves (weak hum) would
#: otherwise stay in the data of every line below it.
USABLE_DB = 10.0
#: Largest |σ| T of a block's fit: a block whose envelope would change by more than e^3 over its
#: length holds no damped sinusoid (it is noise, or a jump) and is not resolved.
MAX_BLOCK_DECAY = 3.0
#: Column pairs of the followed line in its blocks: (Z + U u + W u²) e^{sτ}. The quadratic term
#: takes the curvature of the envelope inside a block (a damping that changes with the
#: amplitude), so that Z and U are the envelope and its slope at the centre: on the drag's
#: 50 cm strip decay (C_d = 15) the first block's ζ was 3.5 % low without it.
TARGET_POWERS = 3


#: Ridge added to a block's normal matrix scaled to a unit diagonal (:func:`_solve`): a slow line
#: over a short block and the drift polynomial span nearly the same curves; the ridge leaves the
#: well-determined coefficients (the followed line's) as they are and shrinks the others'
#: undetermined combinations towards zero instead of amplifying rounding.
RIDGE = 1e-10


def _products(columns: np.ndarray, other: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """columns^T W other for every block: (B, p, q)."""
    return np.matmul(np.ascontiguousarray(np.swapaxes(columns * weight[:, :, None], 1, 2)), other)


def _solve(gram: np.ndarray, rhs: np.ndarray, wanted: int) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients (B, p) of every block's normal equations ``gram`` (B, p, p) c = ``rhs`` (B, p),
    ridged (:data:`RIDGE`) after scaling to a unit diagonal, and the first ``wanted`` columns of
    the inverse (B, p, wanted): one batched :func:`numpy.linalg.solve` (4× cheaper than the
    inverse, 20× cheaper than a batched ``eigh`` under OpenBLAS's threads)."""
    scale = np.sqrt(np.maximum(np.einsum("bpp->bp", gram), 1e-300))
    normal = gram / (scale[:, :, None] * scale[:, None, :]) + RIDGE * np.eye(gram.shape[1])[None]
    unit = np.broadcast_to(np.eye(gram.shape[1])[:, :wanted], (gram.shape[0], gram.shape[1], wanted))
    right = np.concatenate([(rhs / scale)[:, :, None], unit / scale[:, :, None]], axis=2)
    solved = np.linalg.solve(normal, right) / scale[:, :, None]
    return solved[:, :, 0], solved[:, :, 1:]


def _fit_line(record: _Record, centres: np.ndarray, halves: np.ndarray, owner: np.ndarray, s0: complex,
              others: list[tuple[np.ndarray, np.ndarray]], settings: BackboneSettings, reach_Hz: float) -> _Fit:
    """The blocks of one line: Gauss–Newton on its s in each block, the other lines (their s at
    each block, ``others``: (block times, s) to interpolate) and the drift as linear columns.

    The normal matrix is kept in blocks: the fixed columns' part (the drift and the other lines)
    is formed once (again after the spikes leave), each iteration forms only the followed line's
    rows: its 2 TARGET_POWERS columns against everything."""
    tau, y, weight = _gather(record, centres, halves)
    u = tau / halves[:, None]
    drift = np.stack([u**k for k in range(settings.drift_order + 1)], axis=2)
    nuisance = [drift]
    for times, s_other in others:
        s_at = (np.interp(centres, times, s_other.real) + 1j * np.interp(centres, times, s_other.imag)
                if times.size else np.full(centres.size, s_other))
        nuisance.append(_line_columns(tau, u, s_at))
    fixed = np.concatenate(nuisance, axis=2)
    width = 2 * TARGET_POWERS
    fixed_gram = _products(fixed, fixed, weight)
    fixed_rhs = _products(fixed, y[:, :, None], weight)[:, :, 0]
    s = np.full(centres.size, complex(s0))
    omega_limit = 0.05 * abs(s0.imag)
    reach = 2 * np.pi * reach_Hz  # how far a block's frequency may go from the line's
    for iteration in range(settings.iterations + 1):
        target = _line_columns(tau, u, s, TARGET_POWERS)
        cross = _products(target, np.concatenate([target, fixed], axis=2), weight)  # (B, width, p)
        gram = np.concatenate([cross, np.concatenate([np.swapaxes(cross[:, :, width:], 1, 2), fixed_gram], axis=2)],
                              axis=1)
        rhs = np.concatenate([_products(target, y[:, :, None], weight)[:, :, 0], fixed_rhs], axis=1)
        coefficients, inverse = _solve(gram, rhs, 4)
        if iteration == 1 or iteration == settings.iterations:
            fitted = np.matmul(target, coefficients[:, :width, None])[:, :, 0] + np.matmul(
                fixed, coefficients[:, width:, None])[:, :, 0]
            residual = (y - fitted) * weight
        if iteration == 1:  # spikes: residuals beyond spike_sd robust sd leave the block
            absolute = np.where(weight > 0, np.abs(residual), np.nan)
            robust = 1.4826 * np.nanmedian(absolute, axis=1)
            outlier = absolute > settings.spike_sd * robust[:, None]
            if outlier.any():
                weight = np.where(outlier, 0.0, weight)
                y = y * (weight > 0)
                fixed_gram = _products(fixed, fixed, weight)
                fixed_rhs = _products(fixed, y[:, :, None], weight)[:, :, 0]
        z = coefficients[:, 0] + 1j * coefficients[:, 1]
        v = coefficients[:, 2] + 1j * coefficients[:, 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(np.abs(z) > 0, v / (z * halves), 0.0)
        step = np.clip(step.real, -omega_limit, omega_limit) + 1j * np.clip(step.imag, -omega_limit, omega_limit)
        s = s + np.nan_to_num(step)
        # a block's envelope changes by at most e^MAX_BLOCK_DECAY over its length: beyond, it is no
        # damped sinusoid (noise, a jump)
        sigma = np.clip(-s.real, -MAX_BLOCK_DECAY / (2 * halves), MAX_BLOCK_DECAY / (2 * halves))
        s = -sigma + 1j * np.clip(s.imag, s0.imag - reach, s0.imag + reach)
    columns = fixed.shape[2] + width
    # final: covariance of (Z, U) scaled by the residual variance and its AR(1) colour at the line
    count = weight.sum(axis=1)
    p = columns
    variance = (residual**2).sum(axis=1) / np.maximum(count - p, 1.0)
    lagged = (residual[:, 1:] * residual[:, :-1]).sum(axis=1)
    rho = np.clip(lagged / np.maximum((residual**2).sum(axis=1), 1e-300), -0.95, 0.95)
    dt = np.maximum(np.nanmedian(np.where(weight[:, 1:] > 0, np.diff(tau, axis=1), np.nan), axis=1), 1e-300)
    colour = (1 - rho**2) / (1 - 2 * rho * np.cos(s.imag * dt) + rho**2)
    variance = variance * np.maximum(colour, 1.0)
    cov = inverse[:, :4, :] * variance[:, None, None]
    magnitude = np.abs(z)
    unit = np.where(magnitude[:, None] > 0, np.stack([z.real, z.imag], axis=1) / np.maximum(magnitude, 1e-300)[:, None], 0)
    # amplitude sd along Z; the step's sd: U / (Z h) rotated by -arg Z
    amplitude_sd = np.sqrt(np.maximum(np.einsum("bi,bij,bj->b", unit, cov[:, :2, :2], unit), 0.0))
    rotation = np.stack([np.stack([unit[:, 0], unit[:, 1]], 1), np.stack([-unit[:, 1], unit[:, 0]], 1)], 1)
    step_cov = np.einsum("bij,bjk,blk->bil", rotation, cov[:, 2:, 2:], rotation) / (
        np.maximum(magnitude, 1e-300) * halves)[:, None, None] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = 20 * np.log10(magnitude / np.maximum(amplitude_sd, 1e-300))
    sigma_sd, omega_sd = np.sqrt(np.maximum(step_cov[:, 0, 0], 0)), np.sqrt(np.maximum(step_cov[:, 1, 1], 0))
    inside = (np.abs(s.real) * 2 * halves < MAX_BLOCK_DECAY * (1 - 1e-9)) & (np.abs(s.imag - s0.imag) < reach * (1 - 1e-9))
    # no sinusoid in a block is larger than the block's own swing: a larger amplitude is two
    # nearly collinear lines cancelling (a spurious line latched onto a neighbour)
    centred = np.where(weight > 0, y - (y * weight).sum(axis=1, keepdims=True) / np.maximum(count, 1)[:, None], 0.0)
    plausible = magnitude <= 2.0 * np.max(np.abs(centred), axis=1) * np.exp(np.abs(s.real) * halves)
    usable = (snr >= USABLE_DB) & np.isfinite(snr) & (omega_sd < 0.05 * np.abs(s.imag)) & (
        count > p + 4) & inside & np.isfinite(magnitude) & plausible
    resolved = usable & (snr >= settings.min_block_snr_db) & (omega_sd < 0.02 * np.abs(s.imag))
    return _Fit(centres, halves, owner, s, z, amplitude_sd, omega_sd, sigma_sd, snr, np.sqrt(variance), resolved,
                usable)


#: Cycles of the difference frequency a block spans at least, so that two lines are told apart in it.
SEPARATION_CYCLES = 2.0


#: Block length (s) of a line at a mains harmonic whose first blocks show no decay: its amplitude
#: is constant and long blocks resolve a weak hum line that 8 of its cycles do not.
HUM_BLOCK_S = 1.0
#: ... at most this many per segment (its constancy and frequency need no more), binned to this
#: many samples per period (the bins' Dirichlet gain, 0.90 at 4, is corrected).
HUM_BLOCKS = 8
HUM_SAMPLES_PER_PERIOD = 4.0
#: A line's blocks are at most this many times cycles_per_block of its periods long (or
#: HUM_BLOCK_S): lines closer than two cycles of their difference in such a block are one line to
#: the fits (:func:`_inseparable`): a cluster of lines 0.3-2 Hz apart near 360 Hz in a shared
#: run's accelerometer asked for blocks of 6-12 s at 4 kHz and took 20 s of CPU.
LONGEST_BLOCK = 4.0
#: A line's first fit spans this many block lengths from each segment's start (5 blocks; a probe: a decaying
#: line is largest there, a lasting one everywhere); a line no block of it holds is dropped.
PROBE_BLOCKS = 3.0
#: A spectral peak this far (dB) below a neighbour's must be told from it in the neighbour's own
#: blocks (:func:`_inseparable`): on a shared run, a peak 31 dB below mode 2 and 2 Hz from it
#: stretched mode 2's blocks from 0.2 to 1 s and cost it two thirds of its resolved blocks.
DOMINANCE_DB = 20.0
#: A block of the strongest line whose residual sd peaks above this multiple of the line's median
#: holds a disturbance (:func:`_disturbances`).
DISTURBANCE = 5.0
#: Most samples (blocks × samples per block) one fit of one line takes: beyond, fewer blocks.
ROWS_PER_FIT = 32768
#: A segment holding fewer blocks of cycles_per_block than this gets shorter blocks: a steel ruler's
#: 1.9 Hz mode over 12 s made 4 blocks of 8 cycles, too few for a curve and each spanning much of
#: its frequency's change.
SHORT_RECORD_BLOCKS = 8.0
#: Fewest samples per fitted column in a block.
SAMPLES_PER_COLUMN = 3.0


def _block_length(frequency_Hz: float, sigma: float, separation_Hz: float, shortest_s: float,
                  settings: BackboneSettings, span_s: float = np.inf) -> float:
    """The block length (s) for a line: :attr:`BackboneSettings.cycles_per_block` periods, or
    :data:`SEPARATION_CYCLES` periods of its distance to the nearest other line (at most
    :func:`_longest_block`), or
    ``shortest_s`` (:data:`SAMPLES_PER_COLUMN` samples per column) if longer; shortened to
    max_decay_per_block / sigma, and at least min_cycles_per_block periods and ``shortest_s``; a
    segment of ``span_s`` shorter than :data:`SHORT_RECORD_BLOCKS` blocks of cycles_per_block takes
    shorter blocks (down to min_cycles_per_block), so that a slow mode still gets a curve."""
    cycles = max(min(settings.cycles_per_block, span_s * frequency_Hz / SHORT_RECORD_BLOCKS),
                 settings.min_cycles_per_block)
    length = max(cycles / frequency_Hz, shortest_s)
    if separation_Hz > 0:
        length = max(length, min(SEPARATION_CYCLES / separation_Hz, _longest_block(frequency_Hz, settings)))
    if sigma > 0:
        length = min(length, settings.max_decay_per_block / sigma)
    return max(length, settings.min_cycles_per_block / frequency_Hz, shortest_s)


def _most(most: int | None, length_s: float, step_s: float, settings: BackboneSettings) -> int:
    """Most blocks per segment of a fit: ``most`` (default max_blocks), fewer when their samples
    would exceed :data:`ROWS_PER_FIT`."""
    blocks = settings.max_blocks if most is None else most
    return int(max(settings.min_blocks + 1, min(blocks, ROWS_PER_FIT // max(int(length_s / step_s), 1))))


def _summary_s(fit: _Fit) -> complex:
    """The median s over a line's resolved blocks (its usable ones when none is resolved)."""
    ok = fit.s[fit.resolved] if fit.resolved.any() else fit.s[fit.usable]
    return complex(np.median(ok.real), np.median(ok.imag))


def _reconstruct(fit: _Fit, gain: float, t: np.ndarray, segments_s: list[tuple[float, float]]) -> np.ndarray:
    """The line at stamps ``t`` from its usable blocks (the record's unit).

    Over each run of consecutive usable blocks of a segment (no more than 1.5 hops apart), its
    phase is the cubic Hermite interpolant of the blocks' phases (unwrapped by their mean
    frequency, McAulay & Quatieri 1986) and frequencies, its amplitude log-linear between
    theirs; for one block length before a run and two after it, the nearest block's own
    sinusoid, its amplitude never growing away from the block; zero elsewhere (where the line is
    below the noise).
    """
    out = np.zeros(t.size)
    for number, (start, stop) in enumerate(segments_s):
        mine = fit.segment == number
        if not (fit.usable & mine).any():
            continue
        hop = float(np.median(np.diff(fit.centre[mine]))) if mine.sum() > 1 else np.inf
        index = np.flatnonzero(fit.usable & mine)
        breaks = np.flatnonzero(np.diff(fit.centre[index]) > 1.5 * hop) + 1
        for run in np.split(index, breaks):
            c, z, sv = fit.centre[run], fit.z[run] / gain, fit.s[run]
            length = 2 * float(np.median(fit.half[run]))
            lo, first, last, hi = np.searchsorted(t, [max(start, c[0] - length), c[0], c[-1], min(stop, c[-1] + 2 * length)])
            hi = int(np.searchsorted(t, min(stop, c[-1] + 2 * length), side="right"))
            for part, (i, j), block in (("before", (lo, first), 0), ("after", (last, hi), -1)):
                d = t[i:j] - c[block]
                growth = np.clip(sv[block].real * d, -50.0, 0.0)  # never growing away from the block
                out[i:j] = np.real(z[block] * np.exp(growth + 1j * sv[block].imag * d))
            if c.size >= 2:
                phase = np.angle(z)
                for i in range(1, c.size):  # unwrap: the turns the mean frequency predicts
                    predicted = phase[i - 1] + 0.5 * (sv[i - 1].imag + sv[i].imag) * (c[i] - c[i - 1])
                    phase[i] += 2 * np.pi * np.round((predicted - phase[i]) / (2 * np.pi))
                between = t[first:last]
                theta = scipy.interpolate.CubicHermiteSpline(c, phase, sv.imag)(between)
                log_a = np.interp(between, c, np.log(np.maximum(np.abs(z), 1e-300)))
                out[first:last] = np.exp(log_a) * np.cos(theta)
    return out


def _follow(t: np.ndarray, y: np.ndarray, valid: np.ndarray, segments: list[tuple[int, int]], lines: list[float],
            heights: list[float], settings: BackboneSettings, previous: dict[float, tuple] | None = None
            ) -> tuple[list[_Fit | None], list[float], list[int], dict[float, tuple]]:
    """Block fits of every line, highest frequency first, in two sweeps (one when ``previous``
    holds the fits of an earlier call by line frequency: they start this one).

    For each line the lines above it are subtracted (:func:`_reconstruct` from their fits of
    this sweep), the rest averaged over bins of q samples (at least
    :attr:`BackboneSettings.samples_per_period` bins per period of the line: the fit sees only
    the line and the lines below it, which are columns of its blocks, their s from their last
    fits). A line with fewer than min_blocks usable blocks in the first sweep (noise; not a line at
    a mains harmonic that does not decay), or that its blocks cannot
    tell from a line of a higher spectral peak (``heights``, dB) closer than one cycle of their
    difference per block, is dropped (None) and leaves the others' fits.

    Returns the fits, the bins' gain at each line, each line's q, and what a later call may
    start from.
    """
    step = float(np.median(np.diff(t)))
    rate = 1.0 / step
    fits: list[_Fit | None] = [None] * len(lines)
    plans: list[list[float] | None] = [None] * len(lines)  # where each line lives (s, per segment)
    most: list[int | None] = [None] * len(lines)
    gains = [1.0] * len(lines)
    bins = [1] * len(lines)
    active = sorted(range(len(lines)), key=lambda k: -lines[k])
    s_now = [complex(0.0, 2 * np.pi * f) for f in lines]
    for k, f in enumerate(lines):
        if previous is not None and f in previous:
            if previous[f] is None:  # dropped before
                active.remove(k)
            else:
                fits[k], plans[k], s_now[k], most[k] = previous[f]
    segments_s = [(float(t[a]), float(t[b - 1])) for a, b in segments]
    longest_span = max(b - a for a, b in segments_s)
    for sweep in range(1 if previous is not None else 2):
        contributions: dict[int, np.ndarray] = {}
        for k in list(active):
            f = abs(s_now[k]) / (2 * np.pi)
            higher = [j for j in active if lines[j] > lines[k] and j in contributions]
            lower = [j for j in active if lines[j] < lines[k]]
            residual = y - sum((contributions[j] for j in higher), np.zeros(t.size))
            per_period = settings.samples_per_period if most[k] is None else HUM_SAMPLES_PER_PERIOD
            q = max(1, int(rate / (per_period * f)))
            record, fit_segments = _prepared(t, residual, valid, segments, q)
            others = []
            for j in lower:
                earlier = fits[j]
                if earlier is not None and earlier.usable.any():
                    ok = earlier.usable
                    others.append((earlier.centre[ok], earlier.s[ok]))
                else:
                    others.append((np.zeros(0), np.array(s_now[j])))
            # the lines that set how long the blocks must be to tell them apart: not those
            # DOMINANCE_DB weaker (they are left to this line's fit), and in a later call only
            # those with a fit (a new line not yet probed may be noise)
            distance = [abs(abs(s_now[j]) - abs(s_now[k])) / (2 * np.pi) for j in active if j != k]
            neighbours = [abs(abs(s_now[j]) - abs(s_now[k])) / (2 * np.pi) for j in active
                          if j != k and (previous is None or fits[j] is not None)
                          and heights[k] - heights[j] < DOMINANCE_DB]
            separation = min(neighbours, default=0.0)
            reach = min(0.5 * min(distance, default=np.inf), REACH * f)
            columns = 2 * TARGET_POWERS + settings.drift_order + 1 + 4 * len(lower)
            shortest = SAMPLES_PER_COLUMN * columns * step * q
            length = _block_length(f, max(-s_now[k].real, 0.0), separation, shortest, settings, longest_span)
            # a line's first fit probes the start of each segment, where a decaying line is
            # largest, in blocks of its own cycles (cheap: a noise line is dropped at that cost)
            ends = plans[k]
            if plans[k] is None:
                length = max(settings.cycles_per_block / f, shortest)
                ends = [start + PROBE_BLOCKS * length for start, _ in segments_s]
            centres, halves, owner = _place_blocks(record.t, fit_segments, length, settings, ends,
                                                   _most(most[k], length, q * step, settings))
            if centres.size == 0:
                fits[k] = None
                continue
            fit = _fit_line(record, centres, halves, owner, s_now[k], others, settings, reach)
            if plans[k] is None and not fit.usable.any():
                fits[k] = None  # no block of the probe holds it: noise
                continue
            if fit.usable.any():
                # blocks as long as the line's decay allows, where it lives: fit again when the
                # plan changes (a line that dies early, decays fast, or lives longer than planned)
                shorter = _block_length(f, max(-_summary_s(fit).real, 0.0), separation, shortest, settings,
                                        longest_span)
                ok = fit.usable
                if _mains_harmonic(f, settings) is not None and abs(float(np.median(fit.s.real[ok]))) < 3 * float(
                        np.median(fit.sigma_sd[ok])):
                    shorter = max(shorter, HUM_BLOCK_S)  # a line that does not decay: long blocks resolve it
                    most[k] = HUM_BLOCKS
                    q = max(1, int(rate / (HUM_SAMPLES_PER_PERIOD * f)))
                    record, fit_segments = _prepared(t, residual, valid, segments, q)
                    shortest = SAMPLES_PER_COLUMN * columns * step * q
                    length = 0.0  # fit again
                lives = _life(fit, segments_s, settings)
                span = sum(e - t[a] for e, (a, _) in zip(lives, segments))
                planned = sum((t[b - 1] if ends is None else min(e, t[b - 1])) - t[a]
                              for e, (a, b) in zip(ends or [np.inf] * len(segments), segments))
                if length <= 0 or abs(shorter / length - 1) > 0.2 or abs(span / max(planned, 1e-300) - 1) > 0.3:
                    centres, halves, owner = _place_blocks(record.t, fit_segments, shorter, settings, lives,
                                                           _most(most[k], shorter, q * step, settings))
                    if centres.size:
                        fit = _fit_line(record, centres, halves, owner, s_now[k], others, settings, reach)
                plans[k] = lives
            fits[k], bins[k] = fit, q
            gains[k] = _dirichlet(f, q, step)
            if fit.usable.any():
                s_now[k] = _summary_s(fit)
                contributions[k] = _reconstruct(fit, gains[k], t, segments_s)
        if sweep == 0:
            active = [k for k in active if fits[k] is not None and (fits[k].usable.sum() >= settings.min_blocks
                                                                     or most[k] is not None)]
            for k in sorted(active, key=lambda k: heights[k]):
                length = 2 * float(np.median(fits[k].half)) * bins[k] / max(bins[k], 1)
                close = [j for j in active if j != k and abs(abs(s_now[j]) - abs(s_now[k])) / (2 * np.pi) * length < 1.0]
                if close:  # the lower spectral peak of two lines the blocks cannot tell apart
                    active.remove(k)
            fits = [fits[k] if k in active else None for k in range(len(lines))]
    state = {lines[k]: (fits[k], plans[k], s_now[k], most[k]) if k in active and fits[k] is not None else None
             for k in range(len(lines))}
    return fits, gains, bins, state


def _disturbances(t: np.ndarray, y: np.ndarray, valid: np.ndarray, fits: list[_Fit | None],
                  segments: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Stretches (sample index ranges) that hold a disturbance of a decay: in the blocks of the
    strongest line, a block whose residual sd is a local peak above :data:`DISTURBANCE` times the
    median of its usable blocks, with the blocks two hops before and after it below half that
    peak (a tap or a second pluck spoils the one or two blocks that straddle it; a decay's slowly
    changing misfit does not peak). The disturbance is found inside that block by a linear
    predictor (:func:`_jump`); the decay before it ends there and a new one starts a tenth of a
    block after it. None within two blocks of a segment's start."""
    candidates = [f for f in fits if f is not None and f.usable.sum() >= 5]
    if not candidates:
        return []
    fit = max(candidates, key=lambda f: float(np.max(np.abs(f.z[f.usable]))))
    ratio = fit.residual_sd / float(np.median(fit.residual_sd[fit.usable]))
    starts = np.array([t[a] for a, _ in segments])
    order = int(min(2 * sum(f is not None for f in fits) + 2, 32))
    gaps: list[tuple[int, int]] = []
    for b in range(2, ratio.size - 2):
        if not (ratio[b] > DISTURBANCE and ratio[b] >= ratio[b - 1] and ratio[b] >= ratio[b + 1]
                and ratio[b - 2] < 0.5 * ratio[b] and ratio[b + 2] < 0.5 * ratio[b]):
            continue
        c, h = float(fit.centre[b]), float(fit.half[b])
        jump = _jump(t, y, valid, c - h, c + h, order)
        if jump is not None and np.all(np.abs(t[jump] - starts) > 4 * h) and all(
                abs(t[jump] - t[a]) > 4 * h for a, _ in gaps):
            gaps.append((max(jump - 2, 0), int(np.searchsorted(t, t[jump] + 0.1 * h))))
    return gaps


def _jump(t: np.ndarray, y: np.ndarray, valid: np.ndarray, start: float, stop: float, order: int) -> int | None:
    """The sample (index) of [start, stop] s where a decay is disturbed: the largest one-step error
    of a linear predictor of ``order`` (least squares on the valid samples of the stretch and two
    of its lengths around it, put on a uniform grid at their median step). A sum of damped
    sinusoids is predicted to the noise; a tap or a second pluck is not, at the sample it
    happens."""
    span = stop - start
    inside = valid & (t >= start - 2 * span) & (t <= stop + 2 * span)
    if np.count_nonzero(inside) < 4 * order + 8:
        return None
    grid, step = uniform_grid(t[inside], y[inside])
    rows = np.lib.stride_tricks.sliding_window_view(grid, order + 1)
    coefficients, *_ = np.linalg.lstsq(rows[:, :-1], rows[:, -1], rcond=None)
    error = np.abs(rows[:, -1] - rows[:, :-1] @ coefficients)
    times = t[inside][0] + step * (np.arange(error.size) + order)
    window = (times >= start) & (times <= stop)
    if not window.any():
        return None
    return int(np.searchsorted(t, times[window][int(np.argmax(error[window]))]))


# ---------------------------------------------------------------------------------------------
# classification and results


def _mains_harmonic(frequency_Hz: float, settings: BackboneSettings) -> float | None:
    """The mains frequency of which ``frequency_Hz`` is a harmonic (within the tolerance), or None;
    of two (300 Hz is 5 × 60 and 6 × 50), the one of the lower harmonic."""
    found = []
    for mains in settings.mains_Hz:
        k = round(frequency_Hz / mains)
        if k >= 1 and abs(frequency_Hz - k * mains) <= settings.mains_tolerance * k * mains:
            found.append((k, mains))
    return min(found)[1] if found else None


def _fall(fit: _Fit) -> float:
    """Share of its amplitude a line loses over its usable blocks of its first segment, from a
    weighted straight line through their log-amplitudes (weights (A / sd_A)²)."""
    ok = fit.usable & (fit.segment == fit.segment[fit.usable][0])
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


def _log_rate(t: np.ndarray, omega: np.ndarray, omega_sd: np.ndarray, segment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d ln omega / dt at each block (1/s) and its sd, by central differences over the blocks of
    each segment (one-sided at its ends, 0 for a segment of one block)."""
    rate, sd = np.zeros(t.size), np.zeros(t.size)
    for number in np.unique(segment):
        index = np.flatnonzero(segment == number)
        if index.size < 2:
            continue
        before = np.concatenate([[index[0]], index[:-1]])
        after = np.concatenate([index[1:], [index[-1]]])
        before[0], after[0] = index[0], index[1]
        before[-1], after[-1] = index[-2], index[-1]
        span = t[after] - t[before]
        rate[index] = (omega[after] - omega[before]) / span / omega[index]
        sd[index] = np.hypot(omega_sd[after], omega_sd[before]) / span / omega[index]
    return rate, sd


def _mode_of(fit: _Fit, number: int, peak_Hz: float, gain: float, order: int, settings: BackboneSettings) -> ModeBackbone:
    ok = fit.resolved
    if ok.sum() < settings.min_blocks:
        best = float(np.nanmax(fit.snr_db)) if fit.snr_db.size and np.isfinite(fit.snr_db).any() else float("nan")
        note = (f"not resolved: {int(ok.sum())} of its blocks are {settings.min_block_snr_db:g} dB above the noise "
                f"({settings.min_blocks} needed; the best is {best:.0f} dB)")
        return _empty_mode(number, peak_Hz, note, order)
    s = fit.s[ok].copy()
    omega_sd, sigma_sd = fit.omega_sd[ok], fit.sigma_sd[ok].copy()
    if order > 0:
        # the displacement's decay: a velocity or acceleration amplitude is omega^order times it,
        # so where the frequency changes it decays by order d ln omega / dt more (or less)
        rate, rate_sd = _log_rate(fit.centre[ok], s.imag, omega_sd, fit.segment[ok])
        s = s - order * rate + 0j
        sigma_sd = np.hypot(sigma_sd, order * rate_sd)
    magnitude = np.abs(s)
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
    lobe = MAIN_LOBE_BINS * 4.0 / (t[-1] - t[0])  # the main lobe of the spectra's segments (n / 4 to n / 2 long)
    found = _spectral_lines(t[clean][valid[clean]], y[clean][valid[clean]], settings)
    if clean != slice(0, t.size):  # and the whole record's, for what the unclipped stretch is too short to show
        found = _merged(found, _spectral_lines(t[valid], y[valid], settings), lobe, settings)
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
    segments = _segments(t, y, valid, 1.0 / min(lines), first)
    fits, gains, bins, state = _follow(t, y, valid, segments, lines, heights, settings)
    segments_s = tuple((float(t[a]), float(t[b - 1])) for a, b in segments)
    residual = y - sum((_reconstruct(fit, gain, t, list(segments_s)) for fit, gain in zip(fits, gains)
                        if fit is not None and fit.resolved.any()), np.zeros(t.size))
    # a disturbance inside a decay (a tap, a second pluck, a knock): a new segment there, and
    # everything followed again
    gaps = _disturbances(t, y, valid, fits, segments)
    if gaps:
        for lo, hi in gaps:
            segments = [piece for a, b in segments for piece in (
                ((a, lo), (hi, b)) if a < lo < b else ((a, b),)) if piece[1] - piece[0] > 1]
        fits, gains, bins, state = _follow(t, y, valid, segments, lines, heights, settings)
        segments_s = tuple((float(t[a]), float(t[b - 1])) for a, b in segments)
        residual = y - sum((_reconstruct(fit, gain, t, list(segments_s)) for fit, gain in zip(fits, gains)
                            if fit is not None and fit.resolved.any()), np.zeros(t.size))
    # lines the strong ones hid (their leakage raises the release spectrum's floor): searched
    # again in what the lines found leave, and if any, everything followed again
    more = _merged(found, _spectral_lines(t[clean][valid[clean]], residual[clean][valid[clean]], settings), lobe,
                   settings)
    if len(more) > len(found):
        found = sorted(more)
        lines = [f for f, _ in found]
        heights = [h for _, h in found]
        fits, gains, bins, _ = _follow(t, y, valid, segments, lines, heights, settings, state)

    kinds, notes = _kinds(lines, fits, gains, settings)
    strength = [_strength(fit, gain) for fit, gain in zip(fits, gains)]
    strongest = int(np.argmax(strength))
    candidates = [k for k in range(len(lines)) if kinds[k] is None]
    modes: list[ModeBackbone] = []
    shown: set[int] = set()
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
                near = [k for k in range(len(lines)) if kinds[k] in ("hum", "mixed")
                        and abs(math.log(lines[k] / f_asked)) <= settings.hint_tolerance]
                if near:
                    note = (f"not resolved: near {f_asked:.4g} Hz the record holds mains hum "
                            f"({', '.join(f'{lines[k]:.2f} Hz' for k in near)}), which a mode there cannot be told from")
                else:
                    note = (f"not resolved: no spectral peak within {100 * (math.exp(settings.hint_tolerance) - 1):.0f} % "
                            f"of {f_asked:.4g} Hz rises {settings.min_prominence_db:g} dB above the noise")
                modes.append(_empty_mode(number, f_asked, note, order))
            else:
                k = by_frequency[match.frequency_data_Hz]
                shown.add(k)
                modes.append(_mode_of(fits[k], number, lines[k], gains[k], order, settings) if fits[k] is not None
                             else _empty_mode(number, lines[k], DROPPED, order))
    else:
        resolved = [k for k in candidates if fits[k] is not None and fits[k].resolved.sum() >= settings.min_blocks]
        for number, k in enumerate(resolved, start=1):
            shown.add(k)
            modes.append(_mode_of(fits[k], number, lines[k], gains[k], order, settings))
    excluded = []
    for k, f in enumerate(lines):
        if k in shown:
            continue
        if kinds[k] is not None:
            excluded.append(SpectralLine(float(f), kinds[k], strength[k], notes[k]))
        elif fits[k] is not None and fits[k].resolved.sum() >= settings.min_blocks:
            excluded.append(SpectralLine(float(f), "unmatched", strength[k],
                                         "a decaying line that none of the asked modes matches"))
        elif fits[k] is not None and fits[k].usable.any():
            excluded.append(SpectralLine(float(f), "unresolved", strength[k],
                                         "a spectral peak that too few blocks resolve to follow it"))
    noise = float(np.median(fits[strongest].residual_sd)) if fits[strongest] is not None else float("nan")
    return FreeDecayBackbone(
        modes=tuple(modes), lines=tuple(excluded), output_kind=output, segments_s=segments_s,
        clipped_count=clipped_count, spike_count=int(np.count_nonzero(spikes)), sample_rate_Hz=rate,
        fit_rate_Hz=rate / max(bins), noise_sd=noise,
    )


def _strength(fit: _Fit | None, gain: float) -> float:
    """A line's median amplitude over its usable blocks (the record's unit), 0 without any."""
    if fit is None or not fit.usable.any():
        return 0.0
    return float(np.median(np.abs(fit.z[fit.usable]))) / gain


def _kinds(lines: list[float], fits: list[_Fit | None], gains: list[float],
           settings: BackboneSettings) -> tuple[list[str | None], list[str]]:
    """What each line is: ``"hum"``, ``"mixed"`` (a decaying line on a harmonic of the hum the
    record holds), ``"harmonic"`` or None (a mode), with a note (module notes)."""
    largest = [float(np.max(np.abs(f.z[f.usable]))) / g if f is not None and f.usable.any() else 0.0
               for f, g in zip(fits, gains)]
    kinds: list[str | None] = [None] * len(lines)
    notes = [""] * len(lines)
    frequency = [float(np.average(np.abs(f.s[f.usable]), weights=1.0 / np.maximum(f.omega_sd[f.usable], 1e-300) ** 2))
                 / (2 * np.pi) if f is not None and f.usable.any() else 0.0 for f in fits]  # the blocks' weighted mean
    mains = [_mains_harmonic(f, settings) if f > 0 else None for f in frequency]
    falls = [_fall(f) if f is not None and f.usable.any() else 0.0 for f in fits]
    # the record's beam decays: the largest fall of a line that is no mains harmonic
    beam_fall = max((fall for fall, m, f in zip(falls, mains, fits) if m is None and f is not None), default=0.0)
    for k, fit in enumerate(fits):
        if mains[k] is None or fit is None or not fit.usable.any():
            continue
        ok = fit.usable
        steady = falls[k] < settings.persistent_fall or (
            falls[k] < 0.5 and abs(float(np.median(fit.s.real[ok]))) < 3 * float(np.median(fit.sigma_sd[ok])))
        if steady and beam_fall > 2 * settings.persistent_fall:
            kinds[k] = "hum"
            notes[k] = (f"mains hum: {frequency[k]:.2f} Hz = {round(frequency[k] / mains[k])} x {mains[k]:g} Hz, its "
                        f"amplitude constant while the beam's falls by {100 * beam_fall:.0f} %")
    hum = {mains[k] for k in range(len(lines)) if kinds[k] == "hum"}
    for k, fit in enumerate(fits):
        if kinds[k] is None and mains[k] in hum:  # a decaying line on a harmonic of the hum the record holds
            kinds[k] = "mixed"
            notes[k] = (f"at {frequency[k]:.2f} Hz = {round(frequency[k] / mains[k])} x {mains[k]:g} Hz, a harmonic of the "
                        "mains hum the record holds: a mode there cannot be told from the hum")
    for k, (f, fit) in enumerate(zip(lines, fits)):
        if kinds[k] is not None or fit is None or not fit.usable.any():
            continue
        ok = fit.usable
        for j, (g, other) in enumerate(zip(lines, fits)):
            if j == k or other is None or not other.usable.any() or largest[j] <= largest[k]:
                continue
            n = round(frequency[k] / g)
            if not 2 <= n <= MAX_HARMONIC:
                continue
            # n times the other line's frequency at the same times (a nonlinear response's
            # harmonic follows its fundamental's backbone)
            there = n * np.interp(fit.centre[ok], other.centre[other.usable], np.abs(other.s[other.usable]))
            weight = 1.0 / np.maximum(fit.omega_sd[ok], 1e-300) ** 2
            off = float(np.sum(weight * (np.abs(fit.s[ok]) - there)) / np.sum(weight))
            sigma_k, sigma_j = -_summary_s(fit).real, -_summary_s(other).real
            if (abs(off) <= 3.0 / math.sqrt(float(np.sum(weight))) + settings.harmonic_tolerance * float(np.median(there))
                    and sigma_k > 1.5 * max(sigma_j, 0.0)):
                kinds[k] = "harmonic"
                notes[k] = f"harmonic {n} of the {g:.4g} Hz line (decays {sigma_k / max(sigma_j, 1e-300):.1f}x faster)"
                break
    return kinds, notes


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
