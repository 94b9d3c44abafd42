"""Measurement files: ``NAME.csv`` (the samples) plus ``NAME.toml`` (what the lab knows).

``NAME.csv``
    UTF-8 text (an optional byte-order mark is dropped; LF, CRLF or CR line endings), comma
    separated, at most :data:`beam.io.limits.MAX_MEASUREMENT_BYTES` (64 MiB). The first line is
    exactly ``time_s,voltage_V,displacement_m`` (spaces around names are tolerated, the order is
    not negotiable); then one row per sample:
    time (s), piezo voltage (V), displacement at the sensor (m). Numbers are anything Python's
    ``float`` reads (``1e-3``, ``-0.5``); NaN and infinity (``1e309`` included) are rejected. A
    trailing comma is an error (it makes an empty fourth cell). Blank lines are allowed only at
    the end. At least two rows. Time must increase uniformly: every step within
    ``UNIFORM_TIME_TOLERANCE`` (1 %) of the median step and every time stamp within 1 % of a step
    of the grid ``t_0 + k dt`` with ``dt = (t_last - t_0) / (n - 1)``. This accepts time stamps
    printed with a few significant digits and rejects a missing, repeated or out-of-order
    sample. The sampling interval is at least :data:`MIN_SAMPLE_INTERVAL_S` (1e-12 s) and the
    span of the time stamps must fit in a float. Time need not start at 0 and is kept as given;
    models assume the beam is at rest at the first sample and the voltage is held over each
    sample interval.

``NAME.toml``
    Optional ``title`` (string); ``[beam]`` ``length_m``, ``linear_density_kg_m``; ``[patch]``
    ``start_m``, ``end_m``; ``[sensor]`` ``position_m``, with the length and density within
    :data:`beam.io.limits.LENGTH_RANGE_M` (0.01-100 m) and
    :data:`beam.io.limits.LINEAR_DENSITY_RANGE_KG_M` (1e-3 to 1e4 kg/m), where the model is finite;
    optional ``[nominal]`` prior centres keyed by parameter names of
    :data:`beam.physics.effects.PARAMETER_SPECS` (positive finite). Unknown tables or keys are errors.
    At most :data:`beam.io.limits.MAX_TOML_BYTES` (1 MiB).

Errors are :class:`beam.errors.BeamInputError` with one line naming the file and the line
(1-based, as an editor shows it) or key.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from beam.errors import BeamInputError
from beam.io.limits import (
    LENGTH_RANGE_M,
    LINEAR_DENSITY_RANGE_KG_M,
    MAX_MEASUREMENT_BYTES,
)
from beam.io.text import (
    TomlReader,
    as_finite_float,
    atomic_write_texts,
    did_you_mean,
    dump_toml,
    load_toml,
    read_text_file,
    short_repr,
)
from beam.physics.effects import PARAMETER_SPECS
from beam.physics.geometry import BeamGeometry

#: The CSV header, column by column.
CSV_COLUMNS: tuple[str, str, str] = ("time_s", "voltage_V", "displacement_m")

#: Largest allowed deviation of a time step from the record's step, as a fraction of the step.
UNIFORM_TIME_TOLERANCE = 1e-2

#: Smallest sampling interval (s): a sampling rate of 1 THz. Smaller steps are mistaken units
#: (or subnormal numbers whose reciprocal overflows).
MIN_SAMPLE_INTERVAL_S = 1e-12

#: Tables of the measurement sidecar (and of a simulation config, which extends it).
GEOMETRY_TABLES: dict[str, tuple[str, ...]] = {
    "beam": ("length_m", "linear_density_kg_m"),
    "patch": ("start_m", "end_m"),
    "sensor": ("position_m",),
}


@dataclass(frozen=True, eq=False)
class Measurement:
    """A measured (or simulated) record with the geometry the lab knows.

    Parameters
    ----------
    name : str
        File stem ``NAME`` of ``NAME.csv`` / ``NAME.toml``.
    title : str
        Human title (defaults to ``name`` in files without one).
    geometry : BeamGeometry
        Beam, patch and sensor geometry.
    time_s : numpy.ndarray
        Sample times (s), uniformly spaced, increasing, at least two.
    voltage_V : numpy.ndarray
        Piezo voltage (V), held over each sample interval.
    displacement_m : numpy.ndarray
        Displacement at the sensor (m).
    nominal : dict
        Prior centres keyed by parameter name (units in the names).
    csv_path, toml_path : Path or None
        Where it was read from or written to.

    Raises
    ------
    BeamInputError
        Arrays of different lengths, fewer than two samples, non-finite values or time that
        is not uniformly increasing; unknown or non-positive nominal values.
    """

    name: str
    title: str
    geometry: BeamGeometry
    time_s: np.ndarray = field(repr=False)
    voltage_V: np.ndarray = field(repr=False)
    displacement_m: np.ndarray = field(repr=False)
    nominal: dict[str, float] = field(default_factory=dict)
    csv_path: Path | None = None
    toml_path: Path | None = None

    def __post_init__(self) -> None:
        _check_label("name", self.name)
        _check_label(f"measurement {self.name}: title", self.title)
        columns = {}
        for column in CSV_COLUMNS:
            values = np.array(getattr(self, column), dtype=float)
            if values.ndim != 1:
                raise BeamInputError(f"measurement {self.name}: {column} must be 1-D, got shape {values.shape}")
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                raise BeamInputError(
                    f"measurement {self.name}: {column}[{bad[0]}] = {values[bad[0]]} is not finite"
                )
            values.setflags(write=False)
            columns[column] = values
            object.__setattr__(self, column, values)
        lengths = {c: v.size for c, v in columns.items()}
        if len(set(lengths.values())) != 1:
            raise BeamInputError(f"measurement {self.name}: columns differ in length: {lengths}")
        problem = time_grid_problem(columns["time_s"])
        if problem is not None:
            index, message = problem
            where = "" if index is None else f"sample {index}: "
            raise BeamInputError(f"measurement {self.name}: {where}{message}")
        object.__setattr__(self, "nominal", check_nominal(self.nominal, f"measurement {self.name}: nominal"))

    @property
    def sample_count(self) -> int:
        """Number of samples n."""
        return int(self.time_s.size)

    @property
    def sample_interval_s(self) -> float:
        """Sampling interval dt = (t_last - t_0) / (n - 1) (s)."""
        return float((self.time_s[-1] - self.time_s[0]) / (self.time_s.size - 1))

    @property
    def rate_Hz(self) -> float:
        """Sampling rate 1 / dt (Hz)."""
        return 1.0 / self.sample_interval_s

    @property
    def duration_s(self) -> float:
        """Time covered by the record, n dt (s): the last sample is held for one interval too."""
        return self.sample_count * self.sample_interval_s


def _check_label(what: str, value: Any) -> None:
    """A name or title: a string that can be written as UTF-8 (no lone surrogate)."""
    if not isinstance(value, str):
        raise BeamInputError(f"{what} must be a string, got {type(value).__name__} {value!r}")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise BeamInputError(f"{what} {value!r} holds a character that UTF-8 cannot store") from None


def check_nominal(nominal: Mapping[str, Any], where: str) -> dict[str, float]:
    """Validate prior centres: known parameter names, positive finite numbers.

    Parameters
    ----------
    nominal : mapping
        Parameter name to value.
    where : str
        Prefix for messages, e.g. ``"run.toml: [nominal]"``.

    Returns
    -------
    dict
        Names to floats, in the given order.
    """
    checked = {}
    for name, value in nominal.items():
        if name not in PARAMETER_SPECS:
            raise BeamInputError(
                f"{where} {name}: unknown parameter{did_you_mean(name, PARAMETER_SPECS)}; "
                f"known parameters: {', '.join(PARAMETER_SPECS)}"
            )
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise BeamInputError(f"{where} {name}: must be a number, got {short_repr(value)}")
        number = as_finite_float(value)
        if number is None or number <= 0:
            raise BeamInputError(f"{where} {name}: must be a positive finite number, got {short_repr(value)}")
        checked[name] = number
    return checked


def time_grid_problem(time_s: np.ndarray) -> tuple[int | None, str] | None:
    """Why ``time_s`` is not a uniform increasing grid, or None if it is.

    Parameters
    ----------
    time_s : numpy.ndarray
        Finite sample times (s).

    Returns
    -------
    tuple or None
        ``(index, message)`` with the 0-based index of the first offending sample (None when
        the whole record is at fault), or None when the grid is fine.
    """
    n = time_s.size
    if n < 2:
        return None, f"{n} sample(s); need at least 2 to define the sampling interval"
    with np.errstate(over="ignore", invalid="ignore"):
        steps = np.diff(time_s)
    not_increasing = np.flatnonzero(steps <= 0)
    if not_increasing.size:
        k = int(not_increasing[0]) + 1
        return k, f"time_s = {float(time_s[k])!r} does not increase (previous time_s = {float(time_s[k - 1])!r})"
    span = float(time_s[-1]) - float(time_s[0])
    step = span / (n - 1)
    if not (math.isfinite(span) and np.all(np.isfinite(steps))):
        return None, (
            f"time_s runs from {float(time_s[0])!r} to {float(time_s[-1])!r}: the span overflows a float; "
            "give times in seconds"
        )
    if step < MIN_SAMPLE_INTERVAL_S or not math.isfinite(1.0 / step):
        return None, (
            f"the sampling interval {step!r} s is too small (at least {MIN_SAMPLE_INTERVAL_S:g} s, "
            f"a sampling rate of at most {1 / MIN_SAMPLE_INTERVAL_S:g} Hz); give times in seconds"
        )
    typical_step = float(np.median(steps))
    tolerance = UNIFORM_TIME_TOLERANCE * typical_step
    irregular = np.flatnonzero(np.abs(steps - typical_step) > tolerance)
    if irregular.size:
        k = int(irregular[0]) + 1
        return k, (
            f"time step {steps[k - 1]:.9g} s (from time_s = {float(time_s[k - 1])!r} to {float(time_s[k])!r}) "
            f"differs from "
            f"the record's step {typical_step:.9g} s; samples must be uniformly spaced "
            f"(tolerance {UNIFORM_TIME_TOLERANCE:g} of a step)"
        )
    drift = np.abs(time_s - (time_s[0] + np.arange(n) * step))
    off_grid = np.flatnonzero(drift > UNIFORM_TIME_TOLERANCE * step)
    if off_grid.size:
        k = int(off_grid[0])
        return k, (
            f"time_s = {float(time_s[k])!r} is {drift[k]:.3g} s off the uniform grid t_0 + k dt "
            f"(dt = {step:.9g} s); samples must be uniformly spaced (tolerance {UNIFORM_TIME_TOLERANCE:g} of a step)"
        )
    return None


# ---------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------


def measurement_paths(path: str | os.PathLike[str]) -> tuple[Path, Path]:
    """``(NAME.csv, NAME.toml)`` for a path to either file (or to ``NAME`` without suffix)."""
    path = Path(path)
    if not path.name or path.name in (".", ".."):
        raise BeamInputError(f"{path}: not a measurement file (expected NAME.csv, NAME.toml or NAME)")
    if path.name.endswith(".truth.toml"):
        raise BeamInputError(
            f"{path}: this is the true-parameter file of a simulation; read "
            f"{path.name[: -len('.truth.toml')]}.csv instead"
        )
    if path.suffix.lower() in (".csv", ".toml"):
        stem = path.with_suffix("")
    else:
        stem = path
    return stem.with_name(stem.name + ".csv"), stem.with_name(stem.name + ".toml")


def read_measurement(path: str | os.PathLike[str]) -> Measurement:
    """Read ``NAME.csv`` and its sidecar ``NAME.toml``.

    Parameters
    ----------
    path : str or path-like
        Either file of the pair (the other is found next to it), or ``NAME`` alone.

    Returns
    -------
    Measurement

    Raises
    ------
    BeamInputError
        A missing or malformed file; one line naming the file and the line or key.
    """
    csv_path, toml_path = measurement_paths(path)
    csv_exists, toml_exists = _exists(csv_path), _exists(toml_path)
    if not csv_exists and not toml_exists:
        raise BeamInputError(f"{path}: not found (a measurement is NAME.csv plus its sidecar NAME.toml)")
    if not toml_exists:
        raise BeamInputError(f"{csv_path}: sidecar {toml_path.name} not found next to it (it holds the geometry)")
    if not csv_exists:
        raise BeamInputError(f"{toml_path}: data file {csv_path.name} not found next to it")
    title, geometry, nominal = read_sidecar(toml_path)
    time_s, voltage_V, displacement_m = read_measurement_table(csv_path)
    return Measurement(
        name=csv_path.stem, title=title if title is not None else csv_path.stem, geometry=geometry,
        time_s=time_s, voltage_V=voltage_V, displacement_m=displacement_m, nominal=nominal,
        csv_path=csv_path, toml_path=toml_path,
    )


def _exists(path: Path) -> bool:
    """Whether ``path`` exists; a name the system refuses (too long, a NUL) is a BeamInputError."""
    try:
        return path.exists()
    except (OSError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise BeamInputError(f"{path}: cannot open: {reason}") from None


def read_sidecar(path: str | os.PathLike[str]) -> tuple[str | None, BeamGeometry, dict[str, float]]:
    """Title, geometry and nominal values from a measurement ``NAME.toml``.

    Returns
    -------
    title : str or None
        The ``title`` key, None when absent.
    geometry : BeamGeometry
    nominal : dict
        ``[nominal]`` values (empty when absent).
    """
    reader = TomlReader(load_toml(path, "sidecar"), path)
    reader.check_top_level(tables=(*GEOMETRY_TABLES, "nominal"), keys=("title",))
    return read_title(reader), read_geometry(reader), read_nominal(reader)


def read_title(reader: TomlReader) -> str | None:
    """The optional top-level ``title`` string."""
    return reader.string(None, reader.document, "title", required=False)


def read_geometry(reader: TomlReader) -> BeamGeometry:
    """``[beam]``, ``[patch]``, ``[sensor]`` of a sidecar or config as a :class:`BeamGeometry`."""
    values = {}
    for table_name, keys in GEOMETRY_TABLES.items():
        table = reader.table(table_name)
        reader.check_keys(table_name, table, keys)
        for key in keys:
            values[(table_name, key)] = reader.number(table_name, table, key, positive=table_name == "beam")
    for (table_name, key), value in values.items():
        if table_name in ("patch", "sensor") and value < 0:
            raise reader.fail(f"[{table_name}] {key}", f"must be >= 0 (m from the clamp), got {value!r}")
    ranges = (("length_m", LENGTH_RANGE_M, "m"), ("linear_density_kg_m", LINEAR_DENSITY_RANGE_KG_M, "kg/m"))
    for key, (low, high), unit in ranges:
        value = values[("beam", key)]
        if not low <= value <= high:
            raise reader.fail(
                f"[beam] {key}", f"must be between {low:g} and {high:g} {unit} (the model's range), got {value!r}"
            )
    try:
        return BeamGeometry(
            length_m=values[("beam", "length_m")],
            linear_density_kg_m=values[("beam", "linear_density_kg_m")],
            patch_start_m=values[("patch", "start_m")],
            patch_end_m=values[("patch", "end_m")],
            sensor_position_m=values[("sensor", "position_m")],
        )
    except BeamInputError as exc:  # the patch or sensor does not fit on the beam
        message = str(exc)
        table = "[patch]" if message.startswith("patch") else "[sensor]" if message.startswith("sensor") else "[beam]"
        raise reader.fail(table, message) from None


def read_nominal(reader: TomlReader) -> dict[str, float]:
    """The optional ``[nominal]`` table (prior centres), validated."""
    table = reader.table("nominal", required=False)
    return {} if table is None else check_nominal(table, f"{reader.path}: [nominal]")


def read_measurement_table(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read and check the columns of a measurement CSV.

    Parameters
    ----------
    path : str or path-like
        The ``NAME.csv`` file.

    Returns
    -------
    time_s, voltage_V, displacement_m : numpy.ndarray
        The three columns as float arrays (s, V, m).

    Raises
    ------
    BeamInputError
        Missing, empty, binary, non-UTF-8 or too large (over 64 MiB) file; wrong header; a row
        with the wrong number of cells, a cell that is not a number or not finite; fewer than two
        rows; time not uniformly increasing, or a sampling interval that is not representable.
        The message names the file and the 1-based line.
    """
    path = Path(path)
    text = read_text_file(path, "measurement CSV", MAX_MEASUREMENT_BYTES)
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise BeamInputError(f"{path}: empty file; expected the header {','.join(CSV_COLUMNS)} and data rows")
    _check_header(path, lines[0])
    rows = lines[1:]
    if not rows:
        raise BeamInputError(f"{path}: header only, no data rows")
    try:
        table = np.loadtxt(rows, delimiter=",", comments=None, dtype=float, ndmin=2)
    except ValueError:
        table = None
    if table is None or table.shape != (len(rows), len(CSV_COLUMNS)):
        table = _parse_rows(path, rows)  # the fast parser failed or skipped a blank line
    bad_rows, bad_columns = np.nonzero(~np.isfinite(table))
    if bad_rows.size:
        row, column = int(bad_rows[0]), int(bad_columns[0])
        raise BeamInputError(
            f"{path}: line {row + 2}: {CSV_COLUMNS[column]} = {rows[row].split(',')[column].strip()!r} is not finite"
        )
    if len(rows) == 1:
        raise BeamInputError(
            f"{path}: line 2: the only data row; need at least 2 samples to define the sampling interval"
        )
    time_s = np.ascontiguousarray(table[:, 0])
    problem = time_grid_problem(time_s)
    if problem is not None:
        index, message = problem
        where = "" if index is None else f"line {index + 2}: "
        raise BeamInputError(f"{path}: {where}{message}")
    return time_s, np.ascontiguousarray(table[:, 1]), np.ascontiguousarray(table[:, 2])


def _check_header(path: Path, header: str) -> None:
    names = [name.strip() for name in header.split(",")]
    if tuple(names) == CSV_COLUMNS:
        return
    expected = ",".join(CSV_COLUMNS)
    shown = header.strip()
    if len(shown) > 80:
        shown = shown[:77] + "..."
    missing = [c for c in CSV_COLUMNS if c not in names]
    extra = [n for n in names if n not in CSV_COLUMNS]
    if len(names) == 1 and any(separator in header for separator in (";", "\t")):
        detail = "columns must be separated by commas"
    elif tuple(names[:-1]) == CSV_COLUMNS and not names[-1]:
        detail = "remove the trailing comma"
    elif missing and extra and all(_looks_numeric(n) for n in names):
        detail = "the first line holds numbers, the header is missing"
    elif missing and not extra:
        detail = f"missing column {', '.join(missing)}"
    elif extra and not missing:
        detail = f"unexpected column {', '.join(repr(e) for e in extra)}"
    elif missing:
        detail = f"unknown column {', '.join(repr(e) for e in extra)} in place of {', '.join(missing)}"
    elif len(names) != len(set(names)):
        detail = "a column is repeated"
    else:
        detail = "columns are in the wrong order"
    raise BeamInputError(f"{path}: line 1: header must be exactly {expected!r}, got {shown!r} ({detail})")


def _looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parse_rows(path: Path, rows: list[str]) -> np.ndarray:
    """Parse row by row with ``float`` and raise for the first bad row (the slow path).

    Used when :func:`numpy.loadtxt` refuses the rows: either a row is bad, or a cell holds a
    number that ``float`` reads and loadtxt does not (``1_000``, non-ASCII digits).
    """
    table = np.empty((len(rows), len(CSV_COLUMNS)))
    for offset, row in enumerate(rows):
        line = offset + 2
        if not row.strip():
            raise BeamInputError(f"{path}: line {line}: empty row (blank lines are only allowed at the end)")
        cells = row.split(",")
        if len(cells) != len(CSV_COLUMNS):
            hint = "; remove the trailing comma" if len(cells) == len(CSV_COLUMNS) + 1 and not cells[-1].strip() else ""
            expected = f"expected {len(CSV_COLUMNS)} ({','.join(CSV_COLUMNS)})"
            raise BeamInputError(f"{path}: line {line}: {len(cells)} cell(s), {expected}{hint}")
        for index, (column, cell) in enumerate(zip(CSV_COLUMNS, cells)):
            text = cell.strip()
            try:
                value = float(text)
            except ValueError:
                shown = text if len(text) <= 40 else text[:37] + "..."
                raise BeamInputError(f"{path}: line {line}: {column} = {shown!r} is not a number") from None
            if not np.isfinite(value):
                raise BeamInputError(f"{path}: line {line}: {column} = {text!r} is not finite")
            table[offset, index] = value
    return table


# ---------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------


def measurement_csv_text(time_s: np.ndarray, voltage_V: np.ndarray, displacement_m: np.ndarray) -> str:
    """The CSV text: header then rows with every float at full precision (shortest exact repr)."""
    rows = (f"{t!r},{v!r},{d!r}" for t, v, d in zip(time_s.tolist(), voltage_V.tolist(), displacement_m.tolist()))
    return ",".join(CSV_COLUMNS) + "\n" + "\n".join(rows) + "\n"


def sidecar_document(title: str, geometry: BeamGeometry, nominal: Mapping[str, float]) -> dict[str, Any]:
    """The sidecar TOML content (title, geometry and, if any, nominal values) as a document."""
    document: dict[str, Any] = {
        "title": title,
        "beam": {"length_m": float(geometry.length_m), "linear_density_kg_m": float(geometry.linear_density_kg_m)},
        "patch": {"start_m": float(geometry.patch_start_m), "end_m": float(geometry.patch_end_m)},
        "sensor": {"position_m": float(geometry.sensor_position_m)},
    }
    if nominal:
        document["nominal"] = {name: float(value) for name, value in nominal.items()}
    return document


def write_measurement(
    prefix: str | os.PathLike[str],
    data: Measurement | tuple[np.ndarray, np.ndarray, np.ndarray] | Mapping[str, np.ndarray],
    *,
    geometry: BeamGeometry | None = None,
    title: str | None = None,
    nominal: Mapping[str, float] | None = None,
    extra_files: Mapping[str | os.PathLike[str], str] | None = None,
) -> Measurement:
    """Write ``PREFIX.csv`` and ``PREFIX.toml`` atomically (parent directories are created).

    Parameters
    ----------
    prefix : str or path-like
        Output path without suffix (a ``.csv`` or ``.toml`` suffix is dropped).
    data : Measurement, tuple or mapping
        A :class:`Measurement`, or the arrays ``(time_s, voltage_V, displacement_m)`` as a tuple
        or as a mapping with those keys (a pandas DataFrame works).
    geometry : BeamGeometry, optional
        Required with arrays; overrides the measurement's otherwise.
    title : str, optional
        Title; defaults to the measurement's, else the file stem.
    nominal : mapping, optional
        ``[nominal]`` values; default the measurement's, else none.
    extra_files : mapping, optional
        More files (path to text) written in the same all-or-nothing step, e.g. a truth file.

    Returns
    -------
    Measurement
        What was written, with ``csv_path`` and ``toml_path`` set.

    Raises
    ------
    BeamInputError
        Invalid data, or a CSV larger than :data:`beam.io.limits.MAX_MEASUREMENT_BYTES` (which
        :func:`read_measurement` would refuse): nothing is written.
    """
    csv_path, toml_path = measurement_paths(prefix)
    name = csv_path.stem
    if isinstance(data, Measurement):
        measurement = replace(
            data, name=name,
            title=title if title is not None else data.title,
            geometry=geometry if geometry is not None else data.geometry,
            nominal=dict(nominal) if nominal is not None else data.nominal,
            csv_path=csv_path, toml_path=toml_path,
        )
    else:
        if geometry is None:
            raise BeamInputError("write_measurement: geometry is required when writing arrays")
        if isinstance(data, Mapping) or hasattr(data, "columns"):
            missing = [c for c in CSV_COLUMNS if c not in data]
            if missing:
                raise BeamInputError(f"write_measurement: data has no column {', '.join(missing)}")
            columns = [np.asarray(data[c], dtype=float) for c in CSV_COLUMNS]
        else:
            if len(data) != len(CSV_COLUMNS):
                raise BeamInputError("write_measurement: expected arrays (time_s, voltage_V, displacement_m)")
            columns = [np.asarray(c, dtype=float) for c in data]
        measurement = Measurement(
            name=name, title=title if title is not None else name, geometry=geometry,
            time_s=columns[0], voltage_V=columns[1], displacement_m=columns[2],
            nominal=dict(nominal or {}), csv_path=csv_path, toml_path=toml_path,
        )
    csv_text = measurement_csv_text(measurement.time_s, measurement.voltage_V, measurement.displacement_m)
    if len(csv_text) > MAX_MEASUREMENT_BYTES:  # ASCII: characters are bytes
        raise BeamInputError(
            f"{csv_path}: {measurement.sample_count:,} samples make {len(csv_text) / 2**20:.1f} MiB of CSV, more than "
            f"the {MAX_MEASUREMENT_BYTES // 2**20} MiB read_measurement reads back; write a shorter record or "
            "decimate it (beam.calibration.records.decimate_measurement)"
        )
    contents: dict[str | os.PathLike[str], str] = {
        csv_path: csv_text,
        toml_path: dump_toml(
            sidecar_document(measurement.title, measurement.geometry, measurement.nominal),
            header_comment="Measurement sidecar: what the lab knows about the beam (geometry, sensor, "
            "nominal values).\nThe samples are in the CSV file of the same name.",
        ),
    }
    contents.update(extra_files or {})
    atomic_write_texts(contents)
    return measurement
