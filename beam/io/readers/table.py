"""What every format reader returns: named columns (raw values, as the file holds them) in blocks.

A *block* is one continuous acquisition: the columns of a CSV, one segment of an LVM file, one
group of a TDMS file. A file with several blocks offers them as segments (the strongest is used
unless one is chosen); a file holding several separate *records* (a MATLAB file's structs, an
HDF5 file's groups, arrays of different lengths) has one block of kind ``"record"`` each, chosen
by name. The conversion to SI, the choice of the signal, the cleaning of the time
stamps and the splitting into plucks happen once for every format, in
:mod:`beam.io.readers.signal`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from beam.errors import BeamInputError
from beam.io.readers.units import ColumnMeaning, column_meaning


@dataclass(eq=False)
class Column:
    """One named column of a file.

    Attributes
    ----------
    name : str
        Its name in the file (``"column 2"`` for a file without names).
    values : numpy.ndarray
        The values as the file holds them (float; NaN where a cell is empty or not a number).
    meaning : ColumnMeaning
        Quantity, unit and axis read from the name (and the file's unit field, if any).
    position : int
        1-based position of the column in its block (for ``--column INDEX``).
    """

    name: str
    values: np.ndarray
    meaning: ColumnMeaning
    position: int


@dataclass(eq=False)
class Block:
    """One continuous acquisition of a file.

    Attributes
    ----------
    columns : list of Column
        Every column, the time column included.
    time : Column or None
        The time column (None: time comes from ``rate_Hz`` or ``--rate``).
    rate_Hz : float or None
        Sampling rate stated by the file (LVM ``Delta_X``, TDMS ``wf_increment``, a ``fs``
        variable), None when the file states none.
    start_s : float
        Time of the first sample when the time comes from a rate (s).
    label : str
        How the file names the block (``"segment 2"``, a TDMS group, a MATLAB struct's name).
    kind : str
        ``"segment"``: a part of one acquisition (LVM segments, TDMS groups; the strongest is used
        by default); ``"record"``: a record of its own (a MATLAB struct, an HDF5 group), chosen
        by name.
    """

    columns: list[Column]
    time: Column | None = None
    rate_Hz: float | None = None
    start_s: float = 0.0
    label: str = ""
    kind: str = "segment"

    @property
    def data_columns(self) -> list[Column]:
        """Every column but the time column."""
        return [c for c in self.columns if c is not self.time]


@dataclass
class RawRecord:
    """What a format reader found in a file.

    Attributes
    ----------
    path : Path
        The file.
    format : str
        The format's name as the summary prints it (``"phyphox CSV (';' separator, ',' decimal)"``).
    blocks : list of Block
        At least one.
    notes : list of str
        What the reader wants the user to know (a comment line, the zip member read).
    """

    path: Path
    format: str
    blocks: list[Block]
    notes: list[str] = field(default_factory=list)


def make_columns(names: list[str], arrays: list[np.ndarray], units: list[str | None] | None = None) -> list[Column]:
    """Columns from names and arrays (units: a unit per column the file states outside the name
    (an LVM ``Y_Unit_Label``, a TDMS ``unit_string``), or None)."""
    units = units or [None] * len(names)
    columns = []
    for position, (name, values, unit) in enumerate(zip(names, arrays, units), start=1):
        array = np.asarray(values, dtype=float).reshape(-1)
        columns.append(Column(str(name), array, column_meaning(str(name), unit, "the file's unit field"), position))
    return columns


def find_time_column(columns: list[Column]) -> Column | None:
    """The column whose name says time (the first such), or None."""
    return next((c for c in columns if c.meaning.quantity == "time"), None)


def looks_like_time(values: np.ndarray) -> bool:
    """Whether an unnamed column can be time stamps: finite, at least 4 values, increasing at
    >= 95 % of its steps (a phone's stamps repeat or step back now and then) and overall."""
    finite = values[np.isfinite(values)]
    if finite.size < 4:
        return False
    steps = np.diff(finite)
    return bool(np.mean(steps > 0) >= 0.95 and finite[-1] > finite[0])


def check_rectangular(path: Path, names: list[str], arrays: list[np.ndarray]) -> None:
    """Raise unless every column has the same length."""
    lengths = {name: np.asarray(a).size for name, a in zip(names, arrays)}
    if len(set(lengths.values())) > 1:
        raise BeamInputError(f"{path}: columns differ in length ({lengths}); expected one row per sample")
