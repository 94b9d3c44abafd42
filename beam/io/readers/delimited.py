"""Delimited text: phyphox and Physics Toolbox exports, LabVIEW's headerless text, any CSV/TSV.

The layout is read from the file itself:

* lines starting with ``#``, ``%`` or ``//`` before the data are comments (kept as notes);
* the separator is the one of tab, semicolon and comma that splits the first data lines into
  the same number (>= 2) of cells, in that order of preference; otherwise runs of whitespace;
* the decimal mark is a comma when the separator is not a comma and the cells hold digits
  around a comma (phyphox's "decimal comma" exports, spreadsheets in many locales);
* the first line is a header when it is not all numbers; names may be quoted (phyphox quotes
  every name: ``"Time (s)";"Acceleration x (m/s^2)"``); an empty quoted cell (``""``, phyphox's
  missing value) is read as missing.

phyphox writes five CSV variants (its ``exportTypes``: comma/decimal point, tab/decimal point,
semicolon/decimal point, tab/decimal comma, semicolon/decimal comma), a header of quoted
names such as ``"Time (s)"`` and ``"Linear Acceleration x (m/s^2)"`` and numbers with ten
significant digits in scientific notation (``1.234567890E-3``, with the variant's decimal
mark). Physics Toolbox Sensor Suite writes ``time,gFx,gFy,gFz,TgF`` (g-force meter, in g) or
``time,ax,ay,az,aT`` (linear accelerometer, m/s²), comma or semicolon separated, its time in
seconds or as a clock (``17:23:55:464``, ``2018-10-03 17:23:55.4640``), which is read as
seconds from the first sample. LabVIEW's "Write To Spreadsheet File" writes headerless
tab-separated columns, commonly time then the signal. Parsing is pandas' C reader.
"""

from __future__ import annotations

import csv
import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from beam.errors import BeamInputError
from beam.io.limits import MAX_MEASUREMENT_BYTES
from beam.io.readers.table import Block, RawRecord, find_time_column, looks_like_time, make_columns
from beam.io.text import read_text_file

_COMMENT_PREFIXES = ("#", "%", "//")
_SEPARATORS = ("\t", ";", ",")
_SEPARATOR_NAMES = {"\t": "tab", ";": "';'", ",": "','", r"\s+": "whitespace"}
_NUMBER = re.compile(r"^[+-]?(\d+([.,]\d*)?|[.,]\d+)([eE][+-]?\d+)?$")
_CLOCK = re.compile(r"^\d{1,2}:\d{2}:\d{2}[:.]\d+$")
_PROBE_LINES = 50


def read_delimited(path: Path, text: str | None = None, format_hint: str | None = None) -> RawRecord:
    """Read a delimited text file (module notes).

    Parameters
    ----------
    path : Path
        The file (named in every message).
    text : str, optional
        Its content, when already read (a zip member).
    format_hint : str, optional
        The format's name for the summary (default: recognised from the header).

    Raises
    ------
    BeamInputError
        Not text, no data rows, rows of different lengths, a column that is not numbers.
    """
    if text is None:
        text = read_text_file(path, "record", MAX_MEASUREMENT_BYTES)
    lines = text.splitlines()
    notes: list[str] = []
    first = 0
    while first < len(lines) and (not lines[first].strip() or lines[first].lstrip().startswith(_COMMENT_PREFIXES)):
        if lines[first].strip():
            notes.append(lines[first].strip().lstrip("#%/ ").strip())
        first += 1
    if first >= len(lines):
        raise BeamInputError(f"{path}: no data rows; expected columns of numbers (time and the sensor's signal)")
    probe = [line for line in lines[first:first + _PROBE_LINES] if line.strip()]
    separator = _separator(probe)
    header_cells = _split(probe[0], separator)
    has_header = not all(_numeric(cell) for cell in header_cells if cell != "")
    data_probe = probe[1:] if has_header else probe
    if not data_probe:
        raise BeamInputError(f"{path}: header only, no data rows")
    decimal = _decimal(data_probe, separator)
    body = "\n".join(lines[first + (1 if has_header else 0):])
    try:
        frame = pd.read_csv(
            io.StringIO(body), sep=separator, decimal=decimal, header=None, skipinitialspace=True,
            engine="c", skip_blank_lines=True,
            quotechar='"', comment=None, dtype=str if _has_clock(data_probe, separator) else None,
        )
    except (pd.errors.ParserError, ValueError) as exc:
        raise BeamInputError(f"{path}: cannot read the rows as {_SEPARATOR_NAMES[separator]}-separated numbers "
                             f"({' '.join(str(exc).split())[:160]})") from None
    width = frame.shape[1]
    if has_header:
        names = [cell.strip() for cell in header_cells]
        if len(names) == width + 1 and names[-1] == "":
            names = names[:-1]
        if len(names) != width:
            raise BeamInputError(f"{path}: the header names {len(names)} columns but the rows hold {width}; "
                                 f"expected one name per column ({_SEPARATOR_NAMES[separator]}-separated)")
    else:
        names = [f"column {k}" for k in range(1, width + 1)]
    arrays = [_numbers(path, frame.iloc[:, k], names[k]) for k in range(width)]
    columns = make_columns(names, arrays)
    time = find_time_column(columns)
    if time is None and not has_header and width >= 2 and looks_like_time(columns[0].values):
        time = columns[0]
        notes.append("no header: column 1 increases, read as time")
    decimal_name = "',' decimal" if decimal == "," else "'.' decimal"
    layout = f"{_SEPARATOR_NAMES[separator]} separator, {decimal_name}"
    kind = format_hint or _recognise(path, names, has_header)
    return RawRecord(path, f"{kind} ({layout})", [Block(columns, time)], notes)


def _recognise(path: Path, names: list[str], has_header: bool) -> str:
    lower = [n.lower() for n in names]
    if not has_header:
        return "headerless LabVIEW text" if path.suffix.lower() == ".lvm" else "headerless text"
    if lower and lower[0] == "time (s)" and any("(m/s^2)" in n for n in lower):
        return "phyphox CSV"
    if lower and lower[0] == "time" and ({"gfx", "gfy", "gfz"} & set(lower) or {"ax", "ay", "az"} & set(lower)):
        return "Physics Toolbox Sensor Suite CSV"
    return "text table"


def _split(line: str, separator: str) -> list[str]:
    if separator == r"\s+":
        return line.split()
    return next(csv.reader([line], delimiter=separator, quotechar='"', skipinitialspace=True))


def _separator(probe: list[str]) -> str:
    for separator in _SEPARATORS:
        counts = {len(_split(line, separator)) for line in probe}
        if len(counts) == 1 and counts.pop() >= 2:
            return separator
    counts = {len(line.split()) for line in probe[1:] or probe}
    if len(counts) == 1 and counts.pop() >= 1:
        return r"\s+"
    return ","


def _numeric(cell: str) -> bool:
    return bool(_NUMBER.match(cell.strip().strip('"'))) or cell.strip().lower() in ("nan", "inf", "-inf")


def _decimal(probe: list[str], separator: str) -> str:
    if separator == ",":
        return "."
    cells = [cell.strip() for line in probe for cell in _split(line, separator)]
    return "," if any(re.match(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$", c) for c in cells) else "."


def _has_clock(probe: list[str], separator: str) -> bool:
    cells = _split(probe[0], separator)
    return bool(cells) and (bool(_CLOCK.match(cells[0].strip())) or bool(re.match(r"^\d{4}-\d{2}-\d{2}[ T]", cells[0].strip())))


def _numbers(path: Path, series: pd.Series, name: str) -> np.ndarray:
    """A column as floats: numbers as they are, clocks as seconds from the first row."""
    if series.dtype.kind in "fiu":
        return series.to_numpy(dtype=float)
    text = series.astype(str).str.strip()
    sample = text.iloc[0] if len(text) else ""
    if _CLOCK.match(sample):  # hh:mm:ss:mmm or hh:mm:ss.fff
        parts = text.str.replace(r"^(\d+:\d+:\d+):(\d+)$", r"\1.\2", regex=True)
        seconds = pd.to_timedelta(parts, errors="coerce").dt.total_seconds().to_numpy(dtype=float)
        return seconds - seconds[np.isfinite(seconds)][0]
    if re.match(r"^\d{4}-\d{2}-\d{2}[ T]", sample):
        stamps = pd.to_datetime(text, errors="coerce")
        seconds = (stamps - stamps.dropna().iloc[0]).dt.total_seconds().to_numpy(dtype=float)
        return seconds
    values = pd.to_numeric(text.str.replace(",", ".", regex=False), errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values) & ~text.isin(["", "nan", "NaN"]).to_numpy())
    if bad.size > max(2, values.size // 100):
        raise BeamInputError(f"{path}: column {name!r}: {bad.size} cells are not numbers (row {bad[0] + 1} "
                             f"holds {text.iloc[bad[0]]!r}); expected numbers")
    return values
