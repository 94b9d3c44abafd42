"""Hostile measurement files: generated malformed CSV and TOML give exactly one clear error.

Property-based (hypothesis, derandomised, no example database, so CI sees the same inputs):

* :func:`test_generated_csv` - a valid table of any kind (input voltage_V, force_N or none;
  output displacement_m, velocity_m_s or acceleration_m_s2; uniform or irregular time) with
  one mutation from :data:`CSV_MUTATIONS`, each mutation drawn 12 times (missing/extra/renamed/
  reordered columns, a second input or output, a column in another unit, no header,
  NaN/inf/1e309, text in a cell, time repeated or swapped, a gap of more than 100 median steps,
  an output clipped for more than half the record, empty, header only, one row, non-UTF-8 and
  NUL bytes, UTF-16, trailing commas, wrong separators, blank line inside) or a tolerated
  variant (BOM, CRLF and CR line endings, spaces, trailing blank lines, 1e308, subnormals,
  irregular time, a dropped input: a free response). A bad file gives one BeamInputError whose
  one line starts with the file and names the line; a good one reads back the exact values.
* :func:`test_generated_sidecar_of_a_force_record` - ``[force]`` missing or bad, ``[sensor]
  range`` bad or clipping the record, an optional patch.
* :func:`test_generated_sidecar` / :func:`test_generated_config` - the same for TOML: missing
  or unknown keys and tables, wrong types (string, boolean, array, date, table, 400-digit
  integer), NaN/inf, negative or zero lengths and densities, values outside the model's range,
  patch or sensor outside the beam, bad nominal values, sampling that overflows.
* :func:`test_arbitrary_content_raises_only_beam_input_error` - random bytes, random text and
  byte-flipped valid files fed to ``read_measurement``, ``read_sidecar`` and ``load_config``:
  nothing but BeamInputError may escape.
* :func:`test_valid_files_round_trip_bit_exact` - write_measurement -> read_measurement, every
  kind of record, with or without a sensor range; the classic tuple form too.

Decisions: CRLF and CR-only line endings and a UTF-8 byte-order mark are accepted (spreadsheet
exports); a trailing comma is refused with a hint (it is an empty fourth cell).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from beam.errors import BeamInputError
from beam.io.config import load_config
from beam.io.limits import LENGTH_RANGE_M, LINEAR_DENSITY_RANGE_KG_M
from beam.io.measurement import (
    ALL_COLUMNS,
    CSV_COLUMNS,
    INPUT_COLUMNS,
    OUTPUT_COLUMNS,
    measurement_csv_text,
    read_measurement,
    read_sidecar,
    write_measurement,
)
from beam.physics.geometry import BeamGeometry

HEADER = ",".join(CSV_COLUMNS)
SIDECAR = """title = "bench test"
[beam]
length_m = 0.4573
linear_density_kg_m = 0.093
[patch]
start_m = 0.15
end_m = 0.25
[sensor]
position_m = 0.27438
"""
CONFIG_EXTRA = """[parameters]
bending_stiffness_Nm2 = 0.491
patch_coupling_NmV = 0.01746
[excitation]
kind = "pulse"
amplitude_V = 1.0
width_s = 0.01
[sampling]
rate_Hz = 1000.0
duration_s = 0.5
"""

#: Shared hypothesis settings: reproducible, no deadline (the first example imports scipy).
FUZZ = dict(
    deadline=None, derandomize=True, database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
#: Generated inputs per test (the README section "Limits and robustness" gives the totals).
CSV_EXAMPLES_PER_MUTATION = 12
SIDECAR_EXAMPLES = 150
FORCE_SIDECAR_EXAMPLES = 60
CONFIG_EXAMPLES = 100
JUNK_EXAMPLES = 500
ROUND_TRIP_EXAMPLES = 60


@dataclass
class Expect:
    """What reading a generated file must give: the values, or an error with these fragments."""

    valid: bool
    fragments: list[str] = field(default_factory=list)
    arrays: dict[str, np.ndarray] | None = None
    uniform: bool | None = None


def error(*fragments: str) -> Expect:
    return Expect(False, list(fragments))


def _assert_one_line_error(call, path: Path, fragments: list[str]) -> str:
    """``call()`` raises exactly one BeamInputError, one line, starting with ``path``, naming the fragments."""
    with pytest.raises(BeamInputError) as info:
        call()
    message = str(info.value)
    assert type(info.value) is BeamInputError
    assert "\n" not in message and "\r" not in message, message
    assert message.startswith(f"{path}: "), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    return message


# ---------------------------------------------------------------------------------------------
# CSV: a valid table and its mutations
# ---------------------------------------------------------------------------------------------

finite_floats = st.floats(allow_nan=False, allow_infinity=False)

#: A sidecar every kind of record reads with: a patch (voltage_V) and a force position (force_N).
#: The sidecar of the generated records: any input, and the strip's section (a strain output needs it).
SIDECAR_ANY_INPUT = (SIDECAR.replace("linear_density_kg_m = 0.093\n", "linear_density_kg_m = 0.093\nwidth_m = 0.03\nthickness_m = 0.002\n")
                     + "[force]\nposition_m = 0.3\n")


@dataclass
class Table:
    """A valid record: the header and its columns (time first)."""

    names: tuple[str, ...]
    arrays: list[np.ndarray]

    @property
    def time_s(self) -> np.ndarray:
        return self.arrays[0]

    def mapping(self) -> dict[str, np.ndarray]:
        return dict(zip(self.names, self.arrays))

    def with_time(self, time_s: np.ndarray) -> Table:
        return Table(self.names, [time_s] + self.arrays[1:])


@st.composite
def tables(draw, min_rows: int = 2, max_rows: int = 30, kinds: bool = True) -> Table:
    """Time (any start, rates from 1 mHz to 1 GHz, uniform or jittered by up to 40 % of a step) and
    arbitrary finite values: an input (voltage_V, force_N or none) and an output (displacement_m,
    velocity_m_s or acceleration_m_s2; distinct values, so that no run of equal samples looks
    clipped). ``kinds=False`` gives the classic time_s,voltage_V,displacement_m on a uniform grid."""
    n = draw(st.integers(min_rows, max_rows))
    rate = draw(st.sampled_from([1000.0, 2048.0, 51200.0]) | st.floats(1e-3, 1e9))
    start = draw(st.sampled_from([0.0, 12.5]) | st.floats(-1e3, 1e3))
    time_s = start + np.arange(n) / rate
    if kinds and draw(st.booleans()):
        jitter = np.array(draw(st.lists(st.floats(-0.2, 0.2), min_size=n, max_size=n)))
        time_s = start + (np.arange(n) + jitter) / rate
        assume(np.all(np.diff(time_s) > 0))
    input_column = draw(st.sampled_from(["voltage_V", "force_N", None])) if kinds else "voltage_V"
    output_column = draw(st.sampled_from(list(OUTPUT_COLUMNS))) if kinds else "displacement_m"
    names = ("time_s",) + ((input_column,) if input_column else ()) + (output_column,)
    arrays = [time_s]
    if input_column:
        arrays.append(np.array(draw(st.lists(finite_floats, min_size=n, max_size=n))))
    arrays.append(np.array(draw(st.lists(finite_floats, min_size=n, max_size=n, unique=True))))
    return Table(names, arrays)


def _rows(table: Table) -> list[list[str]]:
    return [[repr(value) for value in row] for row in zip(*(a.tolist() for a in table.arrays))]


def _csv(table: Table) -> str:
    return measurement_csv_text(*table.arrays, names=table.names)


def _text(header: list[str] | None, rows: list[list[str]], separator: str = ",", newline: str = "\n") -> str:
    lines = ([separator.join(header)] if header is not None else []) + [separator.join(r) for r in rows]
    return newline.join(lines) + newline


def _valid(table: Table, uniform: bool | None = None) -> Expect:
    return Expect(True, arrays=table.mapping(), uniform=uniform)


def m_tolerated_formatting(draw, table):
    """BOM, CRLF or CR line endings, spaces around names and numbers, blank lines at the end."""
    newline = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    pad = draw(st.sampled_from(["", " ", "  ", "\t"]))
    header = [f"{pad}{name}{pad}" for name in table.names]
    rows = [[f"{pad}{cell}{pad}" for cell in row] for row in _rows(table)]
    text = _text(header, rows, newline=newline) + draw(st.sampled_from(["", newline, newline * 3, " \n\n"]))
    bom = draw(st.sampled_from(["", "\ufeff"]))
    return (bom + text).encode("utf-8"), _valid(table)


def m_extreme_finite_values(draw, table):
    """1e308, -1.7976931348623157e308, subnormals and signed zeros are finite: accepted exactly."""
    arrays = [a.copy() for a in table.arrays]
    specials = [1e308, -1.7976931348623157e308, 5e-324, -0.0, 2.2250738585072014e-308]
    for column in arrays[1:]:
        column[draw(st.integers(0, column.size - 1))] = draw(st.sampled_from(specials))
    changed = Table(table.names, arrays)
    return _csv(changed).encode(), _valid(changed)


def m_number_only_python_reads(draw, table):
    """``1_000``, Arabic-Indic or full-width digits: Python's ``float`` reads them, so they are accepted."""
    arrays = [a.copy() for a in table.arrays]
    token = draw(st.sampled_from(["1_000", "\u0661\u0662", "\uff13.5", "-2_5e-1_0"]))
    row = draw(st.integers(0, table.time_s.size - 1))
    arrays[1][row] = float(token)
    changed = Table(table.names, arrays)
    rows = _rows(changed)
    rows[row][1] = token
    return _text(list(table.names), rows).encode(), _valid(changed)


def m_missing_column(draw, table):
    """Without time_s or without the output: an error; without the input: a valid free response."""
    dropped = draw(st.integers(0, len(table.names) - 1))
    keep = [i for i in range(len(table.names)) if i != dropped]
    header = [table.names[i] for i in keep]
    rows = [[row[i] for i in keep] for row in _rows(table)]
    name = table.names[dropped]
    if name in INPUT_COLUMNS:
        return _text(header, rows).encode(), _valid(Table(tuple(header), [table.arrays[i] for i in keep]))
    fragment = "missing column time_s" if name == "time_s" else "missing column: an output"
    return _text(header, rows).encode(), error("line 1", fragment)


extra_names = st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,12}", fullmatch=True).filter(lambda s: s not in ALL_COLUMNS)


def m_extra_column(draw, table):
    name = draw(extra_names)
    position = draw(st.integers(0, len(table.names)))
    header = list(table.names)
    header.insert(position, name)
    rows = [row[:position] + ["1.0"] + row[position:] for row in _rows(table)]
    return _text(header, rows).encode(), error("line 1", f"unexpected column {name!r}")


def m_second_input_or_output(draw, table):
    """A second input or output column (or the same one twice): one error naming both."""
    extra = draw(st.sampled_from(list(INPUT_COLUMNS) + list(OUTPUT_COLUMNS)))
    header = list(table.names)
    position = 1 if extra in INPUT_COLUMNS else len(header)
    header.insert(position, extra)
    rows = [row[:position] + ["1.0"] + row[position:] for row in _rows(table)]
    if extra in table.names:
        fragment = f"column {extra} is repeated"
    else:
        kind = INPUT_COLUMNS if extra in INPUT_COLUMNS else OUTPUT_COLUMNS
        same = [n for n in header if n in kind]
        if len(same) > 1:
            fragment = f"two {'input' if kind is INPUT_COLUMNS else 'output'} columns {' and '.join(same)}"
        else:  # an input added to a free record: a valid header, but no data for it... it has 1.0s
            changed = Table(tuple(header), table.arrays[:1] + [np.ones(table.time_s.size)] + table.arrays[1:])
            return _text(header, rows).encode(), _valid(changed)
    return _text(header, rows).encode(), error("line 1", fragment)


def m_wrong_unit(draw, table):
    """A data column in another unit (acceleration_g, force_kN, ...): refused with the name to use."""
    index = draw(st.integers(1, len(table.names) - 1))
    quantity = table.names[index].split("_")[0]
    header = list(table.names)
    header[index] = f"{quantity}_{draw(st.sampled_from(['g', 'mm', 'kN', 'mV', 'mm_s', 'um', 'in']))}"
    return _text(header, _rows(table)).encode(), error("line 1", f"unexpected column {header[index]!r}", "is read in")


def m_renamed_column(draw, table):
    index = draw(st.integers(0, len(table.names) - 1))
    header = list(table.names)
    header[index] = draw(extra_names)
    return _text(header, _rows(table)).encode(), error("line 1", "header must be exactly")


def m_reordered_columns(draw, table):
    count = len(table.names)
    order = draw(st.permutations(list(range(count))).filter(lambda p: list(p) != list(range(count))))
    header = [table.names[i] for i in order]
    rows = [[row[i] for i in order] for row in _rows(table)]
    return _text(header, rows).encode(), error("line 1", "wrong order")


def m_no_header(draw, table):
    return _text(None, _rows(table)).encode(), error("line 1", "header is missing")


def m_non_finite_cell(draw, table):
    rows = _rows(table)
    row, column = draw(st.integers(0, len(rows) - 1)), draw(st.integers(0, len(table.names) - 1))
    rows[row][column] = draw(st.sampled_from(["nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e309", "-1e400"]))
    expect = error(f"line {row + 2}", f"{table.names[column]} = ", "is not finite")
    return _text(list(table.names), rows).encode(), expect


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


junk_cells = st.text(
    st.characters(blacklist_characters=",\r\n\x00", blacklist_categories=("Cs",)), max_size=12
).filter(lambda s: not _is_float(s.strip()))


def m_text_cell(draw, table):
    rows = _rows(table)
    row, column = draw(st.integers(0, len(rows) - 1)), draw(st.integers(0, len(table.names) - 1))
    rows[row][column] = draw(junk_cells)
    expect = error(f"line {row + 2}", f"{table.names[column]} = ", "not a number")
    return _text(list(table.names), rows).encode(), expect


def m_time_not_increasing(draw, table):
    time_s = table.time_s.copy()
    k = draw(st.integers(1, time_s.size - 1))
    if draw(st.booleans()):
        time_s[k] = time_s[k - 1]  # a repeated sample
    else:
        time_s[k - 1], time_s[k] = time_s[k], time_s[k - 1]  # out of order
    return _csv(table.with_time(time_s)).encode(), error(f"line {k + 2}", "does not increase")


def _longer(table: Table, n: int = 8) -> Table:
    """The table with at least ``n`` rows (a uniform grid, values 1, 2, ...) for time mutations."""
    if table.time_s.size >= n:
        return table
    step = table.time_s[1] - table.time_s[0]
    return Table(table.names, [table.time_s[0] + np.arange(n) * step] + [np.arange(1.0, n + 1) for _ in table.arrays[1:]])


def m_irregular_time(draw, table):
    """A stamp moved by 5-45 % of a step: accepted, read as given, not uniform."""
    table = _longer(table)
    time_s = table.time_s
    step = (time_s[-1] - time_s[0]) / (time_s.size - 1)
    k = draw(st.integers(1, time_s.size - 1))
    shifted = time_s.copy()
    shifted[k] += draw(st.sampled_from([-1.0, 1.0])) * draw(st.floats(0.05, 0.45)) * step
    assume(np.all(np.diff(shifted) > 0) and np.median(np.diff(table.time_s)) > 0)
    uniform = bool(np.all(np.abs(np.diff(table.time_s) - step) <= 0.01 * step))  # the base grid was uniform
    changed = table.with_time(shifted)
    return _csv(changed).encode(), _valid(changed, uniform=False if uniform else None)


def m_gap(draw, table):
    """A step of more than 100 median steps: a hole in the record."""
    table = _longer(table)
    time_s = table.time_s.copy()
    k = draw(st.integers(1, time_s.size - 1))
    step = float(np.median(np.diff(time_s)))
    time_s[k:] += draw(st.floats(100.5, 1e4)) * step
    assume(np.isfinite(time_s).all() and np.all(np.diff(time_s) > 0))
    return _csv(table.with_time(time_s)).encode(), error(f"line {k + 2}", "a hole in the record")


def m_clipped(draw, table):
    """An output saturated for more than half of the record (flat runs at its extremes): refused."""
    table = _longer(table, 12)
    n = table.time_s.size
    level = draw(st.sampled_from([9.80665, 98.0665, 1e-3, 0.02]))
    output = np.array([(-1.0) ** (k // 4) for k in range(n)]) * level  # runs of 4 at +-level
    output[0] = output[-1] = 0.5 * level  # inside the record
    changed = Table(table.names, table.arrays[:-1] + [output])
    return _csv(changed).encode(), error("are clipped", "more than half")


def m_empty(draw, table):
    return draw(st.sampled_from([b"", b"\n", b" \n\n", b"\r\n\r\n", "\ufeff".encode()])), error("empty file")


def m_header_only(draw, table):
    return (",".join(table.names) + draw(st.sampled_from(["", "\n", "\r\n", "\n\n  \n"]))).encode(), error("header only")


def m_one_row(draw, table):
    return _text(list(table.names), _rows(table)[:1]).encode(), error("line 2", "the only data row")


def m_not_utf8(draw, table):
    rows = _rows(table)
    row = draw(st.integers(0, len(rows) - 1))
    lines = [",".join(table.names).encode()] + [",".join(r).encode() for r in rows]
    lines[row + 1] += b" " + draw(st.sampled_from([b"\xb5m", b"\xe9", b"\xff", b"\xc3", b"\x80"]))
    return b"\n".join(lines) + b"\n", error(f"line {row + 2}", "not UTF-8")


def m_nul_byte(draw, table):
    content = _csv(table).encode()
    position = draw(st.integers(0, len(content)))
    return content[:position] + b"\x00" + content[position:], error("binary content")


def m_utf16(draw, table):
    return _csv(table).encode("utf-16"), error("binary content")


def m_trailing_comma(draw, table):
    rows = _rows(table)
    if draw(st.booleans()):
        text = _text(list(table.names) + [""], [r + [""] for r in rows])
        return text.encode(), error("line 1", "trailing comma")
    return _text(list(table.names), [r + [""] for r in rows]).encode(), error("line 2", "trailing comma")


def m_other_separator(draw, table):
    separator = draw(st.sampled_from([";", "\t"]))
    return _text(list(table.names), _rows(table), separator=separator).encode(), error("line 1", "separated by commas")


def m_blank_line_inside(draw, table):
    rows = _rows(table)
    k = draw(st.integers(1, len(rows) - 1))
    lines = [",".join(table.names)] + [",".join(r) for r in rows]
    lines.insert(k + 1, draw(st.sampled_from(["", " ", "\t"])))
    return ("\n".join(lines) + "\n").encode(), error(f"line {k + 2}", "empty row")


def m_decimal_comma(draw, table):
    rows = _rows(table)
    row = draw(st.integers(0, len(rows) - 1))
    rows[row][1] = rows[row][1].replace(".", ",") if "." in rows[row][1] else rows[row][1] + ",5"
    return _text(list(table.names), rows).encode(), error(f"line {row + 2}", f"{len(table.names) + 1} cell(s)")


def m_time_span_overflows(draw, table):
    time_s = np.linspace(-1.0, 1.0, table.time_s.size) * 1.7e308  # finite stamps, the span overflows
    return _csv(table.with_time(time_s)).encode(), error("time_s", "overflows")


CSV_MUTATIONS = [
    m_tolerated_formatting, m_extreme_finite_values, m_number_only_python_reads, m_missing_column, m_extra_column,
    m_second_input_or_output, m_wrong_unit, m_renamed_column,
    m_reordered_columns, m_no_header, m_non_finite_cell, m_text_cell, m_time_not_increasing, m_irregular_time, m_gap,
    m_clipped, m_empty, m_header_only, m_one_row, m_not_utf8, m_nul_byte, m_utf16, m_trailing_comma,
    m_other_separator, m_blank_line_inside, m_decimal_comma, m_time_span_overflows,
]


@st.composite
def csv_cases(draw, mutation=None) -> tuple[str, bytes, Expect]:
    mutation = draw(st.sampled_from(CSV_MUTATIONS)) if mutation is None else mutation
    content, expect = mutation(draw, draw(tables()))
    return mutation.__name__, content, expect


def _write(directory: Path, name: str, content: bytes | str) -> Path:
    path = directory / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    return path


def check_csv_case(directory: Path, content: bytes, expect: Expect) -> None:
    """Read a generated CSV (with a sidecar that suits every input) and check the outcome."""
    csv_path = _write(directory, "run.csv", content)
    _write(directory, "run.toml", SIDECAR_ANY_INPUT)
    if expect.valid:
        read = read_measurement(csv_path)
        assert read.columns == tuple(expect.arrays)
        for column, expected in expect.arrays.items():
            assert getattr(read, column).tobytes() == np.asarray(expected, dtype=float).tobytes(), column
        if expect.uniform is not None:
            assert read.uniform is expect.uniform
    else:
        _assert_one_line_error(lambda: read_measurement(csv_path), csv_path, expect.fragments)


@pytest.mark.parametrize("mutation", CSV_MUTATIONS, ids=[m.__name__ for m in CSV_MUTATIONS])
def test_generated_csv(tmp_path, mutation):
    """Every mutation, on tables of every kind (input voltage_V, force_N or none; output
    displacement_m, velocity_m_s or acceleration_m_s2; uniform or jittered time)."""

    @settings(max_examples=CSV_EXAMPLES_PER_MUTATION, **FUZZ)
    @given(case=csv_cases(mutation))
    def check(case):
        _, content, expect = case
        check_csv_case(tmp_path, content, expect)

    check()


# ---------------------------------------------------------------------------------------------
# TOML: sidecar and config mutations
# ---------------------------------------------------------------------------------------------

GEOMETRY_KEYS = [("beam", "length_m"), ("beam", "linear_density_kg_m"), ("patch", "start_m"), ("patch", "end_m"),
                 ("sensor", "position_m")]
WRONG_TYPES = [('"0.4"', "string"), ("true", "boolean"), ("[0.4]", "array"), ("1979-05-27", "date"),
               ("{ value = 0.4 }", "table")]


def _set(text: str, table: str, key: str, value: str | None) -> str:
    """Replace (or with None delete) ``key = ...`` inside ``[table]``."""
    lines = text.splitlines()
    current = None
    for i, line in enumerate(lines):
        stripped = line.strip()
        if stripped.startswith("["):
            current = stripped.strip("[]").strip()
        elif current == table and stripped.split("=")[0].strip() == key:
            if value is None:
                del lines[i]
            else:
                lines[i] = f"{key} = {value}"
            return "\n".join(lines) + "\n"
    raise AssertionError(f"no [{table}] {key}")  # pragma: no cover


def t_tolerated(draw, text):
    """CRLF, BOM, comments and integer values are fine."""
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    text = _set(text, "beam", "length_m", "1")
    text = text.replace("\n", f"  # comment{newline}" if draw(st.booleans()) else newline)
    return (draw(st.sampled_from(["", "\ufeff"])) + text).encode(), Expect(True)


def t_missing_key(draw, text):
    table, key = draw(st.sampled_from(GEOMETRY_KEYS))
    return _set(text, table, key, None).encode(), error(f"[{table}] {key}: missing key")


def t_missing_table(draw, text):
    table = draw(st.sampled_from(["beam", "patch", "sensor"]))
    lines, out, skipping = text.splitlines(), [], False
    for line in lines:
        if line.startswith("["):
            skipping = line == f"[{table}]"
        if not skipping:
            out.append(line)
    return ("\n".join(out) + "\n").encode(), error(f"[{table}]: missing table")


def t_wrong_type(draw, text):
    table, key = draw(st.sampled_from(GEOMETRY_KEYS))
    value, kind = draw(st.sampled_from(WRONG_TYPES))
    return _set(text, table, key, value).encode(), error(f"[{table}] {key}: must be a number, got {kind}")


def t_not_finite(draw, text):
    table, key = draw(st.sampled_from(GEOMETRY_KEYS))
    value = draw(st.sampled_from(["nan", "inf", "-inf", "+nan", "1" + "0" * 400, "-1" + "0" * 400]))
    return _set(text, table, key, value).encode(), error(f"[{table}] {key}: must be finite")


def t_too_many_digits(draw, text):
    table, key = draw(st.sampled_from(GEOMETRY_KEYS))
    return _set(text, table, key, "1" * 5000).encode(), error("more than 4300 digits")


def t_not_positive(draw, text):
    key = draw(st.sampled_from(["length_m", "linear_density_kg_m"]))
    value = draw(st.sampled_from(["0", "0.0", "-0.0", "-1", "-0.4573", "-1e308"]))
    return _set(text, "beam", key, value).encode(), error(f"[beam] {key}: must be > 0")


def t_outside_model_range(draw, text):
    key, (low, high) = draw(st.sampled_from([("length_m", LENGTH_RANGE_M),
                                             ("linear_density_kg_m", LINEAR_DENSITY_RANGE_KG_M)]))
    value = draw(st.sampled_from([low / 2, high * 2, 1e308, 5e-324]))
    return _set(text, "beam", key, repr(value)).encode(), error(f"[beam] {key}: must be between")


def t_patch_outside(draw, text):
    start, end = draw(st.sampled_from([(0.15, 0.5), (0.3, 0.2), (0.2, 0.2), (0.0, 1e308), (0.4573, 0.46)]))
    content = _set(_set(text, "patch", "start_m", repr(start)), "patch", "end_m", repr(end))
    return content.encode(), error("[patch]", "patch must satisfy")


def t_negative_position(draw, text):
    table, key = draw(st.sampled_from([("patch", "start_m"), ("patch", "end_m"), ("sensor", "position_m")]))
    return _set(text, table, key, "-0.1").encode(), error(f"[{table}] {key}: must be >= 0")


def t_sensor_outside(draw, text):
    value = draw(st.sampled_from(["0", "0.0", "0.46", "1e308", "0.4574"]))
    return _set(text, "sensor", "position_m", value).encode(), error("[sensor]", "sensor position_m must lie in")


def t_unknown_key(draw, text):
    table = draw(st.sampled_from(["beam", "patch", "sensor"]))
    key = draw(st.sampled_from(["widht_m", "lenght_m", "position", "x"]))
    return text.replace(f"[{table}]\n", f"[{table}]\n{key} = 1.0\n").encode(), error(f"[{table}] {key}: unknown key")


def t_unknown_table(draw, text):
    table = draw(st.sampled_from(["parameters", "beams", "Beam", "extra"]))
    return (text + f"[{table}]\nx = 1\n").encode(), error(f"[{table}]: unknown table")


def t_bad_title(draw, text):
    value = draw(st.sampled_from(["3", "true", "[1]", "1979-05-27"]))
    return text.replace('title = "bench test"', f"title = {value}").encode(), error("title: must be a string")


def t_bad_nominal(draw, text):
    name, value, fragment = draw(st.sampled_from([
        ("bending_stiffnes_Nm2", "0.5", "unknown parameter"),
        ("air_damping_Ns_m2", "-0.01", "must be a positive finite number"),
        ("air_damping_Ns_m2", "0", "must be a positive finite number"),
        ("tip_mass_kg", "nan", "must be a positive finite number"),
        ("tip_mass_kg", "'1 g'", "must be a number"),
        ("kelvin_voigt_Nm2s", "1" + "0" * 400, "must be a positive finite number"),
    ]))
    return (text + f"[nominal]\n{name} = {value}\n").encode(), error(f"[nominal] {name}: {fragment}")


def t_syntax_error(draw, text):
    junk = draw(st.sampled_from(["length_m = 0.45 m", "= 3", "[beam", "x = [1, 2", 'x = "unterminated', "a.b.c"]))
    return (text + junk + "\n").encode(), error("TOML syntax error")


def t_nested_too_deep(draw, text):
    depth = draw(st.integers(2000, 6000))
    return (text + "x = " + "[" * depth + "]" * depth + "\n").encode(), Expect(False, [])


def t_bytes(draw, text):
    content, fragment = draw(st.sampled_from([
        (text.replace("bench", "b\xe9nch").encode("latin-1"), "not UTF-8"),
        (text.encode("utf-16"), "binary content"),
        (text.encode()[:40] + b"\x00" + text.encode()[40:], "binary content"),
    ]))
    return content, error(fragment)


SIDECAR_MUTATIONS = [
    t_tolerated, t_missing_key, t_missing_table, t_wrong_type, t_not_finite, t_too_many_digits, t_not_positive,
    t_outside_model_range, t_patch_outside, t_negative_position, t_sensor_outside, t_unknown_key, t_unknown_table,
    t_bad_title, t_bad_nominal, t_syntax_error, t_nested_too_deep, t_bytes,
]


@st.composite
def sidecar_cases(draw, base: str = SIDECAR):
    mutation = draw(st.sampled_from(SIDECAR_MUTATIONS))
    content, expect = mutation(draw, base)
    return mutation.__name__, content, expect


@settings(max_examples=SIDECAR_EXAMPLES, **FUZZ)
@given(case=sidecar_cases())
def test_generated_sidecar(tmp_path, case):
    _, content, expect = case
    path = _write(tmp_path, "run.toml", content)
    _write(tmp_path, "run.csv", HEADER + "\n0,0,0\n0.001,1,1e-6\n")
    if expect.valid:
        title, geometry, nominal = read_sidecar(path)
        assert isinstance(geometry, BeamGeometry) and read_measurement(path).sample_count == 2
    else:
        _assert_one_line_error(lambda: read_sidecar(path), path, expect.fragments)
        _assert_one_line_error(lambda: read_measurement(path), path, expect.fragments)


FORCE_SIDECAR = """title = "free strip"
[beam]
length_m = 0.5
linear_density_kg_m = 0.27
[force]
position_m = 0.5
[sensor]
position_m = 0.44
range = 98.0665
"""
FORCE_CSV = "time_s,force_N,acceleration_m_s2\n0,0,0.1\n0.00025,1,-0.2\n0.0006,0.5,0.3\n"


def f_force_table(draw, text):
    """[force] missing (a force_N record needs it), or its key missing, misspelt, mistyped, off the beam."""
    choice = draw(st.sampled_from(["table", "key", "misspelt", "type", "outside", "negative"]))
    if choice == "table":
        return text.replace("[force]\nposition_m = 0.5\n", "").encode(), error("[force]: missing table (a force_N input")
    if choice == "key":
        return _set(text, "force", "position_m", None).encode(), error("[force] position_m: missing key")
    if choice == "misspelt":
        return text.replace("[force]\nposition_m", "[force]\nposition").encode(), error("[force] position: unknown key")
    if choice == "type":
        value, kind = draw(st.sampled_from(WRONG_TYPES))
        return _set(text, "force", "position_m", value).encode(), error(f"[force] position_m: must be a number, got {kind}")
    if choice == "outside":
        value = draw(st.sampled_from(["0", "0.0", "0.51", "1e308"]))
        return _set(text, "force", "position_m", value).encode(), error("[force]", "force position_m must lie in")
    return _set(text, "force", "position_m", "-0.1").encode(), error("[force] position_m: must be >= 0")


def f_sensor_range(draw, text):
    """[sensor] range: not positive, not finite, not a number; or the record is clipped at it."""
    value, fragment = draw(st.sampled_from([
        ("0", "[sensor] range: must be > 0"), ("-98.0665", "[sensor] range: must be > 0"),
        ("nan", "[sensor] range: must be finite"), ("inf", "[sensor] range: must be finite"),
        ('"10 g"', "[sensor] range: must be a number"), ("true", "[sensor] range: must be a number"),
        ("0.15", "are clipped (at the sensor's range 0.15 m/s²"),
    ]))
    return _set(text, "sensor", "range", value).encode(), error(fragment)


def f_patch_optional(draw, text):
    """A patch on a force-driven beam is allowed (it still adds mass and stiffness), and so is no range."""
    text = text.replace("[sensor]", "[patch]\nstart_m = 0.0\nend_m = 0.05\n[sensor]")
    if draw(st.booleans()):
        text = _set(text, "sensor", "range", None)
    return text.encode(), Expect(True)


FORCE_SIDECAR_MUTATIONS = [f_force_table, f_sensor_range, f_patch_optional]


@settings(max_examples=FORCE_SIDECAR_EXAMPLES, **FUZZ)
@given(data=st.data())
def test_generated_sidecar_of_a_force_record(tmp_path, data):
    """The sidecar of a ``time_s,force_N,acceleration_m_s2`` record: [force] and [sensor] range."""
    mutation = data.draw(st.sampled_from(FORCE_SIDECAR_MUTATIONS))
    content, expect = mutation(data.draw, FORCE_SIDECAR)
    path = _write(tmp_path, "run.toml", content)
    csv_path = _write(tmp_path, "run.csv", FORCE_CSV)
    if expect.valid:
        read = read_measurement(path)
        assert read.input_kind == "force" and read.geometry.force_position_m == 0.5 and read.geometry.has_patch
    else:
        fragments = expect.fragments
        at = csv_path if any("clipped" in f for f in fragments) else path
        _assert_one_line_error(lambda: read_measurement(path), at, fragments)


CONFIG = SIDECAR + CONFIG_EXTRA


def c_sampling(draw, text):
    key, value, fragment = draw(st.sampled_from([
        ("rate_Hz", "0", "[sampling] rate_Hz: must be > 0"),
        ("rate_Hz", "-1000", "[sampling] rate_Hz: must be > 0"),
        ("rate_Hz", "1e308", "the limit is"),
        ("rate_Hz", "nan", "[sampling] rate_Hz: must be finite"),
        ("rate_Hz", '"1 kHz"', "[sampling] rate_Hz: must be a number"),
        ("duration_s", "1e-9", "[sampling]: rate_Hz x duration_s"),
        ("duration_s", "1e300", "the limit is"),
        ("duration_s", "1" + "0" * 400, "[sampling] duration_s: must be finite"),
    ]))
    return _set(text, "sampling", key, value).encode(), error(fragment)


def c_sampling_overflow(draw, text):
    duration = draw(st.sampled_from(["1e308", "2e10"]))
    text = _set(_set(text, "sampling", "rate_Hz", "1e308"), "sampling", "duration_s", duration)
    return text.encode(), error("[sampling]: rate_Hz x duration_s = inf samples")


def c_sampling_extras(draw, text):
    line, fragment = draw(st.sampled_from([
        ("seed = -1", "[sampling] seed: must be >= 0"),
        ("seed = 1.5", "[sampling] seed: must be an integer"),
        ("noise_m = -1e-6", "[sampling] noise_m: must be >= 0"),
        ("noise_m = inf", "[sampling] noise_m: must be finite"),
        ("rate = 1000", "[sampling] rate: unknown key"),
    ]))
    return text.replace("[sampling]\n", f"[sampling]\n{line}\n").encode(), error(fragment)


def c_parameters(draw, text):
    key, value, fragment = draw(st.sampled_from([
        ("bending_stiffness_Nm2", "-0.491", "must be a positive finite number"),
        ("bending_stiffness_Nm2", "0", "must be a positive finite number"),
        ("bending_stiffness_Nm2", "1" + "0" * 400, "must be a positive finite number"),
        ("patch_coupling_NmV", "nan", "must be a positive finite number"),
        ("patch_coupling_NmV", "'0.017'", "must be a number"),
        ("patch_coupling_NmV", None, "patch_coupling_NmV: missing"),
    ]))
    return _set(text, "parameters", key, value).encode(), error("[parameters]", fragment)


def c_excitation(draw, text):
    old, new, fragment = draw(st.sampled_from([
        ('kind = "pulse"', 'kind = "square"', "unknown kind 'square'"),
        ("width_s = 0.01", "width_s = 0", "[excitation] width_s: must be > 0"),
        ("width_s = 0.01", "", "[excitation] width_s: missing key"),
        ("width_s = 0.01", "width_s = 0.01\nfrequency_Hz = 3", "not used by a 'pulse' excitation"),
        ("amplitude_V = 1.0", "amplitude_V = 1e999", "[excitation] amplitude_V: must be finite"),
        ("amplitude_V = 1.0", "amplitude_V = -inf", "[excitation] amplitude_V: must be finite"),
        ('kind = "pulse"\namplitude_V = 1.0\nwidth_s = 0.01', 'kind = "file"\nfile = "missing.csv"', "not found"),
        ('kind = "pulse"\namplitude_V = 1.0\nwidth_s = 0.01', 'kind = "file"\nfile = ""', "is a directory"),
        ('kind = "pulse"\namplitude_V = 1.0\nwidth_s = 0.01', 'kind = "file"\nfile = "/dev/zero"',
         "not a regular file"),
    ]))
    return text.replace(old, new).encode(), Expect(False, [fragment])


def c_model(draw, text):
    value, fragment = draw(st.sampled_from([
        ("1", "[model] intervals: must be >= 2"), ("401", "[model] intervals: must be <= 400"),
        ("16.0", "[model] intervals: must be an integer"), ("1" + "0" * 400, "[model] intervals: must be <= 400"),
    ]))
    return (text + f"[model]\nintervals = {value}\n").encode(), error(fragment)


def c_geometry(draw, text):
    mutation = draw(st.sampled_from([m for m in SIDECAR_MUTATIONS if m not in (t_unknown_table, t_tolerated)]))
    return mutation(draw, text)


CONFIG_MUTATIONS = [c_sampling, c_sampling_overflow, c_sampling_extras, c_parameters, c_excitation, c_model, c_geometry]


@settings(max_examples=CONFIG_EXAMPLES, **FUZZ)
@given(data=st.data())
def test_generated_config(tmp_path, data):
    mutation = data.draw(st.sampled_from(CONFIG_MUTATIONS))
    content, expect = mutation(data.draw, CONFIG)
    path = _write(tmp_path, "sim.toml", content)
    assert not expect.valid
    message = _assert_one_line_error(lambda: load_config(path), path, [])
    for fragment in expect.fragments:
        assert fragment in message, (fragment, message)


def test_the_unmutated_files_are_valid(tmp_path):
    """The bases the mutations start from read fine (so every error above is the mutation's)."""
    _write(tmp_path, "run.toml", SIDECAR)
    _write(tmp_path, "run.csv", HEADER + "\n0,0,0\n0.001,1,1e-6\n")
    assert read_measurement(tmp_path / "run").sample_count == 2
    config = load_config(_write(tmp_path, "sim.toml", CONFIG))
    assert config.sampling.sample_count == 500


# ---------------------------------------------------------------------------------------------
# anything at all: only BeamInputError may escape
# ---------------------------------------------------------------------------------------------


def _flipped(content: bytes):
    """Strategy: ``content`` with a few bytes replaced, inserted or deleted."""
    edits = st.lists(st.tuples(st.integers(0, len(content)), st.sampled_from(["set", "insert", "delete"]),
                               st.integers(0, 255)), min_size=1, max_size=4)

    def apply(changes):
        data = bytearray(content)
        for position, kind, byte in changes:
            position = min(position, len(data))
            if kind == "insert":
                data[position:position] = bytes([byte])
            elif data and position < len(data):
                if kind == "set":
                    data[position] = byte
                else:
                    del data[position]
        return bytes(data)

    return edits.map(apply)


CELL_TOKENS = [
    "0", "0.001", "1.5", "-0.0", "1e308", "-1.7976931348623157e308", "1e309", "5e-324", "nan", "-inf", "", " ",
    "1_000", "\u0661\u0662", "\uff11", "0x1p3", "abc", "\ufeff1", "+1", "--1", "1e", ".", "1.", ".5", "1d3",
    "Infinity", "\u00a01", "1\u2009", "1e-400", "\x0b1", "\u20281",
]


@st.composite
def token_csv(draw) -> bytes:
    """A CSV that is nearly right: mostly plain numbers, now and then a tricky cell or row."""
    number = st.floats(-1e3, 1e3).map(repr)
    cell = st.one_of(number, number, number, number, st.sampled_from(CELL_TOKENS))
    width = st.sampled_from([3, 3, 3, 3, 3, 3, 2, 4])
    header = draw(st.sampled_from([HEADER] * 6 + [HEADER + ",", " time_s ;voltage_V", "\ufeff" + HEADER, ""]))
    count = draw(st.integers(0, 8))
    rows = [[repr(k * 0.001)] + [draw(cell) for _ in range(draw(width) - 1)] for k in range(count)]
    if rows and draw(st.booleans()):
        rows[draw(st.integers(0, count - 1))][0] = draw(st.sampled_from(CELL_TOKENS))
    newline = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    return newline.join([header] + [",".join(r) for r in rows]).encode("utf-8")


TOML_KEYS = [
    "length_m", "linear_density_kg_m", "start_m", "end_m", "position_m", "title", "rate_Hz", "duration_s", "seed",
    "noise_m", "kind", "amplitude_V", "width_s", "file", "intervals", "bending_stiffness_Nm2", "patch_coupling_NmV",
    "tip_mass_kg", "x",
]
TOML_VALUES = [
    "0.4573", "1", "0", "-1", "1e308", "-1e308", "5e-324", "nan", "inf", "1" + "0" * 400, "true", '"x"', '"pulse"',
    '"file"', '"/dev/null"', '""', "[1, 2]", "1979-05-27", "{ a = 1 }", "[" * 50 + "]" * 50, "2e10", "0.15",
    "0.25", "16", "401", "-0", "0x10", "1_000", "9223372036854775808",
]


@st.composite
def token_toml(draw) -> bytes:
    """The valid sidecar or config with one to three values replaced by tricky ones, or a key added."""
    lines = draw(st.sampled_from([SIDECAR, CONFIG])).splitlines()
    for _ in range(draw(st.integers(1, 3))):
        index = draw(st.sampled_from([i for i, line in enumerate(lines) if "=" in line]))
        value = draw(st.sampled_from(TOML_VALUES))
        if draw(st.integers(0, 4)) == 0:
            lines.insert(index, f"{draw(st.sampled_from(TOML_KEYS))} = {value}")
        else:
            lines[index] = f"{lines[index].split('=')[0].strip()} = {value}"
    return "\n".join(lines).encode("utf-8")


VALID_CSV = measurement_csv_text(np.arange(6) / 1000.0, np.linspace(0, 1, 6), np.linspace(0, 1e-6, 6)).encode()
junk = st.one_of(
    st.binary(max_size=300),
    st.text(max_size=300).map(lambda s: s.encode("utf-8", "surrogatepass")),
    st.text(st.characters(codec="utf-8"), max_size=300).map(str.encode),
    _flipped(VALID_CSV),
    _flipped(SIDECAR.encode()),
    _flipped(CONFIG.encode()),
    token_csv(), token_csv(), token_csv(),
    token_toml(), token_toml(), token_toml(),
)


def _only_beam_input_error(call) -> None:
    try:
        call()
    except BeamInputError as exc:
        message = str(exc)
        assert message and "\n" not in message, repr(message)


@settings(max_examples=JUNK_EXAMPLES, **FUZZ)
@given(content=junk, target=st.sampled_from(["csv", "sidecar", "config"]))
def test_arbitrary_content_raises_only_beam_input_error(tmp_path, content, target):
    csv_content, toml_content = (content, SIDECAR.encode()) if target == "csv" else (VALID_CSV, content)
    _write(tmp_path, "run.csv", csv_content)
    path = _write(tmp_path, "run.toml", toml_content)
    _only_beam_input_error(lambda: read_measurement(tmp_path / "run.csv"))
    _only_beam_input_error(lambda: read_sidecar(path))
    _only_beam_input_error(lambda: load_config(path))


@pytest.mark.parametrize("given_path", ["", ".", "/", "..", "a" * 5000, "missing/dir/run", "run\x00.csv"])
def test_odd_paths_give_a_beam_input_error(tmp_path, given_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for reader in (read_measurement, read_sidecar, load_config):
        _only_beam_input_error(lambda: reader(given_path))
        with pytest.raises(BeamInputError):
            reader(given_path)


def test_a_fifo_or_device_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "run.toml"
    import os

    os.mkfifo(fifo)
    (tmp_path / "run.csv").write_text(HEADER + "\n0,0,0\n1,0,0\n")
    with pytest.raises(BeamInputError, match="not a regular file"):
        read_measurement(tmp_path / "run.csv")
    with pytest.raises(BeamInputError, match="not a regular file"):
        load_config("/dev/zero")


# ---------------------------------------------------------------------------------------------
# valid files round-trip exactly
# ---------------------------------------------------------------------------------------------


@st.composite
def geometries(draw, patch: bool = True, force: bool = False, strain: bool = False) -> BeamGeometry:
    length = draw(st.floats(*LENGTH_RANGE_M))
    density = draw(st.floats(*LINEAR_DENSITY_RANGE_KG_M))
    a, b = sorted(draw(st.lists(st.floats(0.0, 1.0), min_size=2, max_size=2, unique=True)))
    assume(a * length < b * length)
    sensor = draw(st.floats(1e-6, 1.0))
    start, end = (a * length, b * length) if patch else (None, None)
    force_position = draw(st.floats(1e-6, 1.0)) * length if force else None
    if strain:  # a strain gauge reads -(h/2) w'': the strip's section is part of the record
        # a strip: the width at most its length, the thickness at most its width (the reader's rules)
        width = draw(st.floats(1e-3, min(0.2, length)))
        return BeamGeometry(length, density, start, end, sensor * length, force_position,
                            width_m=width, thickness_m=draw(st.floats(1e-4, min(0.02, width))))
    return BeamGeometry(length, density, start, end, sensor * length, force_position)


nominal_values = st.dictionaries(
    st.sampled_from(["bending_stiffness_Nm2", "patch_coupling_NmV", "air_damping_Ns_m2", "tip_mass_kg",
                     "sensor_mass_kg", "damping_ratio_mode_1", "damping_ratio_mode_12"]),
    st.floats(min_value=5e-324, max_value=1.7976931348623157e308),
)


@settings(max_examples=ROUND_TRIP_EXAMPLES, **FUZZ)
@given(table=tables(max_rows=50), data=st.data(), title=st.text(max_size=40), nominal=nominal_values,
       sensor_range=st.none() | st.floats(1e-300, 1e300))
def test_valid_files_round_trip_bit_exact(tmp_path, table, data, title, nominal, sensor_range):
    needs_patch, needs_force = "voltage_V" in table.names, "force_N" in table.names
    geometry = data.draw(geometries(patch=needs_patch or data.draw(st.booleans()),
                                    force=needs_force or data.draw(st.booleans()), strain="strain" in table.names))
    output = table.arrays[-1]
    if sensor_range is not None:  # keep clipping by the range below half of the record
        assume(2 * np.count_nonzero(np.abs(output) >= (1 - 1e-3) * sensor_range) <= output.size)
    written = write_measurement(tmp_path / "rt", table.mapping(), geometry=geometry, title=title, nominal=nominal,
                                sensor_range=sensor_range)
    read = read_measurement(tmp_path / "rt.csv")
    assert read.columns == table.names
    for column, expected in zip(table.names, table.arrays):
        assert getattr(read, column).tobytes() == expected.tobytes(), column
    assert (read.title, read.geometry, read.nominal, read.sensor_range) == (title, geometry, nominal, sensor_range)
    assert read.sample_count == written.sample_count
    np.testing.assert_array_equal(read.clipped, written.clipped)
    assert tomllib.loads((tmp_path / "rt.toml").read_text(encoding="utf-8"))["title"] == title
    assert math.isfinite(read.rate_Hz) and read.median_interval_s > 0


@settings(max_examples=ROUND_TRIP_EXAMPLES, **FUZZ)
@given(table=tables(max_rows=50, kinds=False), geometry=geometries())
def test_classic_records_round_trip_from_a_tuple(tmp_path, table, geometry):
    """``write_measurement(prefix, (time_s, voltage_V, displacement_m))`` as before: uniform, exact."""
    write_measurement(tmp_path / "rt", tuple(table.arrays), geometry=geometry)
    read = read_measurement(tmp_path / "rt.csv")
    assert read.columns == CSV_COLUMNS and read.uniform and read.sample_interval_s > 0
    for column, expected in zip(CSV_COLUMNS, table.arrays):
        assert getattr(read, column).tobytes() == expected.tobytes(), column


def test_a_title_utf8_cannot_store_is_refused_before_writing(tmp_path):
    geometry = BeamGeometry(0.4573, 0.093, 0.15, 0.25, 0.27438)
    with pytest.raises(BeamInputError, match="UTF-8 cannot store"):
        write_measurement(tmp_path / "x", (np.arange(3.0), np.zeros(3), np.zeros(3)), geometry=geometry,
                          title="bad \ud800 surrogate")
    assert list(tmp_path.iterdir()) == []
