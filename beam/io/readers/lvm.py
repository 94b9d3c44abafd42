"""LabVIEW measurement files (``.lvm``) with their standard header.

NI's LVM format (NI tutorial 4139, "Specification of the LabVIEW Measurement File (.lvm)"):
a file header from ``LabVIEW Measurement`` to ``***End_of_Header***`` (``Separator``,
``Decimal_Separator``, ``X_Columns`` = ``No``, ``One`` or ``Multi``, ...), then one or more
segments, each a channel header (``Channels``, ``Samples``, ``Y_Unit_Label``, ``X_Dimension``,
``X0``, ``Delta_X``, one value per channel, ending ``***End_of_Header***``), a line of column
names starting ``X_Value`` and the rows. Each segment is one block (offered as a segment of the
record). Time is the ``X_Value`` column when the file has one, otherwise ``X0 + k Delta_X``;
a channel's unit is its name's or, failing that, its ``Y_Unit_Label``.

Decision: the header is parsed by the maintained ``lvm_read`` package (pyLabDisk, the reader
pyFRF and pyEMA use; it follows NI's description, reads several segments, the decimal
separator and comment columns) rather than a parser of our own: the format has enough corners
(per-segment headers, ``X_Columns``, decimal separators, comments) that a second
implementation would be a maintenance cost without a gain. Its row loop is pure Python
(0.3 s of CPU for 80,000 rows of time and two channels, measured on the development machine),
inside the import budget of 2 s. The
*headerless* two-column text LabVIEW also writes has no header for ``lvm_read`` to read and is
read as plain delimited text (:mod:`beam.io.readers.delimited`).
"""

from __future__ import annotations

import math
from pathlib import Path

import lvm_read
import numpy as np

from beam.errors import BeamInputError
from beam.io.readers.table import Block, RawRecord, make_columns

#: First word of an LVM file with the standard header.
LVM_MAGIC = "LabVIEW Measurement"


def read_lvm(path: Path, text: str) -> RawRecord:
    """Read an LVM file with the standard header (module notes).

    Raises
    ------
    BeamInputError
        No segment, a segment without channels, a channel header that does not match its data.
    """
    try:
        data = lvm_read.read_str(text)
    except (ValueError, SyntaxError, IndexError, KeyError) as exc:
        raise BeamInputError(f"{path}: not a readable LabVIEW measurement file ({' '.join(str(exc).split())[:160]}); "
                             "expected NI's LVM layout: a file header, then per segment a channel header, "
                             "an X_Value line of names and tab-separated rows") from None
    decimal = data.get("Decimal_Separator", ".")
    blocks = []
    for index in range(int(data.get("Segments", 0))):
        segment = data[index]
        table = np.asarray(segment.get("data", np.empty((0, 0))), dtype=float)
        names = [str(n).strip() for n in segment.get("Channel names", [])]
        if table.ndim != 2 or table.shape[0] < 2 or not names:
            raise BeamInputError(f"{path}: segment {index + 1}: no data rows; expected an X_Value line of names and rows")
        if names and names[-1] == "Comment":
            names = names[:-1]
        width = min(len(names), table.shape[1])
        has_x = bool(names) and names[0].lower() == "x_value"
        units = [None] * width
        labels = segment.get("Y_Unit_Label", [])
        offset = 1 if has_x else 0
        for k in range(offset, width):
            label = labels[k - offset] if isinstance(labels, list) and k - offset < len(labels) else None
            units[k] = _unit_label(label)
        if has_x:
            names[0] = "Time (s)"
        columns = make_columns(names[:width], [table[:, k] for k in range(width)], units)
        deltas = [d for d in segment.get("Delta_X", []) if isinstance(d, (int, float)) and math.isfinite(d) and d > 0]
        starts = [x for x in segment.get("X0", []) if isinstance(x, (int, float)) and math.isfinite(x)]
        rate = 1.0 / deltas[0] if deltas else None
        blocks.append(Block(columns, columns[0] if has_x else None, rate, starts[0] if starts else 0.0,
                            label=f"segment {index + 1}"))
    if not blocks:
        raise BeamInputError(f"{path}: no data segment; expected a channel header and rows after the file header")
    layout = f"{len(blocks)} segment(s), decimal {decimal!r}"
    return RawRecord(path, f"LabVIEW LVM ({layout})", blocks)


def _unit_label(label) -> str | None:
    """An LVM ``Y_Unit_Label`` as a unit spelling (``Volts`` -> ``V``), None when empty."""
    if not isinstance(label, str) or not label.strip():
        return None
    text = label.strip()
    return {"volts": "V", "newtons": "N", "meters": "m", "g's": "g"}.get(text.lower(), text)
