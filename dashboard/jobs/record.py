"""Jobs of the "Your record" view: read an uploaded file in any format, describe its beam.

Scheduler jobs (:mod:`dashboard.runtime.scheduler`), no panel: they run on a worker thread of
the session's pool, never on the server's event loop (a 50 MB phone record takes about a
second to parse and another to transform).

:func:`read_job`
    The uploaded bytes are written under their own name (the suffix picks the reader) in a
    temporary folder, read by :func:`beam.io.readers.read_raw` (a ``partial`` stage: the
    file's records and columns, :class:`FileContents`, for the reading options to offer even
    when the file then needs a choice), made a record by :func:`beam.io.readers.signal.build_record`
    and deleted; the record's Welch spectrum (:func:`beam.io.anchor.welch_spectrum`, the one
    ``beam import`` searches for peaks) is reduced for drawing and its peaks found
    (:func:`beam.io.anchor.spectral_peaks`). The reader's findings and refusals are said in the
    page's words (:data:`PAGE`: its controls under *Reading options*, never a command-line flag).
:func:`describe_job`
    The form's description of the beam (:func:`beam_document`, the keys of a sidecar) and the
    record become a :class:`~beam.io.measurement.Measurement`
    (:func:`beam.io.measurement.measurement_from_record`), with the ideal beam's modes
    (:func:`beam.cli.import_command.ideal_modes_Hz`, as ``beam import`` prints them).
"""

from __future__ import annotations

import contextlib
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from beam.errors import BeamInputError
from beam.io.anchor import LOW_HZ, Peak, spectral_peaks, welch_spectrum
from beam.io.measurement import Measurement, measurement_from_record
from beam.io.readers import Phrasing, RawRecord, ReadingError, Record, read_raw
from beam.io.readers.signal import build_record, channel_listing, default_record, holds_records
from dashboard.jobs.beam import MAX_UPLOAD_BYTES, upload_size_text
from dashboard.runtime import scheduler as sch

__all__ = ["CONTROLS", "MAX_SPECTRUM_POINTS", "PAGE", "Described", "FileContents", "RecordRead", "beam_document",
           "describe", "describe_job", "file_contents", "read_job", "read_upload", "reduce_spectrum"]

#: Points of the spectrum sent to the browser at most (a 50 MB record's Welch spectrum has ~500,000).
MAX_SPECTRUM_POINTS = 1500
#: Ideal beam modes computed at most (those within the record's spectrum are drawn): as many as
#: ``beam import`` lists.
MAX_MODES = 6
#: The page's reading options as its texts name them (the state's labels begin with these names).
CONTROLS = {"record": "Record in the file", "column": "Signal column", "axis": "Signal column", "unit": "Signal's unit",
            "rate": "Sampling rate (Hz)", "time_unit": "Time column's unit", "segment": "Pluck to use",
            "format": "file's format"}
_UNKNOWN_SCALE = "a signal of unknown scale: ADC counts, an uncalibrated sensor's volts"
#: The reader's findings and hints in the page's words (:class:`beam.io.readers.Phrasing`).
PAGE = Phrasing(
    options=CONTROLS,
    hints={
        "time_unit": "choose {values} as the Time column's unit under Reading options (s if they are seconds)",
        "rate": "give the Sampling rate (Hz) under Reading options",
        "column": "choose one as the Signal column under Reading options",
        "axis": "choose one as the Signal column under Reading options",
        "column_and_unit": "choose one as the Signal column and its unit as the Signal's unit under Reading options "
                           f"({{listed}}; arbitrary units of what it measures for {_UNKNOWN_SCALE})",
        "unit": f"choose it as the Signal's unit under Reading options ({{listed}}; arbitrary units for {_UNKNOWN_SCALE})",
        "unit_and_quantity": "choose it as the Signal's unit under Reading options ({listed}; arbitrary units of "
                             f"acceleration, velocity, displacement or strain for {_UNKNOWN_SCALE})",
        "output_unit": "if it is the sensor's output, choose its unit as the Signal's unit under Reading options "
                       "({listed}; arbitrary units of what it measures for an uncalibrated sensor's volts)",
        "quantity": "choose what the sensor measures as the Signal's unit under Reading options: {values}",
        "record": "choose one as the Record in the file under Reading options",
        "expected": "expected one of {listed}",
    },
    given="your choice under Reading options",
    change="; another: {option} under Reading options",
    separator=" or ",
    units_shown=True,
    titles={"record": "Record", "block": "Block", "time": "Time", "signal": "Signal used", "unit": "Unit",
            "input": "Input", "pluck": "Pluck"},
)
#: The signal's SI unit by output column (for the spectrum's axis).
SIGNAL_UNITS = {"acceleration_m_s2": "m/s²", "velocity_m_s": "m/s", "displacement_m": "m", "strain": "1"}


@dataclass(frozen=True)
class RecordRead:
    """An uploaded file as read, with its spectrum.

    Attributes
    ----------
    file_name : str
        The name it was uploaded under.
    size_bytes : int
        Its size (bytes).
    record : beam.io.readers.Record
        What the readers made of it (SI units, time from 0).
    frequency_Hz, psd_db : numpy.ndarray
        The Welch spectrum reduced to at most :data:`MAX_SPECTRUM_POINTS` points spaced evenly in
        log frequency over the band searched for peaks (the largest PSD of each span kept, so no
        peak is lost), in dB re 1 (SI unit)²/Hz; empty for a record too short for a spectrum.
    peaks : tuple of beam.io.anchor.Peak
        The record's most prominent spectral peaks, lowest first.
    """

    file_name: str
    size_bytes: int
    record: Record
    frequency_Hz: np.ndarray
    psd_db: np.ndarray
    peaks: tuple[Peak, ...]

    @property
    def signal_unit(self) -> str:
        """SI unit of the signal (``"m/s²"``)."""
        return SIGNAL_UNITS.get(self.record.output_column, "SI")

    def summary(self) -> dict[str, Any]:
        """What was read, for the view, in the page's words (:data:`PAGE`): file, format, channels,
        the signal used and why, ``findings`` (every decision of the reader: (title, what was
        chosen and why, the control that changes it or '')), rate (Hz), duration (s), samples,
        segments (with the one used), notes (what was done to the data), taps (how many: a record
        of several is calibrated with every tap together), artifacts (what
        :mod:`beam.io.artifacts` found, in words)."""
        r = self.record
        signal = next((f for f in r.findings if f.topic == "signal"), None)
        findings = [(PAGE.titles[f.topic], PAGE.finding(f, title=False),
                     "" if f.option is None or f.given else f"{CONTROLS[f.option]} under Reading options")
                    for f in r.findings]
        return {"file": self.file_name, "size_bytes": self.size_bytes, "format": r.format, "channels": list(r.channels),
                "signal": PAGE.finding(signal, title=False) if signal is not None else r.signal, "findings": findings,
                "rate_Hz": r.rate_Hz, "duration_s": r.duration_s, "samples": int(r.time_s.size),
                "segments": [(s.start_s, s.end_s, s.peak) for s in r.segments], "segment_used": r.segment_index,
                "notes": list(r.cleaning), "arbitrary_units": r.arbitrary_units, "taps": len(r.taps),
                "artifacts": r.artifacts.sentences(self.signal_unit) if r.artifacts is not None else []}


@dataclass(frozen=True)
class Described:
    """The record with its beam described: the measurement a calibration takes, the sidecar, the
    ideal beam's natural frequencies (Hz, those below the spectrum's top) and the summary
    ``beam import`` prints for them (:func:`beam.cli.import_command.format_import`)."""

    measurement: Measurement
    document: dict
    modes_Hz: tuple[float, ...]
    summary: str


@dataclass(frozen=True)
class FileContents:
    """What a dropped file holds before any choice: for the reading options to offer its own
    records and columns, also when reading it needs a choice.

    Attributes
    ----------
    file_name : str
        The name it was uploaded under.
    records : tuple of str
        The records of a file holding several (a MATLAB file's structs), empty for one.
    default_record : str
        The record read when none is chosen ('' for a file of one record).
    columns : dict
        Record ('' for a file of one) -> its columns as the reader lists them
        (``"2: gFx (acceleration in g)"``).
    """

    file_name: str
    records: tuple[str, ...]
    default_record: str
    columns: dict[str, tuple[str, ...]]


def file_contents(file_name: str, raw: RawRecord) -> FileContents:
    """The :class:`FileContents` of a file's columns as its reader found them."""
    if holds_records(raw):
        labels = tuple(b.label for b in raw.blocks)
        return FileContents(file_name, labels, labels[default_record(raw)],
                            {b.label: tuple(channel_listing(b)) for b in raw.blocks})
    return FileContents(file_name, (), "", {"": tuple(channel_listing(raw.blocks[0]))})


class _FormDocument(dict):
    """A sidecar document named ``the form`` in messages (:func:`measurement_from_record`)."""

    where = "the form"


def reduce_spectrum(frequency: np.ndarray, density: np.ndarray, low: float, high: float,
                    points: int = MAX_SPECTRUM_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """The spectrum (Hz, unit²/Hz) on [low, high] in at most ``points`` log-spaced spans, each represented by its
    largest bin: (frequency (Hz), PSD (dB re 1 unit²/Hz))."""
    keep = (frequency >= low) & (frequency <= high) & (frequency > 0)
    f, d = frequency[keep], density[keep]
    if f.size == 0:
        return np.empty(0), np.empty(0)
    db = 10.0 * np.log10(np.maximum(d, max(float(d.max()) * 1e-30, np.finfo(float).tiny)))  # a flat-zero column too
    if f.size <= points:
        return f, db
    edges = np.geomspace(f[0], f[-1] * (1 + 1e-12), points + 1)
    span = np.searchsorted(edges, f, side="right") - 1
    starts = np.flatnonzero(np.r_[True, np.diff(span) != 0])
    loudest = np.array([start + int(np.argmax(part)) for start, part in zip(starts, np.split(db, starts[1:]))])
    return f[loudest], db[loudest]


def _safe_name(file_name: str | None) -> str:
    name = Path(file_name or "record").name
    stem, suffix = Path(name).stem, Path(name).suffix
    stem = "".join(c if c.isalnum() or c in " -_." else "_" for c in stem)[:80].strip() or "record"
    suffix = "".join(c for c in suffix if c.isalnum() or c == ".")[:10]
    return stem + suffix


@contextlib.contextmanager
def _uploaded(file_name: str | None, data: bytes | str | None) -> Iterator[tuple[Path, int]]:
    """The upload written under its own (safe) name in a temporary folder: (path, size in bytes);
    the folder is deleted afterwards. A reader's message names the upload, in the page's words."""
    if not data:
        raise BeamInputError(f"{file_name or 'the upload'}: empty file; expected a record")
    data = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    if len(data) > MAX_UPLOAD_BYTES:
        raise BeamInputError(f"{file_name}: {upload_size_text(len(data))} is more than the "
                             f"{upload_size_text(MAX_UPLOAD_BYTES)} an upload may have")
    name = _safe_name(file_name)
    with tempfile.TemporaryDirectory(prefix="beam-record-") as tmp:
        path = Path(tmp) / name
        path.write_bytes(data)
        try:
            yield path, len(data)
        except ReadingError as exc:  # in the page's words, naming the uploaded file, not the temporary path
            raise BeamInputError(exc.phrased(PAGE, path_text=name)) from None
        except BeamInputError as exc:
            raise BeamInputError(str(exc).replace(f"{tmp}/", "")) from None
        except (UnicodeDecodeError, OSError) as exc:
            raise BeamInputError(f"{name}: cannot read the upload ({type(exc).__name__})") from None


def _record_read(file_name: str | None, size_bytes: int, record: Record) -> RecordRead:
    """The record with its spectrum, as the page shows it."""
    record.path = Path(_safe_name(file_name))
    # the spectrum and peaks of the signal the calibration takes: hum subtracted, spikes interpolated
    output = record.artifacts.apply(record.time_s, record.output) if record.artifacts is not None else record.output
    spectrum = welch_spectrum(record.time_s, output)
    if spectrum is None:
        frequency, psd_db = np.empty(0), np.empty(0)
    else:  # drawn from 1 Hz (below the band searched for peaks: mode 1 of a long ruler is that low)
        f, density, _low, high = spectrum
        frequency, psd_db = reduce_spectrum(f, density, max(LOW_HZ, float(f[1])), high)
    kind = record.output_column.split("_", 1)[0]
    peaks = tuple(spectral_peaks(record.time_s, output, kind, max_peaks=6))
    return RecordRead(file_name=file_name or record.path.name, size_bytes=size_bytes, record=record,
                      frequency_Hz=frequency, psd_db=psd_db, peaks=peaks)


def _options(options: dict) -> tuple[str | None, dict]:
    """(format, the other reading options given) of ``read_upload``'s keywords."""
    given = {k: v for k, v in options.items() if v is not None}
    return given.pop("format", None), given


def read_upload(file_name: str | None, data: bytes | str | None, **options: Any) -> RecordRead:
    """Read an uploaded record file in any supported format (module notes).

    Parameters
    ----------
    file_name : str or None
        The name it was uploaded under (its suffix helps recognise the format).
    data : bytes or str
        Its contents (text, as the upload widget decodes ``text/*`` files, is encoded back to UTF-8).
    **options
        ``record``, ``column``, ``rate``, ``time_unit``, ``unit``, ``segment`` of
        :func:`beam.io.readers.read_record` (None: not given).

    Raises
    ------
    BeamInputError
        No file, one larger than :data:`~dashboard.jobs.beam.MAX_UPLOAD_BYTES`, or anything the
        readers refuse; one line naming the file, in the page's words.
    """
    return sch.final_value(read_job(file_name, data, **options))


def read_job(file_name: str | None, data: bytes | str | None, **options: Any) -> Iterator[sch.Stage]:
    """:func:`read_upload` as a scheduler job: a progress stage, a ``partial`` one with the
    file's :class:`FileContents`, then the final :class:`RecordRead`."""
    yield sch.progress(0.1, f"reading {file_name}")
    format, given = _options(options)
    with _uploaded(file_name, data) as (path, size):
        raw = read_raw(path, format)
        yield sch.partial(file_contents(file_name or path.name, raw), 0.5, f"read the columns of {file_name}")
        record = build_record(raw, **given)
    read = _record_read(file_name, size, record)
    yield sch.final(read, f"read {read.file_name}")


def beam_document(title: str, length_m: float, width_m: float, thickness_m: float, material: str,
                  position_m: float, mass_kg: float | None = None, mass_approximate: bool = False) -> dict:
    """The sidecar document of a beam described in a student's words (the keys ``beam import``
    writes): lengths in m, the material a preset's name, the sensor's mass in kg (None: not given)."""
    document: dict[str, Any] = {"title": title, "beam": {"length_m": float(length_m), "width_m": float(width_m),
                                                         "thickness_m": float(thickness_m), "material": str(material)},
                                "sensor": {"position_m": float(position_m)}}
    if mass_kg:
        document["sensor"]["mass_kg"] = float(mass_kg)
        if mass_approximate:
            document["sensor"]["mass_approximate"] = True
    return document


def describe(read: RecordRead, document: dict) -> Described:
    """The measurement of ``read``'s record with the beam ``document`` describes, and the ideal
    beam's modes below the spectrum's top.

    Raises
    ------
    BeamInputError
        A description the library refuses (e.g. a sensor beyond the tip); one line.
    """
    from beam.cli.import_command import format_import, ideal_modes_Hz

    measurement = measurement_from_record(read.record, _FormDocument(document))
    top = float(read.frequency_Hz[-1]) if read.frequency_Hz.size else 0.5 * read.record.rate_Hz
    modes = tuple(f for f in ideal_modes_Hz(measurement, MAX_MODES) if f <= top)
    return Described(measurement=measurement, document=document, modes_Hz=modes, summary=format_import(measurement))


def describe_job(read: RecordRead, document: dict) -> Iterator[sch.Stage[Described]]:
    """:func:`describe` as a scheduler job."""
    yield sch.final(describe(read, document), "beam described")
