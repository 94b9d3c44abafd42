"""The artifacts real labs record, found from the record itself: mains hum, spikes, ADC rail values.

Every record read goes through :func:`clean` once: a reader's record and each of its taps
(:func:`beam.io.readers.signal.build_record`), the project's own ``NAME.csv``
(:func:`beam.io.measurement.read_measurement`). The file's signal stays as it is on the
:class:`~beam.io.readers.Record`; the :class:`~beam.io.measurement.Measurement` made of it is
cleaned (:meth:`Artifacts.apply`) and carries what was found (``artifacts``), said in words
(:meth:`Artifacts.sentences`) in the import's summary and in the calibration's warnings
(:func:`record_warnings`).

Mains hum (:func:`find_hum`)
    Pick-up of the mains at 50 or 60 Hz and its harmonics (a rectifier's odd ones: 180, 300,
    420, 660 Hz ...). It is recognised from the record, never by frequency alone (a beam mode may
    sit at 60 Hz). A candidate is the highest point of the whole record's Hann periodogram within
    :data:`MAINS_TOLERANCE` of k x 50 or k x 60 Hz that noise would reach with chance
    :data:`CANDIDATE_FALSE_ALARM` only. It is measured in :data:`HUM_BLOCKS` consecutive stretches
    (a Hann-weighted tone at its frequency, refined on the whole record), each beside the tones 3
    to 6 of the stretch's bins away (noise, leakage, a tap's broadband burst). It is a constant
    line when it stands :data:`LINE_CONTRAST` x out of them in at least three stretches, is
    :data:`HUM_SNR` x their median there, and stays there within :data:`HUM_SPREAD` of its mean
    (plus four backgrounds; no other stretch above that). The lines of one family are hum when
    the record's swing varies meanwhile (its RMS over the stretches by :data:`BEAM_VARIATION` x or
    more: the beam decays, or is tapped, while the lines do not) or when at least two lines (k f0
    within a bin 1/T of one f0) are so constant. A line that a driven record's input holds too
    is the drive's, not hum. The lines are **subtracted** (a Hann-weighted least-squares fit of
    constant sinusoids at their frequencies over the whole record), not notched: a subtraction
    removes the stationary line only, where a notch also bites into the decay and rings at the
    record's ends (the measured comparison: the design decisions page). A line within a stretch's
    resolution of a decaying mode is not constant in any stretch, and stays.
Spikes (:func:`find_spikes`)
    Single-sample glitches and short transients (at most :data:`MAX_SPIKE_SAMPLES` samples) that
    stand out of the signal's own smoothness: each sample is compared with the cubic through its
    two neighbours on each side (at their own stamps: exact for a cubic whatever the spacing;
    the fourth difference / 6 on a uniform grid), against a robust scale of that difference
    (1.4826 x the median absolute value over blocks of :data:`SCALE_BLOCK_SAMPLES`, the largest
    of a block and its two neighbours). Each neighbourhood of samples more than
    :data:`SPIKE_SIGMAS` scales away is explained by the shortest run of at most
    :data:`MAX_SPIKE_SAMPLES` samples whose replacement by the cubic clears it; a neighbourhood no
    such run explains is an event (a release, a tap), not a spike, and is left alone. Samples
    whose neighbours spread over more than :data:`MAX_NEIGHBOUR_STEPS` median steps (a logger's
    stall) are not judged. Spikes are left out of the likelihood
    (:attr:`beam.io.measurement.Measurement.left_out`), as clipped samples are; their values are
    replaced by the cubic so that spectra and modal identification do not see them.
ADC rail values (:func:`rail_samples`)
    A saturated converter returns its full-scale code. Samples exactly at the record's largest
    (or smallest) value are rail values when that value is reached in at least two separate
    places and, at one of them at least, the cubic through the neighbours goes beyond it by more
    than :data:`RAIL_SIGMAS` scales (the signal's own curvature says it went further than the
    converter could say). They are left out of the likelihood, values kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

__all__ = [
    "Artifacts", "Hum", "HumLine", "amount_text", "clean", "cubic_residual", "find_hum", "find_spikes", "rail_samples",
    "record_warnings",
]

#: Mains frequencies (Hz).
MAINS_HZ = (50.0, 60.0)
#: A line within this fraction of k x mains is a hum candidate (grids hold ±0.2 %; a logger's
#: clock adds its own error to every frequency it reports).
MAINS_TOLERANCE = 0.01
#: Stretches a line's amplitude is measured in (fewer, down to 3, on a short record).
HUM_BLOCKS = 6
#: Fewest cycles of the mains frequency in one stretch.
HUM_MIN_CYCLES = 10.0
#: A constant line's stretches stay within this fraction of their mean (plus four noise standard errors).
HUM_SPREAD = 0.2
#: A hum line's mean amplitude is at least this many times the median of the tones beside it (in
#: the stretches that judge it).
HUM_SNR = 5.0
#: A stretch judges a line where the line is at least this many times the tones beside it (and the noise).
LINE_CONTRAST = 3.0
#: The record's RMS over the stretches varies at least by this factor when the beam decays or is tapped.
BEAM_VARIATION = 2.0
#: Highest harmonic searched.
MAX_HARMONIC = 40

#: A sample this many robust scales away from the cubic through its neighbours is a spike.
SPIKE_SIGMAS = 8.0
#: A spike smaller than this fraction of the record's largest |value| is left alone: it changes no fit
#: (-80 dB of the swing, below any sensor's noise), while on a noiseless record (a simulation, a
#: decimated one) the fourth difference's own scale is the signal's curvature, and a filter's
#: edge or a sharp turn would otherwise stand 8 scales out.
SMALLEST_SPIKE = 1e-4
#: A spike is at most this many samples long (more is an event: a release, a tap).
MAX_SPIKE_SAMPLES = 3
#: Samples of a block of the robust scale.
SCALE_BLOCK_SAMPLES = 128
#: Samples whose four neighbours span more than this many median steps are not judged (uniform: 4).
MAX_NEIGHBOUR_STEPS = 6.0
#: Passes of the spike search.
SPIKE_PASSES = 4
#: A rail value's neighbours put the signal beyond it by at least this many robust scales.
RAIL_SIGMAS = 3.0


@dataclass(frozen=True)
class HumLine:
    """One line of mains hum.

    Attributes
    ----------
    frequency_Hz : float
        Refined on the whole record (Hz).
    harmonic : int
        k of k x the fundamental.
    amplitude : float
        Amplitude of the fitted sinusoid (the signal's SI unit).
    phase_rad : float
        Its phase at t = 0: the line is amplitude cos(2 pi f t + phase).
    spread : float
        (largest - smallest) / mean of its amplitude over the stretches.
    """

    frequency_Hz: float
    harmonic: int
    amplitude: float
    phase_rad: float
    spread: float


@dataclass(frozen=True)
class Hum:
    """Mains hum found in a record (:func:`find_hum`).

    Attributes
    ----------
    mains_Hz : float
        50 or 60.
    fundamental_Hz : float
        The family's fundamental, from its lines (Hz).
    lines : tuple of HumLine
        The lines found, lowest first.
    beam_variation : float
        Largest / smallest RMS of the record over the stretches (the beam's swing varying
        while the lines stay; NaN when not measured).
    """

    mains_Hz: float
    fundamental_Hz: float
    lines: tuple[HumLine, ...]
    beam_variation: float

    def evaluate(self, time_s: np.ndarray) -> np.ndarray:
        """The lines' sum at ``time_s`` (s), in the signal's unit."""
        t = np.asarray(time_s, dtype=float)
        out = np.zeros_like(t)
        for line in self.lines:
            out += line.amplitude * np.cos(2 * np.pi * line.frequency_Hz * t + line.phase_rad)
        return out

    @property
    def frequencies_Hz(self) -> tuple[float, ...]:
        return tuple(line.frequency_Hz for line in self.lines)

    def words(self, unit: str = "") -> str:
        """One sentence: which lines, how constant (the strongest line's spread), what was done."""
        lines = ", ".join(f"{line.frequency_Hz:.5g} Hz ({amount_text(line.amplitude, unit)})" for line in self.lines)
        spread = max(self.lines, key=lambda line: line.amplitude).spread
        why = (f"while the record's swing varies {self.beam_variation:.3g}-fold"
               if np.isfinite(self.beam_variation) and self.beam_variation >= BEAM_VARIATION else
               f"as a family of harmonics of {self.fundamental_Hz:.5g} Hz")
        return (f"mains hum ({self.mains_Hz:g} Hz) removed: {len(self.lines)} line(s) at {lines}, of constant "
                f"amplitude (the strongest within {100 * spread:.0f} % over the record) {why}; subtracted as fitted "
                "sinusoids, not taken for modes")


@dataclass(frozen=True, eq=False)
class Artifacts:
    """What :func:`clean` found in a record.

    Attributes
    ----------
    hum : Hum or None
        Mains hum subtracted from the signal.
    spikes : numpy.ndarray of bool
        Samples flagged as spikes (their values replaced by the cubic through their neighbours).
    rail : numpy.ndarray of bool
        Samples at the converter's rail (values kept).
    notes : tuple of str
        Other things said (a disturbance cut, a tap's own).
    """

    hum: Hum | None
    spikes: np.ndarray = field(repr=False)
    rail: np.ndarray = field(repr=False)
    spike_values: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    notes: tuple[str, ...] = ()
    #: The stamps (s) the masks index (None: the record's own).
    time_s: np.ndarray | None = field(default=None, repr=False)
    #: (spikes, rail values) found on the record as read (a decimation may merge two into one sample).
    found: tuple[int, int] | None = None

    @classmethod
    def none(cls, size: int) -> Artifacts:
        """Nothing found, for a record of ``size`` samples."""
        return cls(None, np.zeros(size, dtype=bool), np.zeros(size, dtype=bool))

    def on(self, time_s: np.ndarray) -> Artifacts:
        """The same findings on other stamps of the same record (a decimation, a crop): a new
        sample is flagged when a flagged sample lies within half its median step of it (spike
        values dropped: they were applied to the samples the new ones come from)."""
        new = np.asarray(time_s, dtype=float)
        if self.time_s is None:
            raise ValueError("these artifacts do not know their stamps")
        if new.shape == self.time_s.shape and np.array_equal(new, self.time_s):
            return self
        half = 0.5 * float(np.median(np.diff(new))) if new.size > 1 else 0.0

        def mapped(mask: np.ndarray) -> np.ndarray:
            out = np.zeros(new.size, dtype=bool)
            at = self.time_s[mask]
            if at.size and new.size:
                index = np.clip(np.searchsorted(new, at), 1, new.size - 1) if new.size > 1 else np.zeros(at.size, int)
                left, right = new[index - 1] if new.size > 1 else new[index], new[index]
                nearest = np.where(np.abs(at - left) <= np.abs(right - at), index - 1 if new.size > 1 else index, index)
                close = np.abs(new[nearest] - at) <= half
                out[nearest[close]] = True
            return out

        return replace(self, spikes=mapped(self.spikes), rail=mapped(self.rail), spike_values=np.zeros(0), time_s=new,
                       found=(self.spike_count, self.rail_count))

    def apply(self, time_s: np.ndarray, output: np.ndarray) -> np.ndarray:
        """The record's signal cleaned: spike samples replaced by their interpolation
        (:attr:`spike_values`), the hum's lines subtracted (``time_s`` on the time base they were found on)."""
        cleaned = np.array(output, dtype=float)
        cleaned[self.spikes] = self.spike_values
        if self.hum is not None:
            cleaned -= self.hum.evaluate(time_s)
        return cleaned

    @property
    def flagged(self) -> np.ndarray:
        """Samples left out of the likelihood: spikes and rail values."""
        return self.spikes | self.rail

    @property
    def spike_count(self) -> int:
        """Spike samples found on the record as read."""
        return self.found[0] if self.found is not None else int(np.count_nonzero(self.spikes))

    @property
    def rail_count(self) -> int:
        """Rail samples found on the record as read."""
        return self.found[1] if self.found is not None else int(np.count_nonzero(self.rail))

    def with_note(self, note: str) -> Artifacts:
        return replace(self, notes=(*self.notes, note))

    def sentences(self, unit: str = "") -> list[str]:
        """Everything found, in words, one sentence each (empty when nothing was)."""
        out = []
        if self.hum is not None:
            out.append(self.hum.words(unit))
        if self.spike_count:
            out.append(f"{self.spike_count} spike sample(s) (a glitch, a stale or late-stamped reading: more than "
                       f"{SPIKE_SIGMAS:g}x the signal's own roughness off the cubic through their neighbours) left out "
                       "of the likelihood, their values interpolated")
        if self.rail_count:
            out.append(f"{self.rail_count} sample(s) at the converter's rail (the record's extreme value, reached "
                       "where the signal's curvature goes beyond it) left out of the likelihood")
        return out + list(self.notes)


def amount_text(value: float, unit: str) -> str:
    """A signal's amount with its unit for a sentence: a strain (unit ``"1"``) in µε, another in its SI unit."""
    if unit == "1":
        return f"{1e6 * value:.3g} µε"
    return f"{value:.3g}" + (f" {unit}" if unit else "")


# ---------------------------------------------------------------------------------------------
# spikes and rails
# ---------------------------------------------------------------------------------------------


def cubic_residual(time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each sample minus the cubic through its two neighbours on each side, and which samples are judged.

    Lagrange weights at the samples' own stamps (on a uniform grid: (-1, 4, 4, -1) / 6, so the
    residual is the fourth difference / 6: 1.39 sd of white noise, 1.6e-3 of a sinusoid's
    amplitude at 20 samples a cycle). The first and last two samples, and those whose four
    neighbours span more than :data:`MAX_NEIGHBOUR_STEPS` median steps, are not judged (residual 0).
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(values, dtype=float)
    n = y.size
    residual = np.zeros(n)
    judged = np.zeros(n, dtype=bool)
    if n < 5:
        return residual, judged
    k = np.arange(2, n - 2)
    nodes = np.stack([k - 2, k - 1, k + 1, k + 2])
    tn = t[nodes]
    prediction = np.zeros(k.size)
    for j in range(4):
        weight = np.ones(k.size)
        for m in range(4):
            if m != j:
                weight *= (t[k] - tn[m]) / (tn[j] - tn[m])
        prediction += weight * y[nodes[j]]
    residual[k] = y[k] - prediction
    step = float(np.median(np.diff(t)))
    judged[k] = (tn[3] - tn[0]) <= MAX_NEIGHBOUR_STEPS * step
    residual[~judged] = 0.0
    return residual, judged


def _robust_scale(residual: np.ndarray, judged: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Per-sample robust scale of ``residual`` (module notes), floored at the record's quantum."""
    n = residual.size
    blocks = max(1, n // SCALE_BLOCK_SAMPLES)
    edges = np.linspace(0, n, blocks + 1).astype(int)
    scale = np.empty(blocks)
    for b in range(blocks):
        r = np.abs(residual[edges[b]:edges[b + 1]][judged[edges[b]:edges[b + 1]]])
        scale[b] = 1.4826 * float(np.median(r)) if r.size else np.inf
    finite = np.isfinite(scale)
    if not finite.any():
        return np.full(n, np.inf)
    scale[~finite] = np.max(scale[finite])
    wide = np.maximum(scale, np.maximum(np.r_[scale[:1], scale[:-1]], np.r_[scale[1:], scale[-1:]]))
    levels = np.unique(values)
    quantum = float(np.min(np.diff(levels))) if levels.size > 1 else 0.0
    peak = float(np.max(np.abs(values))) if values.size else 0.0
    floor = max(quantum / 6.0, SMALLEST_SPIKE * peak / SPIKE_SIGMAS, np.finfo(float).tiny)
    return np.repeat(np.maximum(wide, floor), np.diff(edges))


def find_spikes(time_s: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Spike samples (module notes) and the values with them replaced by the cubic through their neighbours.

    Each neighbourhood of samples beyond :data:`SPIKE_SIGMAS` scales is explained by the shortest
    run of at most :data:`MAX_SPIKE_SAMPLES` samples whose replacement (the cubic through the two
    samples on each side of the run) brings every sample of the neighbourhood back within the
    threshold (a two-sample glitch puts its largest residuals on its neighbours, -1/2 of it,
    against 1/3 on itself); a neighbourhood no such run explains is an event, left alone.

    Returns
    -------
    spikes : (n,) bool array
    repaired : (n,) float array
        ``values`` with every spike sample replaced.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.array(values, dtype=float)
    n = y.size
    spikes = np.zeros(n, dtype=bool)
    if n < 2 * SCALE_BLOCK_SAMPLES:
        return spikes, y
    residual, judged = cubic_residual(t, y)
    scale = _robust_scale(residual, judged, y)
    events = np.zeros(n, dtype=bool)
    for _ in range(SPIKE_PASSES):
        over = np.flatnonzero(judged & (np.abs(residual) > SPIKE_SIGMAS * scale) & ~events)
        if over.size == 0:
            break
        for cluster in np.split(over, np.flatnonzero(np.diff(over) > 4) + 1):
            lo, hi = int(cluster[0]), int(cluster[-1])
            run = _spike_run(t, y, scale, lo, hi) if hi - lo <= MAX_SPIKE_SAMPLES + 3 else None
            if run is None:
                events[max(0, lo - 2): hi + 3] = True
                continue
            start, stop, repaired = run
            y[start:stop] = repaired
            spikes[start:stop] = True
        residual, judged = cubic_residual(t, y)
    return spikes, y


def _spike_run(t: np.ndarray, y: np.ndarray, scale: np.ndarray, lo: int, hi: int):
    """(start, stop, replacement) of the shortest run near samples lo..hi whose replacement by the
    cubic through the two samples on each side leaves no residual beyond the threshold; None if none does."""
    n = y.size
    a, b = max(0, lo - 6), min(n, hi + 7)
    best = None
    for length in range(1, MAX_SPIKE_SAMPLES + 1):
        for start in range(max(2, lo - 2), min(n - 2 - length, hi + 2) + 1):
            stop = start + length
            nodes = np.array([start - 2, start - 1, stop, stop + 1])
            if nodes[-1] >= n:
                continue
            trial = y[a:b].copy()
            for i in range(start, stop):
                trial[i - a] = _through(t, y, nodes, float(t[i]))
            residual, judged = cubic_residual(t[a:b], trial)
            worst = float(np.max(np.where(judged, np.abs(residual) / scale[a:b], 0.0)))
            if worst <= SPIKE_SIGMAS and (best is None or worst < best[0]):
                best = (worst, start, stop, trial[start - a: stop - a].copy())
        if best is not None:
            return best[1:]
    return None


def rail_samples(time_s: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Samples at the converter's rail (module notes), a bool mask."""
    y = np.asarray(values, dtype=float)
    n = y.size
    rail = np.zeros(n, dtype=bool)
    if n < 2 * SCALE_BLOCK_SAMPLES or float(np.ptp(y)) == 0:
        return rail
    t = np.asarray(time_s, dtype=float)
    for extreme, sign in ((float(y.max()), 1.0), (float(y.min()), -1.0)):
        at = np.flatnonzero(y == extreme)
        if at.size < 2 or np.all(np.diff(at) == 1):
            continue  # reached once (one run): the peak of a swing, or a run clipped_samples judges
        beyond = _beyond(t, y, at, sign)
        if beyond is not None and np.any(beyond > RAIL_SIGMAS):
            rail[at] = True
    return rail


def _through(t: np.ndarray, y: np.ndarray, nodes: np.ndarray, at_s: float) -> float:
    """The cubic (Lagrange) through the samples ``nodes`` at time ``at_s``."""
    weights = [np.prod([(at_s - t[m]) / (t[j] - t[m]) for m in nodes if m != j]) for j in nodes]
    return float(np.dot(weights, y[nodes]))


def _beyond(t: np.ndarray, y: np.ndarray, at: np.ndarray, sign: float) -> np.ndarray | None:
    """How far (robust scales) the cubic through the neighbours outside each run at the extreme goes beyond it."""
    residual, judged = cubic_residual(t, y)
    scale = _robust_scale(residual, judged, y)
    runs = np.split(at, np.flatnonzero(np.diff(at) > 1) + 1)
    out = []
    for run in runs:
        first, last = int(run[0]), int(run[-1])
        if first < 2 or last > y.size - 3:
            continue
        before, after = [first - 2, first - 1], [last + 1, last + 2]
        nodes = np.array(before + after)
        predicted = _through(t, y, nodes, 0.5 * (t[first] + t[last]))
        out.append(sign * (predicted - y[first]) / float(scale[first]))
    return np.array(out) if out else None


# ---------------------------------------------------------------------------------------------
# mains hum
# ---------------------------------------------------------------------------------------------


def _tone(t: np.ndarray, y: np.ndarray, frequency_Hz: float) -> complex:
    """Hann-weighted complex amplitude of a tone at ``frequency_Hz`` over samples (t, y): for
    y = a cos(2 pi f t + phi) it is about a e^{i phi}."""
    span = float(t[-1] - t[0])
    weight = np.sin(np.pi * (t - t[0]) / span) ** 2 if span > 0 else np.ones_like(t)
    centred = y - np.sum(weight * y) / np.sum(weight)
    return complex(2.0 * np.sum(weight * centred * np.exp(-2j * np.pi * frequency_Hz * t)) / np.sum(weight))


def _refine(t: np.ndarray, y: np.ndarray, guess_Hz: float, half_width_Hz: float) -> float:
    """The frequency near ``guess_Hz`` (within ``half_width_Hz``) of the largest Hann-weighted tone."""
    from scipy.optimize import minimize_scalar

    span = float(t[-1] - t[0])
    found = minimize_scalar(lambda f: -abs(_tone(t, y, f)), bounds=(guess_Hz - half_width_Hz, guess_Hz + half_width_Hz),
                            method="bounded", options={"xatol": 1e-5 / span})
    return float(found.x)


@dataclass
class _Line:
    frequency_Hz: float
    mains: float
    harmonic: int
    blocks: np.ndarray      # the tone's amplitude in each stretch
    background: np.ndarray  # the tones beside it in each stretch (median of 3 to 6 bins away): noise and leakage

    @property
    def judged(self) -> np.ndarray:
        """Stretches where the line stands out of what is beside it (a tap's broadband burst does not let it)."""
        return self.blocks >= LINE_CONTRAST * self.background

    @property
    def mean(self) -> float:
        judged = self.judged
        return float(np.mean(self.blocks[judged])) if judged.any() else 0.0

    @property
    def spread(self) -> float:
        judged = self.blocks[self.judged]
        return float((judged.max() - judged.min()) / max(self.mean, 1e-300)) if judged.size else math.inf

    @property
    def constant(self) -> bool:
        judged, mean = self.judged, self.mean
        if np.count_nonzero(judged) < 3 or mean < HUM_SNR * float(np.median(self.background[judged])):
            return False
        allowed = HUM_SPREAD * mean + 4.0 * self.background
        return bool(np.all(np.abs(self.blocks[judged] - mean) <= allowed[judged])
                    and np.all(self.blocks[~judged] <= mean + allowed[~judged]))


def _stretches(t: np.ndarray, count: int) -> list[slice]:
    edges = np.searchsorted(t, np.linspace(t[0], t[-1], count + 1))
    edges[-1] = t.size
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


def find_hum(time_s: np.ndarray, values: np.ndarray, input_values: np.ndarray | None = None) -> Hum | None:
    """Mains hum in a record (module notes), None when there is none (or the record is too short to tell).

    Parameters
    ----------
    time_s : (n,) array
        Increasing stamps (s), uniform or not.
    values : (n,) array
        The signal (any unit).
    input_values : (n,) array, optional
        A driven record's input: a line it holds too is the drive's, not hum.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(values, dtype=float)
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    count = int(min(HUM_BLOCKS, math.floor(span * min(MAINS_HZ) / HUM_MIN_CYCLES))) if span > 0 else 0
    if t.size < MIN_HUM_SAMPLES or count < 3:
        return None
    frequency, power = _periodogram(t, y)
    stretches = _stretches(t, count)
    rms = np.array([float(np.std(y[s])) for s in stretches])
    variation = float(rms.max() / rms.min()) if rms.min() > 0 else math.inf
    top = min(float(frequency[-1]) * 0.9, MAX_HARMONIC * max(MAINS_HZ) * (1 + MAINS_TOLERANCE))
    families = []
    for mains in MAINS_HZ:
        lines: list[_Line] = []
        for k in range(1, MAX_HARMONIC + 1):
            centre = k * mains
            if centre * (1 + MAINS_TOLERANCE) > top:
                break
            guess = _candidate(frequency, power, centre, span)
            if guess is None:
                continue
            line = _Line(guess, mains, k, *_block_amplitudes(t, y, stretches, guess))
            if not line.constant:  # screened at the periodogram's frequency, refined only when it passes
                continue
            f = _refine(t, y, guess, 1.0 / span)
            lines.append(_Line(f, mains, k, *_block_amplitudes(t, y, stretches, f)))
        constant = [line for line in lines if line.constant and not _in_input(t, input_values, line)]
        if not constant:
            continue
        fundamental = float(np.median([line.frequency_Hz / line.harmonic for line in constant]))
        family = [line for line in constant if abs(line.frequency_Hz - line.harmonic * fundamental) <= 1.0 / span]
        if family and (variation >= BEAM_VARIATION or len(family) >= 2):
            families.append((sum(line.mean**2 for line in family), mains, fundamental, family))
    if not families:
        return None
    _, mains, fundamental, family = max(families, key=lambda item: item[0])
    amplitudes = _fit_lines(t, y, [line.frequency_Hz for line in family])
    lines = tuple(HumLine(line.frequency_Hz, line.harmonic, float(abs(a)), float(np.angle(a)), line.spread)
                  for line, a in zip(family, amplitudes))
    return Hum(mains, fundamental, lines, variation)


#: Fewest samples searched for hum.
MIN_HUM_SAMPLES = 256
#: Chance that noise alone makes a candidate of one window (the periodogram of noise is
#: exponentially distributed: its highest of N bins passes c x their median with chance N 2^-c).
CANDIDATE_FALSE_ALARM = 1e-3
#: The periodogram's zero padding (its grid is 1 / (4 T)).
PERIODOGRAM_PADDING = 4


def _periodogram(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hann-windowed periodogram of the whole record on a uniform grid at its median step (linear
    interpolation: only to locate candidate lines, measured then at the record's own stamps),
    zero-padded :data:`PERIODOGRAM_PADDING` x. A full-record periodogram, not Welch's average: a
    line gathers its power into one bin of 1 / T while a tap's broadband burst spreads over all."""
    step = float(np.median(np.diff(t)))
    count = int(math.floor((t[-1] - t[0]) / step)) + 1
    grid = t[0] + np.arange(count) * step
    signal = np.interp(grid, t, y)
    signal = (signal - signal.mean()) * np.hanning(signal.size)
    size = PERIODOGRAM_PADDING * signal.size
    return np.fft.rfftfreq(size, step), np.abs(np.fft.rfft(signal, size)) ** 2


def _candidate(frequency: np.ndarray, power: np.ndarray, centre: float, span: float) -> float | None:
    """The periodogram's highest point within :data:`MAINS_TOLERANCE` of ``centre`` (Hz), when it stands
    above the median 10 to 50 bins (1 / T) beside it more than noise would in that window but with
    chance :data:`CANDIDATE_FALSE_ALARM`; None otherwise."""
    window = np.flatnonzero(np.abs(frequency - centre) <= MAINS_TOLERANCE * centre)
    if window.size == 0:
        return None
    i = int(window[np.argmax(power[window])])
    distance = np.abs(frequency - frequency[i]) * span
    beside = (distance >= 10) & (distance <= 50)
    contrast = math.log2(max(window.size / PERIODOGRAM_PADDING, 1.0) / CANDIDATE_FALSE_ALARM)
    if not beside.any() or power[i] < contrast * float(np.median(power[beside])):
        return None
    return float(frequency[i])


def _block_amplitudes(t: np.ndarray, y: np.ndarray, stretches: list[slice], frequency_Hz: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The tone at ``frequency_Hz`` in each stretch, and the median of the tones 3 to 6 of the
    stretch's bins (1 / its duration) on either side (outside a Hann tone's main lobe)."""
    tones, beside = [], []
    for s in stretches:
        bin_Hz = 1.0 / max(float(t[s][-1] - t[s][0]), 1e-300)
        tones.append(abs(_tone(t[s], y[s], frequency_Hz)))
        beside.append(float(np.median([abs(_tone(t[s], y[s], frequency_Hz + sign * k * bin_Hz))
                                       for sign in (-1, 1) for k in (3, 4, 5, 6)])))
    return np.array(tones), np.array(beside)


def _in_input(t: np.ndarray, input_values: np.ndarray | None, line: _Line) -> bool:
    """Whether a driven record's input holds the line too (a tone there above a tenth of the input's RMS / its noise)."""
    if input_values is None:
        return False
    u = np.asarray(input_values, dtype=float)
    if not np.any(u != u[0]):
        return False
    tone = abs(_tone(t, u, line.frequency_Hz))
    return tone >= 0.1 * float(np.std(u)) or tone >= HUM_SNR * float(np.std(u)) * math.sqrt(3.0 / u.size)


def _fit_lines(t: np.ndarray, y: np.ndarray, frequencies: list[float]) -> np.ndarray:
    """Complex amplitudes a_k of y ~ c + sum Re(a_k e^{i 2 pi f_k t}) by least squares over the record,
    weighted by a Hann window over it: the beam's content (a decay starting at full swing is
    broadband) leaks into an unweighted fit at a few percent of a line's amplitude, into the
    weighted one below 1e-4 (measured on a simulated strip: the design decisions page)."""
    span = float(t[-1] - t[0])
    weight = np.sqrt(np.sin(np.pi * (t - t[0]) / span) ** 2) if span > 0 else np.ones_like(t)
    columns = [np.ones_like(t)]
    for f in frequencies:
        columns += [np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)]
    design = np.column_stack(columns)
    coefficients = np.linalg.lstsq(design * weight[:, None], y * weight, rcond=None)[0]
    cos, sin = coefficients[1::2], coefficients[2::2]
    return cos - 1j * sin


# ---------------------------------------------------------------------------------------------
# all of them
# ---------------------------------------------------------------------------------------------


def clean(time_s: np.ndarray, output: np.ndarray, input_values: np.ndarray | None = None
          ) -> tuple[np.ndarray, Artifacts]:
    """The record's signal with mains hum subtracted and spikes interpolated, and what was found.

    Parameters
    ----------
    time_s : (n,) array
        Strictly increasing stamps (s).
    output : (n,) array
        The signal (SI).
    input_values : (n,) array, optional
        A driven record's input.

    Returns
    -------
    cleaned : (n,) array
        The signal, hum subtracted (:func:`find_hum`) and spike samples replaced (:func:`find_spikes`).
    artifacts : Artifacts
        The hum, the spike and rail masks (module notes); ``artifacts.apply(time_s, output)`` is ``cleaned``.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(output, dtype=float)
    rail = rail_samples(t, y)
    spikes, repaired = find_spikes(t, y)
    spikes &= ~rail
    repaired = np.where(rail, y, repaired)
    hum = find_hum(t, repaired, input_values)
    artifacts = Artifacts(hum, spikes, rail, repaired[spikes], time_s=t)
    return artifacts.apply(t, y), artifacts


def record_warnings(measurement) -> list[str]:
    """What the reading found in a measurement's samples (:attr:`Artifacts.sentences`), as a
    calibration's warnings say it; empty for a measurement made in code or found clean."""
    artifacts = getattr(measurement, "artifacts", None)
    return [] if artifacts is None else artifacts.sentences(measurement.output_unit)
