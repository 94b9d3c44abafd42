"""Records in the files labs and phones write, read into one :class:`Record` (SI units).

:func:`read_record` recognises the format from the file's first bytes (zip, NumPy, MATLAB,
HDF5, TDMS, LabVIEW's header) and, for text, from its suffix and header; ``format=`` forces a
reader. One small reader per format turns the file into named columns
(:mod:`beam.io.readers.delimited`: phyphox, Physics Toolbox Sensor Suite, LabVIEW's headerless
text, any CSV/TSV/whitespace table; :mod:`beam.io.readers.lvm`: LabVIEW ``.lvm`` with its
header; :mod:`beam.io.readers.binary`: ``.npy``, ``.npz``, ``.mat`` v5 and v7.3, HDF5, ``.tdms``;
:func:`read_phyphox_zip`: phyphox's zip export), and :mod:`beam.io.readers.signal` does the
rest the same way for all: units to SI, time, the signal, the stamps, the plucks.

Every error is a :class:`beam.errors.BeamInputError` naming the file and what was expected;
one that a reading option resolves is a :class:`beam.io.readers.findings.ReadingError` (the
problem, the option, what was found), which each front end phrases in its own words. A file
that is no record at all (an image, a PDF, a spreadsheet workbook) is named as what it is.
What the reader decided is in :attr:`Record.findings`.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

from beam.errors import BeamInputError
from beam.io.limits import MAX_MEASUREMENT_BYTES
from beam.io.readers.binary import read_hdf5, read_mat, read_npy, read_npz, read_tdms
from beam.io.readers.delimited import read_delimited
from beam.io.readers.findings import COMMAND_LINE, Finding, Hint, Phrasing, ReadingError
from beam.io.readers.lvm import LVM_MAGIC, read_lvm
from beam.io.readers.signal import Record, Segment, build_record
from beam.io.readers.table import RawRecord
from beam.io.text import read_text_file

__all__ = ["COMMAND_LINE", "FORMATS", "Finding", "Hint", "Phrasing", "ReadingError", "Record", "Segment", "detect_format",
           "read_raw", "read_record"]

#: ``format=`` names and what each reads.
FORMATS: dict[str, str] = {
    "text": "CSV/TSV/whitespace text with or without a header (phyphox, Physics Toolbox, LabVIEW's headerless text)",
    "phyphox-zip": "phyphox's zip export (one CSV per sensor, meta/)",
    "lvm": "LabVIEW .lvm with the standard header",
    "tdms": "NI .tdms (npTDMS)",
    "mat": "MATLAB .mat, v5 (scipy) or v7.3 (h5py)",
    "hdf5": "HDF5 (h5py): a group of named arrays per record",
    "npy": "NumPy .npy",
    "npz": "NumPy .npz",
}

_MAGIC = (
    (b"PK\x03\x04", "phyphox-zip"),
    (b"\x93NUMPY", "npy"),
    (b"MATLAB", "mat"),
    (b"\x89HDF", "hdf5"),  # a MATLAB v7.3 file starts with its text header (a 512-byte user block)
    (b"TDSm", "tdms"),
)
_SUFFIX = {".zip": "phyphox-zip", ".npy": "npy", ".npz": "npz", ".mat": "mat", ".tdms": "tdms", ".lvm": "text",
           ".h5": "hdf5", ".hdf5": "hdf5"}
#: First bytes of files that are no record, and what they are.
_NOT_RECORDS = ((b"\x89PNG", "a PNG image"), (b"\xff\xd8\xff", "a JPEG image"), (b"GIF8", "a GIF image"),
                (b"%PDF", "a PDF document"), (b"\xd0\xcf\x11\xe0", "an old Office document (.xls/.doc)"))
#: Members of a zip that make it an office document, not a phyphox export.
_OFFICE_MEMBERS = {"xl/workbook.xml": "an Excel workbook (.xlsx): save the sheet as CSV",
                   "word/document.xml": "a Word document", "content.xml": "an OpenDocument file: save the sheet as CSV"}


def detect_format(path: str | os.PathLike[str]) -> str:
    """The ``format=`` name of a file, from its first bytes, then its suffix (text otherwise).

    Raises
    ------
    BeamInputError
        A missing file or a directory.
    """
    path = Path(path)
    try:
        with open(path, "rb") as handle:
            head = handle.read(64)
    except FileNotFoundError:
        raise BeamInputError(f"{path}: not found") from None
    except IsADirectoryError:
        raise BeamInputError(f"{path}: is a directory, expected a record file") from None
    except (OSError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise BeamInputError(f"{path}: cannot open: {reason}") from None
    if head.startswith(b"PK\x03\x04") and path.suffix.lower() == ".npz":
        return "npz"
    for magic, name in _MAGIC:
        if head.startswith(magic):
            return name
    if head.lstrip(b"\xef\xbb\xbf").startswith(LVM_MAGIC.encode()):
        return "lvm"
    return _SUFFIX.get(path.suffix.lower(), "text")


def read_raw(path: str | os.PathLike[str], format: str | None = None) -> RawRecord:
    """The columns of a file, before any choice (see :func:`read_record`)."""
    path = Path(path)
    name = format or detect_format(path)
    if name not in FORMATS:
        raise ReadingError(None, "unknown", Hint("expected", tuple(FORMATS)), option="format", value=repr(name))
    if format is None:
        _refuse_non_record(path)
    try:
        return _read_raw(path, name)
    except BeamInputError:
        raise
    except Exception as exc:  # a library's own error on a malformed file: one line naming the file
        raise BeamInputError(f"{path}: not a readable {FORMATS[name]} file ({type(exc).__name__}: "
                             f"{' '.join(str(exc).split())[:160]})") from None


def _refuse_non_record(path: Path) -> None:
    """A file that is no record (an image, a document) named as what it is, never echoed."""
    with open(path, "rb") as handle:
        head = handle.read(16)
    what = next((kind for magic, kind in _NOT_RECORDS if head.startswith(magic)), None)
    if what is None and head.startswith(b"PK\x03\x04"):
        try:
            with zipfile.ZipFile(path) as archive:
                members = set(archive.namelist())
        except (zipfile.BadZipFile, OSError):
            return
        what = next((kind for member, kind in _OFFICE_MEMBERS.items() if member in members), None)
    if what is not None:
        raise BeamInputError(f"{path}: binary content ({what}), not a record; expected a record file "
                             f"({', '.join(FORMATS)})")


def _read_raw(path: Path, name: str) -> RawRecord:
    if name == "npy":
        return read_npy(path)
    if name == "npz":
        return read_npz(path)
    if name == "mat":
        return read_mat(path)
    if name == "hdf5":
        return read_hdf5(path)
    if name == "tdms":
        return read_tdms(path)
    if name == "phyphox-zip":
        return read_phyphox_zip(path)
    text = read_text_file(path, "record", MAX_MEASUREMENT_BYTES)
    if name == "lvm" or text.lstrip().startswith(LVM_MAGIC):
        return read_lvm(path, text)
    return read_delimited(path, text)


def read_phyphox_zip(path: Path) -> RawRecord:
    """phyphox's zip export: one CSV per export set, plus ``meta/`` (device and time), which
    is not data. The set holding acceleration is read (the first one, in the archive's order;
    the others are listed)."""
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as exc:
        raise BeamInputError(f"{path}: not a readable zip archive ({exc})") from None
    with archive:
        office = next((kind for member, kind in _OFFICE_MEMBERS.items() if member in archive.namelist()), None)
        if office is not None:
            raise BeamInputError(f"{path}: {office}, not a record")
        members = [m for m in archive.infolist() if m.filename.lower().endswith(".csv") and not m.is_dir()
                   and not m.filename.split("/")[-2:-1] == ["meta"] and "/meta/" not in f"/{m.filename}"]
        if not members:
            raise BeamInputError(f"{path}: no data CSV in the zip; expected phyphox's export (one CSV per sensor, "
                                 "e.g. 'Raw Data.csv' or 'Accelerometer.csv', and a meta/ folder)")
        if sum(m.file_size for m in members) > MAX_MEASUREMENT_BYTES:
            raise BeamInputError(f"{path}: the CSVs in the zip are larger than {MAX_MEASUREMENT_BYTES // 2**20} MiB")
        records = []
        for member in members:
            text = archive.read(member).decode("utf-8-sig", errors="replace")
            records.append((member.filename, read_delimited(path, text, format_hint="phyphox zip export")))
        meta = [m.filename for m in archive.infolist() if "meta/" in m.filename and not m.is_dir()]
    with_motion = [(name, r) for name, r in records
                   if any(c.meaning.quantity in ("acceleration", "velocity", "displacement") for c in r.blocks[0].columns)]
    name, record = (with_motion or records)[0]
    record.notes.insert(0, f"zip member {name!r} read" + (f" (also in the zip: {', '.join(n for n, _ in records if n != name)})"
                                                          if len(records) > 1 else "")
                        + (f"; metadata in {', '.join(meta)}" if meta else ""))
    return record


def read_record(
    path: str | os.PathLike[str], *, format: str | None = None, record: str | int | None = None,
    column: str | None = None, axis: str | None = None, rate: float | None = None, time_unit: str | None = None,
    unit: str | None = None, segment: int | None = None,
) -> Record:
    """Read a record from any supported file (module notes).

    Parameters
    ----------
    path : str or path-like
        The file.
    format : str, optional
        A key of :data:`FORMATS` (default: recognised).
    record : str or int, optional
        For a file holding several records (a MATLAB file's structs, an HDF5 file's groups): which,
        by name or 1-based position (default: the longest; all are listed in the findings).
    column : str, optional
        The signal's column, by name or 1-based position.
    axis : {"x", "y", "z"}, optional
        The signal's axis.
    rate : float, optional
        Sampling rate (Hz), for a file without time.
    time_unit : {"s", "ms", "us"}, optional
        Unit of the time column.
    unit : str, optional
        Unit of the signal column (g, m/s^2, mm/s, m, µm, microstrain, ...;
        :data:`beam.io.readers.units.SIGNAL_UNITS`), or ``"arbitrary"`` for a signal of unknown
        scale (``"arbitrary-acceleration"`` when the column's name does not say what it measures).
    segment : int, optional
        1-based pluck or file segment to use (default: the strongest).

    Returns
    -------
    Record
        Time (s, from 0), the signal (SI, or arbitrary units), what was decided and why
        (:attr:`Record.findings`) and everything done to them.

    Raises
    ------
    BeamInputError
        One line naming the file and what was expected (a :class:`ReadingError` when a
        reading option resolves it).
    """
    raw = read_raw(path, format)
    return build_record(raw, record=record, column=column, axis=axis, rate=rate, time_unit=time_unit, unit=unit,
                        segment=segment)
