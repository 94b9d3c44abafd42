"""Jobs of the "Your record" view: read an uploaded file in any format, describe its beam.

Scheduler jobs (:mod:`dashboard.runtime.scheduler`), no panel: they run on a worker thread of
the session's pool, never on the server's event loop (a 50 MB phone record takes about a
second to parse and another to transform).

:func:`read_job`
    The uploaded bytes are written under their own name (the suffix picks the reader) in a
    temporary folder, read by :func:`beam.io.readers.read_record` and deleted; the record's
    Welch spectrum (:func:`beam.io.anchor.welch_spectrum`, the one ``beam import`` searches for
    peaks) is reduced for drawing and its peaks found (:func:`beam.io.anchor.spectral_peaks`).
:func:`describe_job`
    The form's description of the beam (:func:`beam_document`, the keys of a sidecar) and the
    record become a :class:`~beam.io.measurement.Measurement`
    (:func:`beam.io.measurement.measurement_from_record`), with the ideal beam's modes
    (:func:`beam.cli.import_command.ideal_modes_Hz`, as ``beam import`` prints them).
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from beam.errors import BeamInputError
from beam.io.anchor import LOW_HZ, Peak, spectral_peaks, welch_spectrum
from beam.io.measurement import Measurement, measurement_from_record
from beam.io.readers import Record, read_record
from dashboard.jobs.beam import MAX_UPLOAD_BYTES, upload_size_text
from dashboard.runtime import scheduler as sch

__all__ = ["MAX_SPECTRUM_POINTS", "Described", "RecordRead", "beam_document", "describe", "describe_job",
           "in_words", "read_job", "read_upload", "reduce_spectrum"]

#: Points of the spectrum sent to the browser at most (a 50 MB record's Welch spectrum has ~500,000).
MAX_SPECTRUM_POINTS = 1500
#: Ideal beam modes computed at most (those within the record's spectrum are drawn): as many as
#: ``beam import`` lists.
MAX_MODES = 6
#: The readers' command-line flags (in their messages) as the view names its reading options.
FLAG_WORDS = {
    "--rate HZ": "the sampling rate (Hz) under Reading options",
    "--rate": "the sampling rate (Hz) under Reading options",
    "--time-unit ms|us": "the time column's unit under Reading options",
    "--time-unit": "the time column's unit under Reading options",
    "--unit": "the signal's unit under Reading options",
    "--column NAME|INDEX": "the signal column under Reading options",
    "--column": "the signal column under Reading options",
    "--axis x|y|z": "the signal column under Reading options",
    "--axis": "the signal column under Reading options",
    "--segment K": "the pluck to use under Reading options",
    "--segment": "the pluck to use under Reading options",
}
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
        """What was read, for the view: file, format, channels, signal, rate (Hz), duration (s),
        samples, segments (with the one used), notes (the cleaning report), taps (how many: a record of
        several is calibrated with every tap together), artifacts (what :mod:`beam.io.artifacts` found, in words)."""
        r = self.record
        return {"file": self.file_name, "size_bytes": self.size_bytes, "format": r.format, "channels": list(r.channels),
                "signal": r.signal, "rate_Hz": r.rate_Hz, "duration_s": r.duration_s, "samples": int(r.time_s.size),
                "segments": [(s.start_s, s.end_s, s.peak) for s in r.segments], "segment_used": r.segment_index,
                "notes": list(r.notes), "taps": len(r.taps),
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


def in_words(message: str) -> str:
    """A reader's message with its command-line flags named as the view's reading options."""
    for flag, words in FLAG_WORDS.items():
        message = message.replace(flag, words)
    return message


def read_upload(file_name: str | None, data: bytes | str | None, **options: Any) -> RecordRead:
    """Read an uploaded record file in any supported format (module notes).

    Parameters
    ----------
    file_name : str or None
        The name it was uploaded under (its suffix helps recognise the format).
    data : bytes or str
        Its contents (text, as the upload widget decodes ``text/*`` files, is encoded back to UTF-8).
    **options
        ``column``, ``rate``, ``time_unit``, ``unit``, ``segment`` of
        :func:`beam.io.readers.read_record` (None: not given).

    Raises
    ------
    BeamInputError
        No file, one larger than :data:`~dashboard.jobs.beam.MAX_UPLOAD_BYTES`, or anything the
        readers refuse; one line naming the file.
    """
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
            record = read_record(path, **{k: v for k, v in options.items() if v is not None})
        except BeamInputError as exc:  # name the uploaded file, not the temporary path
            raise BeamInputError(in_words(str(exc).replace(f"{tmp}/", ""))) from None
        except (UnicodeDecodeError, OSError) as exc:
            raise BeamInputError(f"{name}: cannot read the upload ({type(exc).__name__})") from None
    record.path = Path(name)
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
    return RecordRead(file_name=file_name or name, size_bytes=len(data), record=record, frequency_Hz=frequency,
                      psd_db=psd_db, peaks=peaks)


def read_job(file_name: str | None, data: bytes | str | None, **options: Any) -> Iterator[sch.Stage[RecordRead]]:
    """:func:`read_upload` as a scheduler job (a progress stage, then the final read)."""
    yield sch.progress(0.1, f"reading {file_name}")
    read = read_upload(file_name, data, **options)
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
