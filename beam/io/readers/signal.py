"""From a file's columns to one record: SI units, time, the signal, clean stamps, the pluck.

The steps, the same for every format:

0. *Record.* A file holding several records (the structs of a MATLAB file, the groups of an
   HDF5 file, arrays of different lengths: :attr:`Block.kind` ``"record"``) uses ``record=``
   (``--record NAME|INDEX``) or the longest (the first of equal length); all are listed.
1. *Block.* A file with several blocks (LVM segments, TDMS groups) uses ``--segment K`` or
   the block whose signal has the most vibration power; the others are listed.
2. *Time.* The time column (its unit from its name, or ``--time-unit``), else the file's rate,
   else ``--rate``; a file with neither is refused with the flag to give. Time is shifted to
   start at 0 (phones and loggers stamp with clocks); a column of whole numbers stepping by
   >= 1 with no unit is refused unless ``--time-unit`` says ms or us (Arduino's ``micros()``),
   and so is one without a unit that, read as seconds, gives fewer than
   :data:`MIN_ASSUMED_RATE_HZ` samples per second (milliseconds); otherwise a time column
   without a unit is read as seconds, and the finding says so.
3. *Signal.* ``--column NAME|INDEX`` (INDEX counts the file's columns from 1), else ``--axis``,
   else, among the columns measuring motion (acceleration, velocity, displacement; a magnitude
   such as phyphox's "Absolute acceleration" only when asked for), the one with the most
   *vibration power*: the Welch power spectral density integrated above
   :data:`VIBRATION_LOW_HZ` or 4/duration, whichever is higher (gravity, a tilt and a slow
   drift are not vibration). Columns of different quantities are not compared: the choice
   must then be given. A voltage or force column beside the signal is the record's input.
   Units become SI; gravity and the sensor's bias stay in the signal (the calibration's offset
   parameter takes them). A signal in arbitrary units (``--unit arbitrary``, a column named
   in counts) keeps its values and marks the record (:attr:`Record.arbitrary_units`).
4. *Stamps.* Samples whose stamp repeats or goes back (phone apps do both) are dropped, keeping
   the first of each stamp and a strictly increasing time; what was dropped is reported.
   Rows with a missing value in the time or the signal are dropped too.
5. *Plucks.* The signal's envelope (half its range over blocks of two periods of its dominant
   frequency, at least :data:`ENVELOPE_BLOCK_S`: shorter blocks follow the oscillation itself)
   is searched for onsets: a block at least :data:`ONSET_RATIO` times the quietest of the blocks before
   it (over :data:`ONSET_LOOKBACK_S`), staying so in the next block, above
   :data:`ONSET_NOISE_RATIO` times the record's quiet level and
   :data:`ONSET_PEAK_FRACTION` of the loudest block. With two or more onsets the record is
   split at them, and a free decay also where its swing jumps in the middle of a decay
   (:func:`beam.io.taps.split_at_disturbances`); the segment with the loudest block (or
   ``--segment K``) is kept from one block before its onset, every segment is listed and each
   is kept as a tap of its own (:attr:`Record.taps`).
6. *Artifacts.* Mains hum, spikes and ADC rail values are searched in the samples kept and in
   each tap (:func:`beam.io.artifacts.clean`: :attr:`Record.artifacts`); the signal stays as the
   file holds it, the measurement made of it is cleaned
   (:func:`beam.io.measurement.measurement_from_record`).

Every decision is a :class:`beam.io.readers.findings.Finding` (:attr:`Record.findings`), every
refusal a :class:`beam.io.readers.findings.ReadingError` naming the option that resolves it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import welch

from beam.errors import BeamInputError
from beam.io.artifacts import Artifacts, clean
from beam.io.readers.findings import COMMAND_LINE, Finding, Hint, ReadingError
from beam.io.readers.table import Block, Column, RawRecord
from beam.io.readers.units import (
    ARBITRARY,
    INPUT_COLUMN_OF,
    OUTPUT_COLUMN_OF,
    SIGNAL_UNITS,
    ColumnMeaning,
    arbitrary_spelling,
    column_meaning,
    display_unit,
    is_known_unit,
    normalise_unit,
)
from beam.io.taps import TapPiece, impact_start, split_at_disturbances

#: Lowest frequency counted as vibration (Hz).
VIBRATION_LOW_HZ = 1.0
#: Shortest envelope block (s).
ENVELOPE_BLOCK_S = 0.02
#: An onset is a block this many times the quietest block before it.
ONSET_RATIO = 4.0
#: How far back the quietest block is looked for (s).
ONSET_LOOKBACK_S = 0.2
#: An onset's block is at least this many times the record's quiet level (10th percentile of blocks).
ONSET_NOISE_RATIO = 10.0
#: An onset's block is at least this fraction of the loudest block.
ONSET_PEAK_FRACTION = 0.1
#: Two onsets closer than this are one (s).
MIN_SEGMENT_S = 0.5

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
#: A time column without a unit is read as seconds only when that makes at least this many samples
#: per second (Hz): fewer cannot follow a vibrating strip (the stamps are then milliseconds or
#: microseconds; ``time_unit="s"`` still reads them as seconds).
MIN_ASSUMED_RATE_HZ = 20.0
#: Units a hint lists for a column without one (``"arbitrary"`` last).
UNIT_HINT_VALUES = ("g", "m/s^2", "mm/s", "m/s", "µm", "mm", "m", "microstrain", "strain", ARBITRARY)


@dataclass(frozen=True)
class Segment:
    """One pluck or tap found in a record.

    Attributes
    ----------
    start_s, end_s : float
        Where it starts (one envelope block before its onset) and ends (s, record time).
    peak : float
        Its loudest envelope block (half the range, SI unit of the signal).
    """

    start_s: float
    end_s: float
    peak: float


@dataclass
class Record:
    """A record read from any supported file, in SI units, ready to become a measurement.

    Attributes
    ----------
    path : pathlib.Path
        The file.
    format : str
        The format recognised.
    time_s : numpy.ndarray
        Time stamps (s), strictly increasing, from 0 at the file's first sample.
    output_column : str
        ``"acceleration_m_s2"``, ``"velocity_m_s"``, ``"displacement_m"`` or ``"strain"``.
    output : numpy.ndarray
        The signal (SI).
    signal : str
        Which column of the file the signal is, and why (``"Acceleration z (m/s^2): the most
        vibration power"``).
    channels : list of str
        Every column of the block read, with quantity and unit.
    input_column : str or None
        ``"voltage_V"`` or ``"force_N"`` when the file holds an input beside the signal.
    input : numpy.ndarray or None
        The input (SI).
    segments : list of Segment
        Plucks found (empty for one).
    segment_index : int or None
        0-based index of the segment kept (None: the whole record).
    notes : list of str
        Everything done to the data (stamps dropped, time shifted, blocks skipped), in the
        command line's words; the first says where the time came from.
    findings : list of Finding
        The reader's decisions (record, block, time, signal, unit, input, pluck), each with why
        and the reading option that changes it (:mod:`beam.io.readers.findings`).
    cleaning : list of str
        What was done to the data and what the file says beside it (stamps dropped, time shifted,
        a comment line, the zip member read), in words that name no front end.
    records : list of str
        The records of a file holding several (empty for one); ``findings`` says which was used.
    arbitrary_units : bool
        True when the signal is in arbitrary units (its scale unknown: ADC counts, an
        uncalibrated sensor's volts); ``output`` then holds the values as the file does.
        Everything done to the data (stamps dropped, time shifted, blocks skipped).
    artifacts : beam.io.artifacts.Artifacts or None
        Hum, spikes and rail values found in the samples kept (None: not searched).
    taps : tuple of beam.io.taps.TapPiece
        Every segment of a record of several plucks or taps, each with its own samples (empty for one).
    """

    path: object
    format: str
    time_s: np.ndarray
    output_column: str
    output: np.ndarray
    signal: str
    channels: list[str]
    input_column: str | None = None
    input: np.ndarray | None = None
    segments: list[Segment] = field(default_factory=list)
    segment_index: int | None = None
    notes: list[str] = field(default_factory=list)
    findings: list[Finding] = field(default_factory=list)
    cleaning: list[str] = field(default_factory=list)
    records: list[str] = field(default_factory=list)
    arbitrary_units: bool = False
    artifacts: Artifacts | None = None
    taps: tuple[TapPiece, ...] = ()

    @property
    def rate_Hz(self) -> float:
        """1 / the median time step (Hz)."""
        return 1.0 / float(np.median(np.diff(self.time_s)))

    @property
    def duration_s(self) -> float:
        """Last minus first stamp (s)."""
        return float(self.time_s[-1] - self.time_s[0])

    def arrays(self) -> dict[str, np.ndarray]:
        """The project's columns: ``time_s``, the input if any, the output."""
        return record_arrays(self)


def record_arrays(record) -> dict[str, np.ndarray]:
    """``{"time_s": ..., input column: ... (if any), output column: ...}`` of anything with
    ``time_s``, ``input_column``, ``input``, ``output_column`` and ``output``."""
    out = {"time_s": record.time_s}
    if record.input_column is not None:
        out[record.input_column] = record.input
    out[record.output_column] = record.output
    return out


def _psd(time_s: np.ndarray, values: np.ndarray):
    """(frequency, Welch PSD of values / peak, lowest vibration frequency, peak) of finite samples on
    the median step, or None; peak = max |value| (the PSD is of the values scaled to at most 1, so
    that no square overflows: a file may hold values near the float range).

    Segments of about a quarter of the record (at most 2^16 samples); stamps need not be
    uniform for a ranking or a block length."""
    finite = np.isfinite(values) & np.isfinite(time_s)
    t, y = time_s[finite], values[finite]
    if y.size < 8:
        return None
    step = float(np.median(np.diff(t)))
    peak = float(np.max(np.abs(y)))
    if not step > 0 or not peak > 0:
        return None
    z = y / peak
    frequency, density = welch(z - np.mean(z), fs=1.0 / step, nperseg=int(min(y.size, max(64, min(2**16, y.size // 4)))))
    return frequency, density, max(VIBRATION_LOW_HZ, 4.0 / max(float(t[-1] - t[0]), step)), peak


def vibration_power(time_s: np.ndarray, values: np.ndarray) -> float:
    """Power of ``values`` above max(:data:`VIBRATION_LOW_HZ`, 4 / duration) (unit²), from
    Welch's estimate (:func:`_psd`); inf when it exceeds the float range."""
    spectrum = _psd(time_s, values)
    if spectrum is None:
        return 0.0
    frequency, density, low, peak = spectrum
    band = frequency >= low
    if not np.any(band):
        return 0.0
    with np.errstate(over="ignore"):
        return float(np.sum(density[band]) * (frequency[1] - frequency[0]) * np.float64(peak) ** 2)


def _time_axis(record: RawRecord, block: Block, rate: float | None, time_unit: str | None,
               findings: Sequence[Finding] = ()) -> tuple[np.ndarray, str, Finding]:
    """(time (s), the note saying where it came from, the finding) of a block (module notes, step 2)."""
    path = record.path
    n = block.columns[0].values.size
    context = _context(record, block, findings)
    if rate is not None:
        return (np.arange(n) / float(rate), f"time from --rate {rate:g} Hz",
                Finding("time", f"a sampling rate of {rate:g} Hz", option="rate", given=True,
                        found=f"column {block.time.name!r} left aside" if block.time is not None else ""))
    if block.time is not None:
        values = block.time.values
        meaning = block.time.meaning
        factor = meaning.factor if meaning.quantity == "time" else None
        if time_unit is not None:
            factor = TIME_UNITS[time_unit]
            finding = Finding("time", f"column {block.time.name!r}", f"in {display_unit(time_unit)}", option="time_unit",
                              given=True)
        elif factor is not None:
            source = meaning.unit_source
            why = f"from {source}" if source in ("its name", "the file's unit field") else source
            finding = Finding("time", f"column {block.time.name!r}", f"in {display_unit(meaning.unit)}, {why}",
                              option="time_unit")
        else:
            finite = values[np.isfinite(values)]
            steps = np.diff(finite)
            typical = float(np.median(steps[steps > 0])) if np.any(steps > 0) else 0.0
            if finite.size and np.all(finite == np.round(finite)) and typical >= 1:
                raise ReadingError(
                    path, f"time column {block.time.name!r} holds whole numbers stepping by {typical:g} with no unit "
                    "(an Arduino's micros() or millis()?)", Hint("time_unit", ("ms", "us")), **context)
            if 0 < typical and 1.0 / typical < MIN_ASSUMED_RATE_HZ:
                raise ReadingError(
                    path, f"time column {block.time.name!r} has no unit; read as seconds its stamps step by {typical:g} s "
                    f"({1.0 / typical:.3g} samples per second), too slow for a vibrating strip: milliseconds?",
                    Hint("time_unit", ("ms", "us")), **context)
            factor = 1.0
            finding = Finding("time", f"column {block.time.name!r}", "in s, assumed (its name gives no unit)",
                              option="time_unit")
        where = f"time from column {block.time.name!r}" + (f" in {time_unit}" if time_unit else "")
        return values * factor, where, finding
    if block.rate_Hz is not None:
        return (block.start_s + np.arange(n) / block.rate_Hz, f"time from the file's sampling rate {block.rate_Hz:g} Hz",
                Finding("time", f"the file's sampling rate {block.rate_Hz:g} Hz", "no time column", option="rate"))
    raise ReadingError(path, "no time column and no sampling rate in the file", Hint("rate"), **context)


def channel_listing(block: Block) -> list[str]:
    """``"2: gFx (acceleration in g)"``, one line per column of the block."""
    out = []
    for column in block.columns:
        meaning = column.meaning
        what = "time" if column is block.time else (meaning.quantity or "unknown quantity")
        if meaning.arbitrary:
            unit = " in arbitrary units" + (f" ({meaning.unit})" if not _canonical_arbitrary(meaning.unit) else "")
        else:
            unit = f" in {meaning.unit}" if meaning.unit else ""
        out.append(f"{column.position}: {column.name} ({what}{unit})")
    return out


def _canonical_arbitrary(unit: str | None) -> bool:
    """Whether ``unit`` is the canonical word for arbitrary units (nothing more to show)."""
    return unit is not None and unit.strip().lower().startswith(ARBITRARY)


def _pick_column(record: RawRecord, block: Block, column: str | None, context: dict) -> Column:
    if column is None:
        raise AssertionError  # pragma: no cover
    text = str(column).strip()
    data = block.data_columns
    if text.isdigit():
        index = int(text)
        match = next((c for c in block.columns if c.position == index), None)
        if match is None:
            raise ReadingError(record.path, f"the file has columns 1 to {len(block.columns)}", option="column",
                               value=index, **context)
        return match
    lowered = text.lower()
    match = next((c for c in data if c.name.lower() == lowered), None) or next(
        (c for c in data if c.name.lower().startswith(lowered)), None)
    if match is None:
        names = ", ".join(repr(c.name) for c in block.columns)
        raise ReadingError(record.path, f"no such column; the file has {names}", option="column", value=repr(text),
                           **context)
    return match


def _with_unit(column: Column, unit: str | None) -> Column:
    if unit is None:
        return column
    return Column(column.name, column.values, column_meaning(column.name, unit), column.position)


def _context(record: RawRecord, block: Block, findings: Sequence[Finding]) -> dict:
    return {"findings": tuple(findings), "format": record.format, "columns": channel_listing(block),
            "records": [b.label for b in record.blocks] if holds_records(record) else ()}


def choose_signal(record: RawRecord, block: Block, time_s: np.ndarray, *, column: str | None, axis: str | None,
                  unit: str | None, findings: Sequence[Finding] = ()) -> tuple[Column, Finding]:
    """The signal column of a block (its unit applied) and the finding saying why it was chosen
    (module notes, step 3); ``findings`` are the reader's earlier ones, for its messages."""
    context = _context(record, block, findings)
    if unit is not None and not is_known_unit(unit):
        raise ReadingError(record.path, "unknown unit", Hint("expected", SIGNAL_UNITS), option="unit",
                           value=repr(unit), **context)
    if column is not None:
        chosen = _with_unit(_pick_column(record, block, column, context), unit)
        return _checked(record, chosen, context), Finding("signal", chosen.name, option="column", given=True)
    candidates = [_with_unit(c, unit) if c.meaning.factor is None else c for c in block.data_columns]
    motion = [c for c in candidates if c.meaning.quantity in OUTPUT_COLUMN_OF or c.meaning.quantity is None]
    if axis is not None:
        on_axis = [c for c in motion if c.meaning.axis == axis.lower()]
        if not on_axis:
            axes = sorted({c.meaning.axis for c in motion if c.meaning.axis in ("x", "y", "z")})
            raise ReadingError(record.path, f"no column on that axis (axes: {', '.join(axes) or 'none named'})",
                               Hint("axis"), option="axis", value=axis, **context)
        motion = on_axis
    signed = [c for c in motion if not c.meaning.is_total] or motion
    if not signed:
        raise ReadingError(record.path, "no column measures motion (acceleration, velocity, displacement or strain)",
                           Hint("column_and_unit", UNIT_HINT_VALUES), **context)
    kinds = {c.meaning.quantity for c in signed}
    if len(signed) == 1:
        how = Finding("signal", signed[0].name, "the only signal", option="column", given=axis is not None)
        if axis is not None:
            how = Finding("signal", signed[0].name, option="axis", given=True)
        return _checked(record, signed[0], context), how
    if len(kinds) > 1:
        names = ", ".join(f"{c.name!r} ({c.meaning.quantity or 'unknown'})" for c in signed)
        raise ReadingError(record.path, f"columns of different quantities ({names}) cannot be compared",
                           Hint("column"), **context)
    powers = [vibration_power(time_s, c.values * (c.meaning.factor or 1.0)) for c in signed]
    best = int(np.argmax(powers))
    chosen = signed[best]
    ranked = ", ".join(f"{c.name} {p:.3g}" for c, p in sorted(zip(signed, powers), key=lambda cp: -cp[1]))
    units = "arbitrary units²" if chosen.meaning.arbitrary else "SI units²"
    return _checked(record, chosen, context), Finding("signal", chosen.name, "the most vibration power",
                                                      f"{units}: {ranked}", option="column")


def _checked(record: RawRecord, column: Column, context: dict) -> Column:
    meaning = column.meaning
    if meaning.quantity in INPUT_COLUMN_OF:
        raise ReadingError(record.path, f"column {column.name!r} is a {meaning.quantity} (an input, in {meaning.unit})",
                           Hint("output_unit", UNIT_HINT_VALUES[:-1]), **context)
    if meaning.arbitrary and meaning.quantity not in OUTPUT_COLUMN_OF:
        raise ReadingError(record.path, f"column {column.name!r} is read in arbitrary units ({meaning.unit}), but its name "
                           "does not say what the sensor measures",
                           Hint("quantity", tuple(arbitrary_spelling(q) for q in OUTPUT_COLUMN_OF)), **context)
    if meaning.factor is None or meaning.quantity not in OUTPUT_COLUMN_OF:
        said = f" (its name says {meaning.unit!r})" if meaning.unit else ""
        kind = "unit" if meaning.quantity in OUTPUT_COLUMN_OF else "unit_and_quantity"
        raise ReadingError(record.path, f"column {column.name!r} has no unit the reader knows{said}",
                           Hint(kind, UNIT_HINT_VALUES[:-1]), **context)
    return column


def _unit_finding(column: Column, unit: str | None, original: ColumnMeaning | None) -> Finding:
    """Where the signal's unit comes from (and, for arbitrary units, what that means)."""
    meaning = column.meaning
    scale = ("arbitrary units: the values as the file holds them, their scale unknown (nothing that depends on the "
             "amplitude can be calibrated)") if meaning.arbitrary else ""
    if unit is not None and meaning.unit_source == "given":
        found = f"its name says {original.unit}" if original is not None and original.unit and original.unit != unit else ""
        return Finding("unit", unit, scale, found=found, option="unit", given=True)
    source = meaning.unit_source or "its name"
    why = f"from {source}" if source in ("its name", "the file's unit field") else source
    return Finding("unit", meaning.unit or "", f"{why}; {scale}" if scale else why, option="unit")


def _in_si(raw: RawRecord, block: Block, column: Column, findings: Sequence[Finding]) -> np.ndarray:
    """A column's values in SI; a value that its unit's factor carries beyond the float range is refused."""
    with np.errstate(over="ignore"):
        values = column.values * column.meaning.factor
    beyond = np.isinf(values) & np.isfinite(column.values)
    if np.any(beyond):
        first = float(column.values[np.flatnonzero(beyond)[0]])
        raise ReadingError(raw.path, f"column {column.name!r} holds {first:g} {column.meaning.unit}, beyond the range of "
                           "numbers in SI units", **_context(raw, block, findings))
    return values


def _input_column(block: Block, chosen: Column) -> Column | None:
    inputs = [c for c in block.data_columns if c is not chosen and c.meaning.quantity in INPUT_COLUMN_OF
              and c.meaning.factor is not None]
    return inputs[0] if len(inputs) == 1 else None


def clean_stamps(time_s: np.ndarray, *arrays: np.ndarray) -> tuple[np.ndarray, str | None]:
    """Mask of samples kept: finite time and values, stamps strictly increasing (module notes, step 4).

    Returns
    -------
    keep : (n,) bool array
    report : str or None
        What was dropped (None when nothing was).
    """
    finite = np.isfinite(time_s)
    for array in arrays:
        finite &= np.isfinite(array)
    t = np.where(finite, time_s, -np.inf)
    previous_max = np.maximum.accumulate(np.concatenate([[-np.inf], t[:-1]]))
    repeated = finite & (t == previous_max)
    backwards = finite & (t < previous_max)
    keep = finite & ~repeated & ~backwards
    parts = []
    if np.any(~finite):
        parts.append(f"{int(np.count_nonzero(~finite))} row(s) with a missing value")
    if np.any(repeated):
        parts.append(f"{int(np.count_nonzero(repeated))} repeated stamp(s)")
    if np.any(backwards):
        first = int(np.flatnonzero(backwards)[0])
        parts.append(f"{int(np.count_nonzero(backwards))} stamp(s) going back in time (first at sample {first})")
    return keep, ("dropped " + ", ".join(parts)) if parts else None


def dominant_frequency(time_s: np.ndarray, values: np.ndarray) -> float | None:
    """Frequency (Hz) of the highest Welch peak above max(:data:`VIBRATION_LOW_HZ`, 4 / duration), None if none."""
    spectrum = _psd(time_s, values)
    if spectrum is None:
        return None
    frequency, density, low, _peak = spectrum
    band = frequency >= low
    if not np.any(band) or not np.any(density[band] > 0):
        return None
    return float(frequency[band][np.argmax(density[band])])


def envelope_block_s(time_s: np.ndarray, values: np.ndarray) -> float:
    """The envelope's block (s): two periods of the dominant frequency, at least :data:`ENVELOPE_BLOCK_S`."""
    dominant = dominant_frequency(time_s, values)
    return max(ENVELOPE_BLOCK_S, 2.0 / dominant) if dominant else ENVELOPE_BLOCK_S


def find_segments(time_s: np.ndarray, values: np.ndarray) -> list[Segment]:
    """Plucks or taps in a signal (module notes, step 5); empty when there are fewer than two."""
    n = values.size
    if n < 16:
        return []
    step = float(np.median(np.diff(time_s)))
    block_s = envelope_block_s(time_s, values)
    per_block = max(4, int(round(block_s / step)))
    count = n // per_block
    if count < 8:
        return []
    blocks = values[: count * per_block].reshape(count, per_block)
    envelope = 0.5 * (blocks.max(axis=1) - blocks.min(axis=1))
    quiet = float(np.percentile(envelope, 10))
    loudest = float(envelope.max())
    if loudest <= 0:
        return []
    lookback = max(3, int(round(ONSET_LOOKBACK_S / (per_block * step))))
    onsets: list[int] = []
    for k in range(1, count - 1):
        first = max(0, k - lookback, onsets[-1] + 1 if onsets else 0)
        if first >= k:
            continue
        before = float(envelope[first:k].min())
        level = min(envelope[k], envelope[k + 1])
        if (level >= ONSET_RATIO * before and envelope[k] >= ONSET_NOISE_RATIO * quiet
                and envelope[k] >= ONSET_PEAK_FRACTION * loudest):
            start_time = float(time_s[k * per_block])
            if onsets and start_time - float(time_s[onsets[-1] * per_block]) < MIN_SEGMENT_S:
                continue
            onsets.append(k)
    if len(onsets) < 2:
        return []
    segments = []
    bounds = onsets + [count]
    for k, (start, stop) in enumerate(zip(bounds[:-1], bounds[1:])):
        first = max(0, start - 1) * per_block
        last = (stop - 1) * per_block if k + 1 < len(onsets) else n
        segments.append(Segment(float(time_s[first]), float(time_s[min(last, n) - 1]),
                                float(envelope[start:stop].max())))
    return segments


def holds_records(raw: RawRecord) -> bool:
    """Whether the file's blocks are separate records (:attr:`Block.kind`), not one acquisition's parts."""
    return len(raw.blocks) > 1 and all(b.kind == "record" for b in raw.blocks)


def default_record(raw: RawRecord) -> int:
    """0-based index of the record used when none is chosen: the one with the most samples, the
    first of those in the file's order."""
    sizes = [b.columns[0].values.size for b in raw.blocks]
    return int(np.argmax(sizes))


def _pick_record(raw: RawRecord, record: str | int | None) -> tuple[int, Finding]:
    labels = [b.label for b in raw.blocks]
    found = f"{len(labels)} records in the file: " + ", ".join(
        f"{k}: {b.label} ({len(b.columns)} column(s), {b.columns[0].values.size} samples)" for k, b in enumerate(raw.blocks, 1))
    context = {"format": raw.format, "records": labels}
    if record is None:
        index = default_record(raw)
        sizes = [b.columns[0].values.size for b in raw.blocks]
        why = "the longest" if sizes.count(max(sizes)) == 1 else "the first of the longest"
        return index, Finding("record", labels[index], why, found, option="record")
    text = str(record).strip()
    if text.isdigit():
        index = int(text) - 1
        if not 0 <= index < len(labels):
            raise ReadingError(raw.path, f"the file holds records 1 to {len(labels)} ({', '.join(labels)})",
                               option="record", value=text, **context)
    else:
        matches = [k for k, label in enumerate(labels) if label.lower() == text.lower()] or [
            k for k, label in enumerate(labels) if label.lower().startswith(text.lower())]
        if len(matches) != 1:
            raise ReadingError(raw.path, f"{'no such record' if not matches else 'names several records'}; the file "
                               f"holds {', '.join(repr(label) for label in labels)}", option="record", value=repr(text),
                               **context)
        index = matches[0]
    return index, Finding("record", labels[index], found=found, option="record", given=True)


def build_record(raw: RawRecord, *, record: str | int | None = None, column: str | None = None, axis: str | None = None,
                 rate: float | None = None, time_unit: str | None = None, unit: str | None = None,
                 segment: int | None = None) -> Record:
    """One record from a file's columns (module notes).

    Parameters
    ----------
    raw : RawRecord
        What the format reader found.
    record : str or int, optional
        For a file holding several records (MATLAB structs, HDF5 groups, arrays of different
        lengths): which, by name (or a name's beginning) or 1-based position (default: the longest).
    column : str, optional
        The signal's column, by name (or a name's beginning) or 1-based position.
    axis : {"x", "y", "z"}, optional
        The signal's axis.
    rate : float, optional
        Sampling rate (Hz): time is k / rate (overrides a time column).
    time_unit : {"s", "ms", "us"}, optional
        Unit of the time column.
    unit : str, optional
        Unit of the signal column (for a column whose name has none; given with ``column``, it
        wins over the name's); :data:`beam.io.readers.units.SIGNAL_UNITS` lists the common ones,
        ``"arbitrary"`` reads a signal of unknown scale.
    segment : int, optional
        1-based segment (block or pluck) to keep.

    Raises
    ------
    ReadingError
        Anything that keeps the file from being one record without a choice; one line naming
        the file, the problem and the option that resolves it.
    """
    if rate is not None and not (math.isfinite(rate) and rate > 0):
        raise BeamInputError(f"--rate must be a positive number of Hz, got {rate!r}")
    if time_unit is not None and time_unit not in TIME_UNITS:
        raise BeamInputError(f"--time-unit must be one of {', '.join(TIME_UNITS)}, got {time_unit!r}")
    notes = list(raw.notes)
    findings: list[Finding] = []
    blocks = raw.blocks
    records = [b.label for b in blocks] if holds_records(raw) else []
    if records:
        index, chosen_record = _pick_record(raw, record)
        findings.append(chosen_record)
        notes.append(f"{len(blocks)} records in the file ({', '.join(records)}); using {blocks[index].label}"
                     + (f" ({chosen_record.why})" if chosen_record.why else ""))
        blocks = [blocks[index]]
    elif record is not None and not (str(record).strip() in ("1", blocks[0].label) and len(blocks) == 1):
        raise ReadingError(raw.path, "the file holds one record" + (f" ({blocks[0].label})" if blocks[0].label else ""),
                           option="record", value=repr(str(record)), format=raw.format)
    block = blocks[0]
    block_segments: list[Segment] = []
    if len(blocks) > 1:
        scored = []
        for candidate in blocks:
            t, _, _ = _time_axis(raw, candidate, rate, time_unit, findings)
            chosen, _ = choose_signal(raw, candidate, t, column=column, axis=axis, unit=unit, findings=findings)
            values = _in_si(raw, candidate, chosen, findings)
            scored.append((candidate, t, vibration_power(t, values), float(np.nanmax(np.abs(values)))))
        block_segments = [Segment(float(t[0]), float(t[-1]), peak) for _, t, _, peak in scored]
        if segment is not None:
            if not 1 <= segment <= len(blocks):
                raise ReadingError(raw.path, f"the file has segments 1 to {len(blocks)}", option="segment", value=segment,
                                   format=raw.format)
            index = segment - 1
        else:
            index = int(np.argmax([power for _, _, power, _ in scored]))
        block = blocks[index]
        findings.append(Finding("block", block.label, "the most vibration power" if segment is None else "",
                                f"{len(blocks)} blocks: {', '.join(b.label for b in blocks)}", option="segment",
                                given=segment is not None))
        notes.append(f"{len(blocks)} blocks in the file ({', '.join(b.label for b in blocks)}); "
                     f"using {block.label}" + (" (the most vibration power)" if segment is None else ""))
    time_s, time_source, time_finding = _time_axis(raw, block, rate, time_unit, findings)
    findings.append(time_finding)
    chosen, signal_finding = choose_signal(raw, block, time_s, column=column, axis=axis, unit=unit, findings=findings)
    if unit is not None and chosen.meaning.unit_source != "given":  # the given unit is for a column without one
        if column is None and chosen.meaning.unit and normalise_unit(chosen.meaning.unit) != normalise_unit(unit):
            notes.append(f"the unit given ({unit}) is for a column without one; {chosen.name} says {chosen.meaning.unit}")
    original = next((c.meaning for c in block.columns if c.position == chosen.position), None)
    findings += [signal_finding, _unit_finding(chosen, unit, original)]
    output = _in_si(raw, block, chosen, findings)
    input_column = _input_column(block, chosen)
    if input_column is not None:
        findings.append(Finding("input", input_column.name, f"a {input_column.meaning.quantity} beside the signal: "
                                "what drives the beam"))
    input_values = _in_si(raw, block, input_column, findings) if input_column is not None else None
    cleaning = list(raw.notes)
    keep, dropped = clean_stamps(time_s, output, *([input_values] if input_values is not None else []))
    if dropped:
        notes.append(dropped)
        cleaning.append(dropped)
    time_s, output = time_s[keep], output[keep]
    input_values = input_values[keep] if input_values is not None else None
    if time_s.size < 2:
        raise ReadingError(raw.path, f"fewer than 2 usable samples in column {chosen.name!r}", **_context(raw, block, findings))
    if time_s[0] != 0:
        shifted = f"time shifted by {-time_s[0]:+.9g} s to start at 0"
        notes.append(shifted)
        cleaning.append(shifted)
        time_s = time_s - time_s[0]
    notes.insert(0, time_source)
    segments = block_segments
    segment_index = raw.blocks.index(block) if len(blocks) > 1 else None
    taps: tuple[TapPiece, ...] = ()
    if len(blocks) == 1:
        segments, taps, more = tap_segments(time_s, output, input_values)
        notes += more
        if segments:
            if segment is not None:
                if not 1 <= segment <= len(segments):
                    raise ReadingError(raw.path, f"the record has segments 1 to {len(segments)}", option="segment",
                                       value=segment, **_context(raw, block, findings))
                segment_index = segment - 1
            else:
                segment_index = int(np.argmax([s.peak for s in segments]))
            kept = segments[segment_index]
            inside = (time_s >= kept.start_s) & (time_s <= kept.end_s)
            time_s, output = time_s[inside] - kept.start_s, output[inside]
            input_values = input_values[inside] if input_values is not None else None
            findings.append(Finding("pluck", f"segment {segment_index + 1} ({kept.start_s:.3f}-{kept.end_s:.3f} s)",
                                    "the strongest" if segment is None else "", f"{len(segments)} plucks/taps found",
                                    option="segment", given=segment is not None))
            notes.append(f"{len(segments)} plucks/taps found; using segment {segment_index + 1} "
                         f"({kept.start_s:.3f}-{kept.end_s:.3f} s of the record)"
                         + (" (the strongest)" if segment is None else ""))
        elif segment is not None and segment != 1:
            raise ReadingError(raw.path, "the record holds one pluck", option="segment", value=segment,
                               **_context(raw, block, findings))
    artifacts = taps[segment_index].artifacts if taps else clean(time_s, output, input_values)[1]
    return Record(
        path=raw.path, format=raw.format, time_s=np.ascontiguousarray(time_s), output_column=OUTPUT_COLUMN_OF[chosen.meaning.quantity],
        output=np.ascontiguousarray(output), signal=COMMAND_LINE.finding(signal_finding, title=False),
        channels=channel_listing(block),
        input_column=INPUT_COLUMN_OF[input_column.meaning.quantity] if input_column is not None else None,
        input=np.ascontiguousarray(input_values) if input_values is not None else None,
        segments=segments, segment_index=segment_index, notes=notes, findings=findings, cleaning=cleaning,
        records=records, arbitrary_units=chosen.meaning.arbitrary, artifacts=artifacts, taps=taps,
    )


def tap_segments(time_s: np.ndarray, output: np.ndarray, input_values: np.ndarray | None
                 ) -> tuple[list[Segment], tuple[TapPiece, ...], list[str]]:
    """The segments of one block (module notes, step 6), each as a tap with its own samples, and
    what was done in words: plucks or taps (:func:`find_segments`), a free decay's split where its
    swing jumps (:func:`beam.io.taps.split_at_disturbances`), each piece of a free decay from its
    impact on (:func:`beam.io.taps.impact_start`)."""
    segments = find_segments(time_s, output)
    notes: list[str] = []
    said = [""] * len(segments)
    if input_values is None and output.size >= 16:
        block_s = envelope_block_s(time_s, output)
        pieces, notes = split_at_disturbances(time_s, output, [(s.start_s, s.end_s, s.peak) for s in segments], block_s)
        segments = [Segment(impact_start(time_s, output, start, block_s), end, peak) for start, end, peak, _ in pieces]
        said = [note for *_, note in pieces]
    taps = []
    for segment, note in zip(segments, said):
        inside = (time_s >= segment.start_s) & (time_s <= segment.end_s)
        t, y = time_s[inside] - segment.start_s, output[inside]
        u = input_values[inside] if input_values is not None else None
        artifacts = clean(t, y, u)[1]
        taps.append(TapPiece(segment.start_s, segment.end_s, segment.peak, t, y, u,
                             artifacts.with_note(note) if note else artifacts))
    return segments, tuple(taps), notes
