"""Every tap of a file: the plucks or taps of one record are records of one beam at several amplitudes.

A record with several hammer taps (or plucks) is split at their onsets
(:func:`beam.io.readers.signal.find_segments`); a free decay is also split where its swing
jumps in the middle of a decay (:func:`find_disturbances`: a second tap, a knock), the decay
before the jump cut one envelope block before it and the one after it kept as a tap of its own
(after the knock the beam rings freely again, from a new state). Each piece starts at its
hammer's impact when one shows (:func:`impact_start`). Each is a :class:`Tap`: its place in the
file, its peak amplitude and its own :class:`~beam.io.measurement.Measurement` (time from 0 at
its start; the calibration leaves out the impact's transient itself,
:func:`beam.calibration.free.free_response_start`). The taps of one file share the beam's
physics and differ in amplitude, initial state, offset and noise:
:func:`beam.calibration.joint.joint_calibrate` fits them together (``beam calibrate FILE`` does
so by default), and their peaks order them for reading how damping and frequency change with
amplitude.

Disturbances (:func:`find_disturbances`)
    On the envelope of :func:`~beam.io.readers.signal.find_segments` (half the range over blocks
    of two periods of the dominant frequency, at least 20 ms), after the decay's own peak (the
    loudest block within :data:`JUMP_LOOKBACK_S` of the first block above the noise level below)
    and after each jump's: a block whose level, and the next block's, is at least
    :data:`JUMP_RATIO` times the largest block of the :data:`JUMP_LOOKBACK_S` before it, and
    :data:`JUMP_NOISE_RATIO` times the record's noise sd (a robust scale of each sample's
    departure from the cubic through its neighbours, :func:`beam.io.artifacts.cubic_residual`:
    blind to the smooth swing). A free decay's envelope never rises that fast (two modes beating
    rise and fall slowly). A knock that raises the swing less, or lowers it (a tap out of phase,
    a hand), is not found.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Disturbance", "Tap", "TapPiece", "find_disturbances", "impact_start", "split_at_disturbances",
           "tap_measurements", "taps_words"]

#: A block at least this many times the largest of the blocks just before it is a jump in the swing.
JUMP_RATIO = 1.5
#: How far back the largest block is looked for (s).
JUMP_LOOKBACK_S = 0.2
#: A jump's block is at least this many times the record's noise sd.
JUMP_NOISE_RATIO = 10.0
#: Pieces shorter than this are no tap (s), as :data:`beam.io.readers.signal.MIN_SEGMENT_S`.
MIN_TAP_S = 0.5
#: A hammer's impact: the first sample off the cubic through its neighbours by this many times
#: the robust scale of the piece's lead (the first :data:`IMPACT_LEAD` of an envelope block).
IMPACT_RATIO = 10.0
#: The share of an envelope block taken as a piece's lead, before its impact.
IMPACT_LEAD = 0.4


@dataclass(frozen=True)
class Disturbance:
    """A jump of the swing in the middle of a decay.

    Attributes
    ----------
    time_s : float
        Start of the block where the swing jumps (s, the record's time).
    ratio : float
        Its level over the largest block just before it.
    cut_s : float
        Where the decay before it ends: one envelope block before the jump (s).
    """

    time_s: float
    ratio: float
    cut_s: float


@dataclass(frozen=True, eq=False)
class TapPiece:
    """One tap's samples as a reader cut them (:attr:`beam.io.readers.Record.taps`).

    Attributes
    ----------
    start_s, end_s, peak : float
        As :class:`Tap`'s.
    time_s : numpy.ndarray
        Its stamps (s, from 0 at ``start_s``).
    output : numpy.ndarray
        Its signal (SI).
    input : numpy.ndarray or None
        Its input, if the record has one.
    artifacts : beam.io.artifacts.Artifacts
        What was found in its samples.
    """

    start_s: float
    end_s: float
    peak: float
    time_s: np.ndarray
    output: np.ndarray
    input: np.ndarray | None
    artifacts: Any


@dataclass(frozen=True)
class Tap:
    """One tap (or pluck) of a file.

    Attributes
    ----------
    index : int
        1-based, in the file's order (``--segment K`` takes tap K alone).
    start_s, end_s : float
        Where it starts and ends in the file (s, from the file's first sample).
    peak : float
        Its largest envelope block (half the range, the signal's SI unit): its amplitude.
    measurement : beam.io.measurement.Measurement
        The tap as a record of its own (time from 0 at ``start_s``).
    """

    index: int
    start_s: float
    end_s: float
    peak: float
    measurement: Any


def _envelope(time_s: np.ndarray, values: np.ndarray, block_s: float) -> tuple[np.ndarray, int]:
    step = float(np.median(np.diff(time_s)))
    per_block = max(4, int(round(block_s / step)))
    count = values.size // per_block
    blocks = values[: count * per_block].reshape(count, per_block)
    return 0.5 * (blocks.max(axis=1) - blocks.min(axis=1)), per_block


def find_disturbances(time_s: np.ndarray, values: np.ndarray, block_s: float) -> list[Disturbance]:
    """Jumps of the swing after the peak of a free decay (module notes), earliest first.

    Parameters
    ----------
    time_s, values : (n,) arrays
        The decay (s, any unit).
    block_s : float
        The envelope's block (s): two periods of the dominant frequency, at least 20 ms.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(values, dtype=float)
    if y.size < 16:
        return []
    envelope, per_block = _envelope(t, y, block_s)
    count = envelope.size
    if count < 8:
        return []
    from beam.io.artifacts import cubic_residual

    residual, judged = cubic_residual(t, y)  # the noise: 1.39 sd of white noise, blind to the smooth swing
    quiet = 1.4826 * float(np.median(np.abs(residual[judged]))) / 1.39 if judged.any() else 0.0
    lookback = max(3, int(round(JUMP_LOOKBACK_S / (per_block * float(np.median(np.diff(t)))))))
    out: list[Disturbance] = []
    loud = np.flatnonzero(envelope >= JUMP_NOISE_RATIO * quiet)
    if loud.size == 0:
        return []
    first = int(loud[0])  # the decay's own peak: the loudest block within the lookback of its start
    start = first + int(np.argmax(envelope[first: first + lookback + 1]))
    k = start + 1
    while k < count - 1:
        before = float(envelope[max(start, k - lookback):k].max())
        level = min(envelope[k], envelope[k + 1])
        if before > 0 and level >= JUMP_RATIO * before and envelope[k] >= JUMP_NOISE_RATIO * quiet:
            out.append(Disturbance(float(t[k * per_block]), float(level / before), float(t[max(0, k - 1) * per_block])))
            # the new decay: its own loudest block within the lookback, then on
            stop = min(count, k + lookback + 1)
            start = k + int(np.argmax(envelope[k:stop]))
            k = start + 1
            continue
        k += 1
    return out


def impact_start(time_s: np.ndarray, values: np.ndarray, start_s: float, block_s: float) -> float:
    """Where a tap's impact starts in a piece that starts at ``start_s`` (s), one envelope block
    ``block_s`` before the block its swing rose in: the first sample within two blocks whose
    departure from the cubic through its neighbours (:func:`beam.io.artifacts.cubic_residual`,
    a hammer's impulse rings every mode) exceeds :data:`IMPACT_RATIO` times the robust scale of the
    piece's lead; ``start_s`` when there is none (a pluck let go by hand, a record too coarse to see
    the impulse).

    A tap on a beam that still rings from the last one is a free decay only from its impact on:
    the piece must not start before it (the beam at rest before a tap, the calibration leaves the
    rest out itself, :func:`beam.calibration.free.release_index`).
    """
    from beam.io.artifacts import cubic_residual

    t = np.asarray(time_s, dtype=float)
    y = np.asarray(values, dtype=float)
    window = np.flatnonzero((t >= start_s) & (t <= start_s + 2.0 * block_s))
    if window.size < 16:
        return float(start_s)
    residual, judged = cubic_residual(t[window], y[window])
    lead = (t[window] < start_s + IMPACT_LEAD * block_s) & judged
    if np.count_nonzero(lead) < 8:
        return float(start_s)
    scale = 1.4826 * float(np.median(np.abs(residual[lead])))
    if not scale > 0:
        return float(start_s)
    hits = np.flatnonzero(judged & ~lead & (np.abs(residual) > IMPACT_RATIO * scale))
    if hits.size == 0:
        return float(start_s)
    first = max(0, int(hits[0]) - 2)  # the residual leads its sample by two (the cubic's stencil)
    return float(t[window][first])


def split_at_disturbances(time_s: np.ndarray, values: np.ndarray, pieces: list[tuple[float, float, float]],
                          block_s: float) -> tuple[list[tuple[float, float, float, str]], list[str]]:
    """``pieces`` (start, end, peak) of a free decay, each split where its swing jumps (module notes).

    ``pieces`` empty means the whole record is one. Returns the pieces as (start, end, peak,
    what happened to it in words, "" when nothing did) — an empty list when there is one piece
    and nothing was cut, as :func:`~beam.io.readers.signal.find_segments` returns — and what was
    done to the record, in words.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(values, dtype=float)
    given = pieces or [(float(t[0]), float(t[-1]), float(0.5 * np.ptp(y)))]
    out: list[tuple[float, float, float, str]] = []
    notes: list[str] = []
    for start_s, end_s, peak in given:
        inside = (t >= start_s) & (t <= end_s)
        jumps = find_disturbances(t[inside], y[inside], block_s)
        if not jumps:
            out.append((start_s, end_s, peak, ""))
            continue
        said = [f"the swing jumps {j.ratio:.2g}x at {j.time_s:.3f} s (a second tap or a knock): the decay before it "
                f"is cut at {j.cut_s:.3f} s, the one after it is a tap of its own" for j in jumps]
        bounds = [start_s] + [j.time_s for j in jumps] + [end_s]
        for k, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
            first = max(start_s, a - (block_s if k > 0 else 0.0))  # from one block before the jump
            last = jumps[k].cut_s if k < len(jumps) else b
            piece = (t >= first) & (t <= last)
            if last - first < MIN_TAP_S or np.count_nonzero(piece) < 16:
                notes.append(f"{last - first:.3g} s between {first:.3f} and {last:.3f} s dropped: too short to be a tap")
                continue
            own = "; ".join(said[j] for j in (k - 1, k) if 0 <= j < len(jumps))  # the jumps that bound this piece
            out.append((float(first), float(last), float(0.5 * np.ptp(y[piece])), own))
        notes += said
    cut = any(note for *_, note in out) or len(out) != len(given)
    return (out if len(out) >= 2 or cut else []), notes


def tap_measurements(measurement) -> list:
    """The measurements of a record's taps (:attr:`beam.io.measurement.Measurement.taps`), in the
    file's order; ``[measurement]`` for a record of one tap."""
    taps = getattr(measurement, "taps", ())
    return [tap.measurement for tap in taps] if taps else [measurement]


def taps_words(measurement, diagnosis: bool = False) -> str | None:
    """One sentence: how many taps a record holds and how a command uses them (None for one tap).

    ``diagnosis``: the words of ``beam diagnose``, which reads the strongest tap (a joint diagnosis
    of every tap ranks each candidate on every record: tens of minutes for six taps).
    """
    taps = getattr(measurement, "taps", ())
    if len(taps) < 2:
        return None
    from beam.io.artifacts import amount_text

    peaks = ", ".join(amount_text(tap.peak, measurement.output_unit) for tap in taps)
    ratio = max(t.peak for t in taps) / max(min(t.peak for t in taps), 1e-300)
    span = f"{ratio:.2g}x apart" if math.isfinite(ratio) else "far apart"
    found = f"{len(taps)} taps found (peaks {peaks}, {span}): one beam at {len(taps)} amplitudes"
    if diagnosis:
        kept = next((tap.index for tap in taps if tap.measurement.name == measurement.name), taps[0].index)
        return (f"{found}; diagnosed on tap {kept}, the strongest (beam calibrate calibrates every tap together; "
                "--segment K diagnoses tap K)")
    return (f"{found}, calibrated together (shared physics; each tap its own initial state, offset and noise); "
            "--segment K takes tap K alone")
