"""Measurement files: ``NAME.csv`` (the samples) plus ``NAME.toml`` (what the lab knows).

``NAME.csv``
    UTF-8 text (an optional byte-order mark is dropped; LF, CRLF or CR line endings), comma
    separated, at most :data:`beam.io.limits.MAX_MEASUREMENT_BYTES` (64 MiB). The first line is the
    header (spaces around names are tolerated, the order is not negotiable):

    * ``time_s``, then
    * at most one input column: ``voltage_V`` (the piezo patch's voltage) or ``force_N`` (a
      point force at ``[force] position_m``); none means a *free response*: nothing drives the
      beam and it is already moving at the first sample;
    * one output column, what the sensor at ``[sensor] position_m`` measures:
      ``displacement_m``, ``velocity_m_s``, ``acceleration_m_s2`` or ``strain`` (dimensionless,
      a gauge on the strip's surface at the sensor: -(h/2) w''(x_obs); needs ``[beam]
      thickness_m``).

    So ``time_s,voltage_V,displacement_m`` (:data:`CSV_COLUMNS`) is one of twelve
    headers, e.g. ``time_s,force_N,acceleration_m_s2`` or ``time_s,acceleration_m_s2``. A
    column in another unit (``acceleration_g``, ``force_kN``) is refused with the name to use.
    Then one row per sample. Numbers are anything Python's ``float`` reads (``1e-3``,
    ``-0.5``); NaN and infinity (``1e309`` included) are rejected. A trailing comma is an error
    (it makes an empty extra cell). Blank lines are allowed only at the end. At least two rows.

    Time stamps (s) must increase strictly; they may be irregular (a logger that stalls now and
    then), with every step at most :data:`MAX_GAP_STEPS` (100) times the median step: a larger
    gap is refused as a hole in the record. The median step is at least
    :data:`MIN_SAMPLE_INTERVAL_S` (1e-12 s) and the span of the time stamps must fit in a
    float. Time need not start at 0 and is kept as given.

    *Uniform records.* When every step is within :data:`UNIFORM_TIME_TOLERANCE` (1 %) of the
    median step and every stamp within 1 % of a step of the grid t_0 + k dt,
    dt = (t_last - t_0) / (n - 1), the record is uniform (:attr:`Measurement.uniform`): its
    :attr:`Measurement.sample_interval_s` is dt and the models step on that grid (this accepts
    stamps printed with a few significant digits as the grid they stand for). Otherwise the record is irregular and is evaluated at its own stamps
    (:meth:`beam.physics.model.BeamModel.response_at`, :meth:`beam.physics.model.BeamModel.free_response`); it
    has no single sampling interval. (The rule is the same for every header: the tolerance
    decides which path a record takes, not whether it is read. Round trips need no tolerance:
    :func:`write_measurement` writes every float exactly.)

    Models of a driven record assume the beam is at rest at the first sample and the input is
    held over each sample interval [t_k, t_k+1) (zero-order hold).

``NAME.toml``
    Optional ``title`` (string); ``[beam]`` ``length_m``, ``linear_density_kg_m``; ``[patch]``
    ``start_m``, ``end_m`` (required with ``voltage_V``, optional otherwise: a patch on the beam
    still adds its mass and stiffness); ``[force]`` ``position_m`` (required with ``force_N``);
    ``[sensor]`` ``position_m``, optional ``range`` (the sensor's full scale, in the output
    column's unit, e.g. 98.0665 for a ±10 g accelerometer) and optional ``unit = "arbitrary"``
    (the output column holds values proportional to its quantity in an unknown unit: ADC counts,
    an uncalibrated sensor's volts; :attr:`Measurement.arbitrary_units`), with the length and density within
    :data:`beam.io.limits.LENGTH_RANGE_M` (0.01-100 m) and
    :data:`beam.io.limits.LINEAR_DENSITY_RANGE_KG_M` (1e-3 to 1e4 kg/m), where the model is finite;
    optional ``[nominal]`` prior centres keyed by parameter names of
    :data:`beam.physics.effects.PARAMETER_SPECS` (positive finite). The beam may instead be
    described in a student's words (:func:`read_description`): ``[beam]`` ``width_m``,
    ``thickness_m`` and ``material`` (or ``youngs_modulus_Pa`` and ``density_kg_m3``) give the
    linear density and a nominal bending stiffness; ``[sensor]`` ``mass_kg`` (with
    ``mass_approximate = true`` when not weighed) the sensor's mass. Without a nominal
    bending stiffness the record's lowest strong spectral peak sets it (:mod:`beam.io.anchor`).
    Unknown tables or keys are errors.
    At most :data:`beam.io.limits.MAX_TOML_BYTES` (1 MiB).

Clipping
    A saturated sensor reports its full scale while the beam moves further. Samples whose
    magnitude reaches the ``[sensor] range`` (within :data:`CLIP_RANGE_FRACTION`, 0.1 %) and
    samples in runs of at least :data:`MIN_CLIP_RUN` (3) consecutive equal values at the
    record's maximum or minimum, neither at its start nor at its end (a saturated sensor repeats
    its extreme; a flat start or end is a beam at rest or a held deflection), are marked clipped
    (:attr:`Measurement.clipped`, :attr:`Measurement.clipped_count`), for a calibration to
    leave out of the likelihood. A constant record has no extreme and nothing is marked. A
    record with more than half of its samples clipped is refused.

Errors are :class:`beam.errors.BeamInputError` with one line naming the file and the line
(1-based, as an editor shows it) or key.
"""

from __future__ import annotations

import math
import os
import re
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
from beam.io.readers.signal import record_arrays
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
from beam.physics.effects import PARAMETER_SPECS, effective_length, parameter_listing
from beam.physics.geometry import BeamGeometry

#: The classic CSV header (patch voltage in, displacement out), column by column.
CSV_COLUMNS: tuple[str, str, str] = ("time_s", "voltage_V", "displacement_m")

#: Input columns and the input kind each stands for.
INPUT_COLUMNS: dict[str, str] = {"voltage_V": "voltage", "force_N": "force"}
#: Output columns and the output kind each stands for.
OUTPUT_COLUMNS: dict[str, str] = {
    "displacement_m": "displacement", "velocity_m_s": "velocity", "acceleration_m_s2": "acceleration",
    "strain": "strain",
}
#: Every column a CSV may hold, in the order a header lists them.
ALL_COLUMNS: tuple[str, ...] = ("time_s", *INPUT_COLUMNS, *OUTPUT_COLUMNS)
#: The unit a record in arbitrary units shows (:attr:`Measurement.output_unit`).
ARBITRARY_UNIT = "a.u."
#: Unit of each column (for labels).
COLUMN_UNITS: dict[str, str] = {
    "time_s": "s", "voltage_V": "V", "force_N": "N", "displacement_m": "m", "velocity_m_s": "m/s",
    "acceleration_m_s2": "m/s²", "strain": "1",
}
#: The header rule, as messages quote it.
HEADER_RULE = "time_s[,voltage_V|force_N],displacement_m|velocity_m_s|acceleration_m_s2|strain"

#: Largest allowed deviation of a time step from the record's step, as a fraction of the step,
#: for the record to count as uniform.
UNIFORM_TIME_TOLERANCE = 1e-2

#: Smallest sampling interval (s): a sampling rate of 1 THz. Smaller steps are mistaken units
#: (or subnormal numbers whose reciprocal overflows).
MIN_SAMPLE_INTERVAL_S = 1e-12

#: Largest time step accepted, in median steps: a larger one is a hole in the record.
MAX_GAP_STEPS = 100

#: Shortest run of equal samples at the record's extreme counted as clipping.
MIN_CLIP_RUN = 3
#: Samples within this fraction of the sensor's range count as clipped.
CLIP_RANGE_FRACTION = 1e-3

#: Tables of a simulation config's geometry (a config drives its beam by the patch).
GEOMETRY_TABLES: dict[str, tuple[str, ...]] = {
    "beam": ("length_m", "linear_density_kg_m"),
    "patch": ("start_m", "end_m"),
    "sensor": ("position_m",),
}
#: Tables of a measurement sidecar: the geometry plus the force's position and the sensor's range.
SIDECAR_TABLES: dict[str, tuple[str, ...]] = {
    "beam": ("length_m", "linear_density_kg_m", "width_m", "thickness_m", "material", "youngs_modulus_Pa",
             "density_kg_m3"),
    "patch": ("start_m", "end_m"),
    "force": ("position_m",),
    "sensor": ("position_m", "range", "mass_kg", "mass_approximate", "unit"),
}
#: Sidecar keys that describe the beam or the sensor but are not geometry (read by :func:`read_description`).
DESCRIPTION_KEYS: frozenset[tuple[str, str]] = frozenset({
    ("beam", "width_m"), ("beam", "thickness_m"), ("beam", "material"), ("beam", "youngs_modulus_Pa"),
    ("beam", "density_kg_m3"), ("sensor", "range"), ("sensor", "mass_kg"), ("sensor", "mass_approximate"),
    ("sensor", "output"), ("sensor", "unit"),
})
#: Log standard deviation of the prior of a sensor mass that was weighed (``[sensor] mass_kg``).
KNOWN_MASS_LOG_SD = 0.02
#: Log standard deviation of the prior of an approximate sensor mass (``mass_approximate = true``):
#: a factor 1.4 at one sigma (a phone of 150-250 g given as 200 g).
APPROXIMATE_MASS_LOG_SD = 0.35

#: Data columns of a :class:`Measurement` (every input and output column).
_DATA_COLUMNS: tuple[str, ...] = ALL_COLUMNS[1:]


@dataclass(frozen=True, eq=False)
class Measurement:
    """A measured (or simulated) record with the geometry the lab knows.

    Give ``time_s``, at most one input column (``voltage_V`` or ``force_N``) and exactly one
    output column (``displacement_m``, ``velocity_m_s`` or ``acceleration_m_s2``); the others
    stay None. The general view is :attr:`input_kind` / :attr:`input` and :attr:`output_kind`
    / :attr:`output`.

    Parameters
    ----------
    name : str
        File stem ``NAME`` of ``NAME.csv`` / ``NAME.toml``.
    title : str
        Human title (defaults to ``name`` in files without one).
    geometry : BeamGeometry
        Beam, patch (required with a voltage input), force position (required with a force
        input) and sensor.
    time_s : numpy.ndarray
        Sample times (s), strictly increasing, at least two, possibly irregular (see the module
        notes).
    voltage_V : numpy.ndarray or None
        Piezo voltage (V), held over each sample interval.
    displacement_m : numpy.ndarray or None
        Displacement at the sensor (m).
    nominal : dict
        Prior centres keyed by parameter name (units in the names).
    csv_path, toml_path : Path or None
        Where it was read from or written to.
    force_N : numpy.ndarray or None
        Point force (N) at ``geometry.force_position_m``, held over each sample interval.
    velocity_m_s, acceleration_m_s2 : numpy.ndarray or None
        Velocity (m/s) or acceleration (m/s²) at the sensor.
    strain : numpy.ndarray or None
        Strain (dimensionless, SI: 1e-6 is one microstrain) of a gauge on the strip's surface at
        the sensor, -(h/2) w''(x_obs); needs the thickness h (``geometry.thickness_m``).
    sensor_range : float or None
        The sensor's full scale in the output's unit (``[sensor] range``), for clipping.
    nominal_spread : dict
        Log standard deviation of the prior around a nominal value, by parameter name, where the
        beam's description says how well it is known (a material's spread, a weighed sensor);
        parameters not in it take the calibration's defaults.
    nominal_origin : dict
        Where a nominal value not written in ``[nominal]`` came from, by parameter name (the
        beam's description, or the record's lowest strong spectral peak).
    source : tuple of str
        For a record read from another format: what was read and done, one line each.
    arbitrary_units : bool
        True when the output is in arbitrary units: proportional to its quantity (the output
        column's), the scale unknown (ADC counts, an uncalibrated sensor's volts). A linear
        calibration of a free decay does not need the scale (the initial state and the offset
        absorb it); an effect whose force depends on the amplitude does
        (:func:`true_unit_problem`).

    Raises
    ------
    BeamInputError
        No or two output columns, two input columns, arrays of different lengths, fewer than
        two samples, non-finite values, time that does not increase or has a gap of more than
        :data:`MAX_GAP_STEPS` median steps; an input without the geometry it needs; a record
        more than half clipped; unknown or non-positive nominal values.
    """

    name: str
    title: str
    geometry: BeamGeometry
    time_s: np.ndarray = field(repr=False)
    voltage_V: np.ndarray | None = field(default=None, repr=False)
    displacement_m: np.ndarray | None = field(default=None, repr=False)
    nominal: dict[str, float] = field(default_factory=dict)
    csv_path: Path | None = None
    toml_path: Path | None = None
    force_N: np.ndarray | None = field(default=None, repr=False)
    velocity_m_s: np.ndarray | None = field(default=None, repr=False)
    acceleration_m_s2: np.ndarray | None = field(default=None, repr=False)
    strain: np.ndarray | None = field(default=None, repr=False)
    sensor_range: float | None = None
    nominal_spread: dict[str, float] = field(default_factory=dict)
    nominal_origin: dict[str, str] = field(default_factory=dict)
    source: tuple[str, ...] = ()
    arbitrary_units: bool = False
    uniform: bool = field(init=False, repr=False)
    clipped: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        _check_label("name", self.name)
        _check_label(f"measurement {self.name}: title", self.title)
        where = f"measurement {self.name}"
        given = [c for c in _DATA_COLUMNS if getattr(self, c) is not None]
        inputs = [c for c in given if c in INPUT_COLUMNS]
        outputs = [c for c in given if c in OUTPUT_COLUMNS]
        if len(inputs) > 1:
            raise BeamInputError(f"{where}: two input columns ({', '.join(inputs)}); a record has at most one input")
        if len(outputs) != 1:
            detail = "none" if not outputs else ", ".join(outputs)
            raise BeamInputError(
                f"{where}: needs exactly one output column ({', '.join(OUTPUT_COLUMNS)}), got {detail}"
            )
        columns = {}
        for column in ("time_s", *given):
            values = np.array(getattr(self, column), dtype=float)
            if values.ndim != 1:
                raise BeamInputError(f"{where}: {column} must be 1-D, got shape {values.shape}")
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                raise BeamInputError(f"{where}: {column}[{bad[0]}] = {values[bad[0]]} is not finite")
            values.setflags(write=False)
            columns[column] = values
            object.__setattr__(self, column, values)
        lengths = {c: v.size for c, v in columns.items()}
        if len(set(lengths.values())) != 1:
            raise BeamInputError(f"{where}: columns differ in length: {lengths}")
        problem = time_stamp_problem(columns["time_s"])
        if problem is not None:
            index, message = problem
            at = "" if index is None else f"sample {index}: "
            raise BeamInputError(f"{where}: {at}{message}")
        if inputs == ["voltage_V"] and not self.geometry.has_patch:
            raise BeamInputError(f"{where}: a voltage_V input needs the patch (the geometry has none)")
        if inputs == ["force_N"] and self.geometry.force_position_m is None:
            raise BeamInputError(f"{where}: a force_N input needs the force's position (geometry.force_position_m)")
        if outputs == ["strain"] and self.geometry.thickness_m is None:
            raise BeamInputError(f"{where}: a strain output needs the strip's thickness: [beam] thickness_m (with width_m)")
        if self.sensor_range is not None:
            number = as_finite_float(self.sensor_range)
            if number is None or number <= 0:
                raise BeamInputError(f"{where}: sensor range must be a positive finite number, got {short_repr(self.sensor_range)}")
            object.__setattr__(self, "sensor_range", number)
        clipped = clipped_samples(columns[outputs[0]], self.sensor_range)
        clipped.setflags(write=False)
        problem = clipping_problem(clipped, outputs[0], self.sensor_range)
        if problem is not None:
            raise BeamInputError(f"{where}: {problem}")
        object.__setattr__(self, "clipped", clipped)
        object.__setattr__(self, "uniform", uniform_time_problem(columns["time_s"]) is None)
        object.__setattr__(self, "nominal", check_nominal(self.nominal, f"{where}: nominal"))
        spread = check_nominal(self.nominal_spread, f"{where}: nominal_spread")
        unknown = [name for name in spread if name not in self.nominal]
        if unknown:
            raise BeamInputError(f"{where}: nominal_spread {unknown[0]}: has no nominal value")
        object.__setattr__(self, "nominal_spread", spread)
        object.__setattr__(self, "nominal_origin", dict(self.nominal_origin))
        object.__setattr__(self, "source", tuple(str(line) for line in self.source))
        object.__setattr__(self, "arbitrary_units", bool(self.arbitrary_units))

    # ------------------------------------------------------------------ columns
    @property
    def input_column(self) -> str | None:
        """``"voltage_V"``, ``"force_N"`` or None (a free response)."""
        return next((c for c in INPUT_COLUMNS if getattr(self, c) is not None), None)

    @property
    def input_kind(self) -> str | None:
        """``"voltage"``, ``"force"`` or None (a free response: nothing drives the beam)."""
        column = self.input_column
        return None if column is None else INPUT_COLUMNS[column]

    @property
    def input(self) -> np.ndarray | None:
        """The input samples (V or N), None for a free response."""
        column = self.input_column
        return None if column is None else getattr(self, column)

    @property
    def input_unit(self) -> str | None:
        """``"V"``, ``"N"`` or None."""
        column = self.input_column
        return None if column is None else COLUMN_UNITS[column]

    @property
    def prior_nominal(self) -> dict[str, float]:
        """Prior centres by parameter name: :attr:`nominal`, plus the stated length as the centre
        of ``effective_length_m`` (the free length) unless ``[nominal]`` gives one."""
        return {effective_length.LENGTH.name: float(self.geometry.length_m), **self.nominal}

    @property
    def output_column(self) -> str:
        """``"displacement_m"``, ``"velocity_m_s"``, ``"acceleration_m_s2"`` or ``"strain"``."""
        return next(c for c in OUTPUT_COLUMNS if getattr(self, c) is not None)

    @property
    def output_kind(self) -> str:
        """``"displacement"``, ``"velocity"``, ``"acceleration"`` or ``"strain"``."""
        return OUTPUT_COLUMNS[self.output_column]

    @property
    def output(self) -> np.ndarray:
        """The sensor's samples (m, m/s or m/s²)."""
        return getattr(self, self.output_column)

    @property
    def output_unit(self) -> str:
        """``"m"``, ``"m/s"``, ``"m/s²"`` or ``"1"`` (strain); :data:`ARBITRARY_UNIT` for a record in
        arbitrary units."""
        return ARBITRARY_UNIT if self.arbitrary_units else COLUMN_UNITS[self.output_column]

    @property
    def columns(self) -> tuple[str, ...]:
        """The CSV header of this record, e.g. ``("time_s", "acceleration_m_s2")``."""
        return ("time_s",) + ((self.input_column,) if self.input_column else ()) + (self.output_column,)

    @property
    def is_free(self) -> bool:
        """True for a free response (no input column)."""
        return self.input_column is None

    @property
    def features(self) -> frozenset[str]:
        """The features of the record that effects can need (:data:`beam.physics.effects.RECORD_FEATURES`)
        read from the record itself, without its spectra (a diagnosis adds ``rising_frequency``,
        :func:`beam.discovery.ranking.record_features`)."""
        free = self.is_free
        features = {"patch" if self.geometry.has_patch else "no_patch", "free" if free else "input"}
        if self.output_kind == "acceleration":
            features.add("contact_sensor")
        if self.uniform:
            features.add("uniform")
        if self.output_kind == "displacement":
            features.add("displacement")
        if self.geometry.width_m is not None:
            features.add("width")
        return frozenset(features)

    @property
    def clipped_count(self) -> int:
        """Number of clipped samples (see the module notes)."""
        return int(np.count_nonzero(self.clipped))

    # ------------------------------------------------------------------ time
    @property
    def sample_count(self) -> int:
        """Number of samples n."""
        return int(self.time_s.size)

    @property
    def sample_interval_s(self) -> float:
        """Sampling interval dt = (t_last - t_0) / (n - 1) (s) of a uniform record.

        Raises BeamInputError for an irregular record, which has none (use :attr:`time_s`, or
        :attr:`median_interval_s` for a typical step).
        """
        if not self.uniform:
            raise BeamInputError(
                f"measurement {self.name}: the time stamps are irregular (steps from {self.min_interval_s:.6g} to "
                f"{self.max_interval_s:.6g} s): there is no single sampling interval; this use needs a uniform record"
            )
        return float((self.time_s[-1] - self.time_s[0]) / (self.time_s.size - 1))

    @property
    def median_interval_s(self) -> float:
        """Median time step (s)."""
        return float(np.median(np.diff(self.time_s)))

    @property
    def min_interval_s(self) -> float:
        """Smallest time step (s)."""
        return float(np.min(np.diff(self.time_s)))

    @property
    def max_interval_s(self) -> float:
        """Largest time step (s)."""
        return float(np.max(np.diff(self.time_s)))

    @property
    def rate_Hz(self) -> float:
        """Sampling rate 1 / dt (Hz); for an irregular record 1 / median step."""
        return 1.0 / (self.sample_interval_s if self.uniform else self.median_interval_s)

    @property
    def duration_s(self) -> float:
        """Time covered by the record, n dt (s): the last sample is held for one interval too
        (for an irregular record: t_last - t_0 plus one median step)."""
        if self.uniform:
            return self.sample_count * self.sample_interval_s
        return float(self.time_s[-1] - self.time_s[0]) + self.median_interval_s


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
                f"known parameters: {parameter_listing()}"
            )
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise BeamInputError(f"{where} {name}: must be a number, got {short_repr(value)}")
        number = as_finite_float(value)
        if number is None or number <= 0:
            raise BeamInputError(f"{where} {name}: must be a positive finite number, got {short_repr(value)}")
        checked[name] = number
    return checked


def time_stamp_problem(time_s: np.ndarray) -> tuple[int | None, str] | None:
    """Why ``time_s`` cannot be a record's time stamps, or None if it can (see the module notes).

    Parameters
    ----------
    time_s : numpy.ndarray
        Finite sample times (s).

    Returns
    -------
    tuple or None
        ``(index, message)`` with the 0-based index of the first offending sample (None when
        the whole record is at fault), or None when the stamps are fine: at least two, strictly
        increasing, a finite span, a median step of at least :data:`MIN_SAMPLE_INTERVAL_S` and
        no step longer than :data:`MAX_GAP_STEPS` median steps.
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
    if not (math.isfinite(span) and np.all(np.isfinite(steps))):
        return None, (
            f"time_s runs from {float(time_s[0])!r} to {float(time_s[-1])!r}: the span overflows a float; "
            "give times in seconds"
        )
    typical_step = float(np.median(steps))
    if typical_step < MIN_SAMPLE_INTERVAL_S or not math.isfinite(1.0 / typical_step):
        return None, (
            f"the sampling interval {typical_step!r} s is too small (at least {MIN_SAMPLE_INTERVAL_S:g} s, "
            f"a sampling rate of at most {1 / MIN_SAMPLE_INTERVAL_S:g} Hz); give times in seconds"
        )
    gaps = np.flatnonzero(steps > MAX_GAP_STEPS * typical_step)
    if gaps.size:
        k = int(gaps[0]) + 1
        return k, (
            f"time step {steps[k - 1]:.9g} s (from time_s = {float(time_s[k - 1])!r} to {float(time_s[k])!r}) is "
            f"{steps[k - 1] / typical_step:.3g} times the record's median step {typical_step:.9g} s, more than the "
            f"{MAX_GAP_STEPS} allowed: a hole in the record; split it there"
        )
    return None


def uniform_time_problem(time_s: np.ndarray) -> tuple[int, str] | None:
    """Why valid stamps ``time_s`` are not a uniform grid, or None if they are (tolerance 1 %).

    Every step within :data:`UNIFORM_TIME_TOLERANCE` of the median step and every stamp within
    that fraction of a step of t_0 + k dt, dt = (t_last - t_0) / (n - 1).
    """
    n = time_s.size
    steps = np.diff(time_s)
    step = (float(time_s[-1]) - float(time_s[0])) / (n - 1)
    typical_step = float(np.median(steps))
    irregular = np.flatnonzero(np.abs(steps - typical_step) > UNIFORM_TIME_TOLERANCE * typical_step)
    if irregular.size:
        k = int(irregular[0]) + 1
        return k, (
            f"time step {steps[k - 1]:.9g} s (from time_s = {float(time_s[k - 1])!r} to {float(time_s[k])!r}) "
            f"differs from the record's step {typical_step:.9g} s; samples must be uniformly spaced "
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


def time_grid_problem(time_s: np.ndarray) -> tuple[int | None, str] | None:
    """Why ``time_s`` is not a valid *uniform* grid (stamps first, then uniformity), or None.

    For uses that need a uniform record (a voltage replayed by a simulation config).
    """
    return time_stamp_problem(time_s) or uniform_time_problem(time_s)


def clipped_samples(output: np.ndarray, sensor_range: float | None = None) -> np.ndarray:
    """Boolean mask of clipped output samples (see the module notes).

    Parameters
    ----------
    output : (n,) array
        The sensor's samples.
    sensor_range : float, optional
        Full scale of the sensor in the output's unit; samples with
        |y| >= (1 - :data:`CLIP_RANGE_FRACTION`) range are clipped.

    Returns
    -------
    (n,) bool array
        Samples at the range, and samples in runs of at least :data:`MIN_CLIP_RUN` equal
        values at the record's maximum or minimum inside the record (a flat stretch that
        starts or ends the record is a beam at rest or a held deflection, not clipping;
        nothing for a constant record).
    """
    values = np.asarray(output, dtype=float)
    mask = np.zeros(values.size, dtype=bool)
    if sensor_range is not None:
        mask |= np.abs(values) >= (1.0 - CLIP_RANGE_FRACTION) * float(sensor_range)
    if values.size == 0:
        return mask
    high, low = float(values.max()), float(values.min())
    if high == low:
        return mask
    for extreme in (high, low):
        at = np.concatenate([[False], values == extreme, [False]])
        edges = np.flatnonzero(np.diff(at.astype(np.int8)))
        for start, stop in zip(edges[0::2], edges[1::2]):
            if stop - start >= MIN_CLIP_RUN and start > 0 and stop < values.size:
                mask[start:stop] = True
    return mask


def clipping_problem(clipped: np.ndarray, column: str, sensor_range: float | None) -> str | None:
    """Why a record with this clipping mask cannot be used (more than half clipped), or None."""
    count, n = int(np.count_nonzero(clipped)), clipped.size
    if 2 * count <= n:
        return None
    source = f"at the sensor's range {sensor_range:g} {COLUMN_UNITS[column]} or " if sensor_range is not None else ""
    return (
        f"{count} of {n} samples of {column} are clipped ({source}in runs of {MIN_CLIP_RUN} or more equal samples at "
        "the record's extreme), more than half: the sensor was saturated; record with a larger range"
    )


# ---------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MeasurementTable:
    """The columns of a measurement CSV, as read by :func:`read_measurement_table`.

    Attributes
    ----------
    columns : tuple of str
        The header, e.g. ``("time_s", "force_N", "acceleration_m_s2")``.
    time_s : numpy.ndarray
        Time stamps (s).
    input_column : str or None
        ``"voltage_V"``, ``"force_N"`` or None.
    input : numpy.ndarray or None
        The input samples.
    output_column : str
        The output column's name.
    output : numpy.ndarray
        The output samples.
    uniform : bool
        Whether the stamps form a uniform grid (module notes).
    """

    columns: tuple[str, ...]
    time_s: np.ndarray
    input_column: str | None
    input: np.ndarray | None
    output_column: str
    output: np.ndarray
    uniform: bool

    def arrays(self) -> dict[str, np.ndarray]:
        """Column name to array (time, input if any, output)."""
        return record_arrays(self)


@dataclass(frozen=True)
class Sidecar:
    """What a measurement sidecar holds (:func:`load_sidecar`).

    ``nominal`` holds ``[nominal]`` plus what the beam's description gives (the bending
    stiffness from E, width and thickness; the sensor's mass), ``nominal_spread`` the log
    standard deviations the description sets, ``nominal_origin`` where a derived value came from.
    """

    title: str | None
    geometry: BeamGeometry
    nominal: dict[str, float]
    sensor_range: float | None = None
    nominal_spread: dict[str, float] = field(default_factory=dict)
    nominal_origin: dict[str, str] = field(default_factory=dict)
    arbitrary_units: bool = False


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


def read_measurement(path: str | os.PathLike[str], *, beam: Any = None, **record_options: Any) -> Measurement:
    """Read ``NAME.csv`` and its sidecar ``NAME.toml``, or a record in another format.

    Parameters
    ----------
    path : str or path-like
        Either file of the pair (the other is found next to it), or ``NAME`` alone; or a file in
        any format :func:`beam.io.readers.read_record` reads (a phyphox export, an ``.lvm``, a
        ``.mat``...). A ``.csv`` is the project's own when its header follows the rule above or
        tries to (it names one of the project's columns, or holds numbers and no reading option
        is given): then its errors are the project's. Anything else is read by
        :mod:`beam.io.readers`, with the beam described by ``beam`` or by a sidecar ``STEM.toml``
        next to the file (:func:`measurement_from_record`); when such a ``.csv``
        is not readable either, the message gives the project's header rule and the reason.
    beam : path-like or mapping, optional
        For a record in another format: the sidecar (a TOML path, or the document as a mapping)
        describing the beam, instead of ``STEM.toml``.
    **record_options
        ``format``, ``column``, ``axis``, ``rate``, ``time_unit``, ``unit``, ``segment`` of
        :func:`beam.io.readers.read_record`, for a record in another format.

    Returns
    -------
    Measurement

    Raises
    ------
    BeamInputError
        A missing or malformed file; one line naming the file and the line or key.
    """
    options = {key: value for key, value in record_options.items() if value is not None}
    if beam is not None or options or not is_project_file(path):
        from beam.io.readers import read_record

        try:
            record = read_record(path, **options)
        except BeamInputError as exc:
            header = _first_line(Path(path)) if Path(path).suffix.lower() == ".csv" and not options else None
            if header is None:
                raise
            try:
                _check_header(Path(path), header)
            except BeamInputError as project:  # say both: first what the reader found and the option that helps
                reason = str(exc).removeprefix(f"{path}: ")
                rule = str(project).removeprefix(f"{path}: ")
                raise BeamInputError(f"{path}: read as another format: {reason}; not the project's own CSV either "
                                     f"({rule})") from None
            raise
        return measurement_from_record(record, beam)
    csv_path, toml_path = measurement_paths(path)
    csv_exists, toml_exists = _exists(csv_path), _exists(toml_path)
    if not csv_exists and not toml_exists:
        raise BeamInputError(f"{path}: not found (a measurement is NAME.csv plus its sidecar NAME.toml)")
    if not toml_exists:
        raise BeamInputError(f"{csv_path}: sidecar {toml_path.name} not found next to it (it holds the geometry)")
    if not csv_exists:
        raise BeamInputError(f"{toml_path}: data file {csv_path.name} not found next to it")
    # the CSV's header first: it says which sidecar tables are required ([patch], [force])
    text = read_text_file(csv_path, "measurement CSV", MAX_MEASUREMENT_BYTES)
    lines = _lines(text)
    try:
        header = _check_header(csv_path, lines[0]) if lines else ()
    except BeamInputError as exc:
        raise BeamInputError(f"{exc}{_readable_otherwise(csv_path)}") from None
    input_column = next((c for c in header if c in INPUT_COLUMNS), None)
    sidecar = load_sidecar(toml_path, input_kind=INPUT_COLUMNS.get(input_column))
    table = _table_from_lines(csv_path, lines, sidecar.sensor_range)
    nominal, origin = anchored(sidecar, table.time_s, table.output, OUTPUT_COLUMNS[table.output_column],
                               INPUT_COLUMNS.get(input_column), table.input)
    return Measurement(
        name=csv_path.stem, title=sidecar.title if sidecar.title is not None else csv_path.stem,
        geometry=sidecar.geometry, time_s=table.time_s, nominal=nominal, csv_path=csv_path,
        toml_path=toml_path, sensor_range=sidecar.sensor_range, nominal_spread=sidecar.nominal_spread,
        nominal_origin=origin, arbitrary_units=sidecar.arbitrary_units,
        **{name: values for name, values in table.arrays().items() if name != "time_s"},
    )


def _readable_otherwise(path: Path) -> str:
    """For a CSV that names the project's columns but breaks its header rule: the way to read it
    as a table in its own units (``--format text``) when the readers can ('' otherwise)."""
    from beam.io.readers import read_record

    try:
        record = read_record(path, format="text")
    except BeamInputError:
        return ""
    signal = next((f.chosen for f in record.findings if f.topic == "signal"), record.output_column)
    return f"; or read it as a table in its own units with --format text (its signal: {signal})"


def true_unit_problem(measurement: Measurement, effects) -> str | None:
    """Why ``effects`` (ids, or a comma-separated string) cannot be calibrated on ``measurement``,
    None when they can.

    A record in arbitrary units (:attr:`Measurement.arbitrary_units`) fits every linear model of
    a free decay (the initial state and the offset take the scale), but an effect whose force
    depends on the amplitude (a nonlinear one: :attr:`beam.physics.effects.Effect.nonlinear`,
    the air drag, the clamp's friction, the tip's cubic spring) reads a size in metres from the
    signal, which an unknown scale does not give.
    """
    from beam.physics.effects import EFFECTS, parse_effects

    if not measurement.arbitrary_units:
        return None
    needing = [e for e in parse_effects(effects) if EFFECTS[e].nonlinear]
    if not needing:
        return None
    verb = "needs" if len(needing) == 1 else "need"
    return (f"{', '.join(needing)} {verb} the signal in its true unit: {'its force depends' if len(needing) == 1 else 'their forces depend'} "
            f"on the amplitude, and measurement {measurement.name} is in arbitrary units (its scale unknown); give "
            "the signal's unit (--unit), or calibrate without it (a linear model does not need the scale)")


def anchored(sidecar: Sidecar, time_s: np.ndarray, output: np.ndarray, output_kind: str,
             input_kind: str | None, input: np.ndarray | None = None) -> tuple[dict[str, float], dict[str, str]]:
    """The sidecar's nominal values plus, without a bending stiffness, the one anchored on the
    record's lowest strong spectral peak (:func:`beam.io.anchor.anchor_nominal`); and their origins."""
    from beam.io.anchor import anchor_nominal

    nominal, origin = anchor_nominal(sidecar.geometry, sidecar.nominal, time_s, output, output_kind, input_kind, input)
    return nominal, {**sidecar.nominal_origin, **origin}


def is_project_file(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is read as the project's own ``NAME.csv`` + ``NAME.toml`` (see :func:`read_measurement`).

    True for ``NAME``, ``NAME.toml``, a missing ``NAME.csv`` and a CSV whose first line is the
    project's header, tries to be (names one of :data:`ALL_COLUMNS` or ``quantity_unit`` of a
    project quantity) or holds only numbers; False for any other file.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".toml" or (not suffix and not _exists(path)):
        return True
    if suffix == ".csv" and not _exists(path):
        return True
    if suffix != ".csv" or path.is_dir():
        return False
    first = _first_line(path)
    if first is None:
        return True  # let the project's reader report it
    names = [name.strip().strip('"') for name in re.split(r"[,;\t]", first.strip())]
    if not any(names):
        return True
    if any(name in ALL_COLUMNS for name in names):
        return True
    if any("_" in name and name.split("_", 1)[0].lower() in _QUANTITIES and " " not in name for name in names):
        return True
    return all(_looks_numeric(name) for name in names if name)


def _first_line(path: Path) -> str | None:
    """The first line of a file (at most 4 KiB, undecodable bytes replaced), None if unreadable."""
    try:
        with open(path, "rb") as handle:
            return handle.readline(4096).decode("utf-8-sig", errors="replace").rstrip("\r\n")
    except OSError:
        return None


def _lines(text: str) -> list[str]:
    """The lines of a CSV's text (any line ending), trailing blank lines dropped."""
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    while lines and not lines[-1].strip():
        lines.pop()
    return lines


def _exists(path: Path) -> bool:
    """Whether ``path`` exists; a name the system refuses (too long, a NUL) is a BeamInputError."""
    try:
        return path.exists()
    except (OSError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise BeamInputError(f"{path}: cannot open: {reason}") from None


def read_sidecar(
    path: str | os.PathLike[str], input_kind: str | None = "voltage"
) -> tuple[str | None, BeamGeometry, dict[str, float]]:
    """Title, geometry and nominal values from a measurement ``NAME.toml``.

    Parameters
    ----------
    path : str or path-like
        The sidecar.
    input_kind : {"voltage", "force", None}
        The record's input: ``[patch]`` is required for a voltage, ``[force] position_m`` for a
        force (default: voltage, the classic record).

    Returns
    -------
    title : str or None
        The ``title`` key, None when absent.
    geometry : BeamGeometry
    nominal : dict
        ``[nominal]`` values (empty when absent).
    """
    sidecar = load_sidecar(path, input_kind=input_kind)
    return sidecar.title, sidecar.geometry, sidecar.nominal


def load_sidecar(path: str | os.PathLike[str], input_kind: str | None = "voltage", record: Any = None) -> Sidecar:
    """Everything a measurement sidecar holds, including ``[sensor] range`` and the beam's
    description (see :func:`read_sidecar`, :func:`read_description`). ``record`` is unused
    (kept for a reader of another format to pass what it read)."""
    return _sidecar(TomlReader(load_toml(path, "sidecar"), path), input_kind)


def sidecar_from_document(document: Mapping[str, Any], where: str, input_kind: str | None = None,
                          record: Any = None) -> Sidecar:
    """A sidecar given as a parsed document (command-line flags) instead of a file; ``where``
    names it in messages."""
    return _sidecar(TomlReader(dict(document), where), input_kind)


def _sidecar(reader: TomlReader, input_kind: str | None) -> Sidecar:
    reader.check_top_level(tables=(*SIDECAR_TABLES, "nominal"), keys=("title",))
    title = read_title(reader)
    description = read_description(reader)
    geometry = read_geometry(reader, tables=SIDECAR_TABLES, input_kind=input_kind, description=description)
    sensor = reader.table("sensor")
    sensor_range = reader.number("sensor", sensor, "range", required=False)
    unit = reader.string("sensor", sensor, "unit", required=False)
    if unit is not None and unit != "arbitrary":
        raise reader.fail("[sensor] unit", f"must be \"arbitrary\" (a signal of unknown scale; the output column's name "
                          f"gives the SI unit otherwise), got {short_repr(unit)}")
    nominal, spread, origin = described_nominal(read_nominal(reader), description)
    return Sidecar(title, geometry, nominal, sensor_range, spread, origin, unit == "arbitrary")


def described_nominal(nominal: Mapping[str, float], description: Mapping[str, Any]
                      ) -> tuple[dict[str, float], dict[str, float], dict[str, str]]:
    """``[nominal]`` plus what the beam's description (:func:`read_description`) gives where
    ``[nominal]`` is silent: the bending stiffness E b h³ / 12 and the sensor's mass, with the
    log standard deviations of their priors and where they came from.

    Returns
    -------
    (nominal, nominal_spread, nominal_origin)
    """
    nominal = dict(nominal)
    spread: dict[str, float] = {}
    origin: dict[str, str] = {}
    stiffness = description.get("bending_stiffness_Nm2")
    if stiffness is not None and "bending_stiffness_Nm2" not in nominal:
        nominal["bending_stiffness_Nm2"] = stiffness
        spread["bending_stiffness_Nm2"] = description["bending_stiffness_spread"]
        origin["bending_stiffness_Nm2"] = description["bending_stiffness_origin"]
    mass = description.get("sensor_mass_kg")
    if mass is not None and "sensor_mass_kg" not in nominal:
        nominal["sensor_mass_kg"] = mass
        approximate = description["sensor_mass_approximate"]
        spread["sensor_mass_kg"] = APPROXIMATE_MASS_LOG_SD if approximate else KNOWN_MASS_LOG_SD
        origin["sensor_mass_kg"] = "[sensor] mass_kg" + (" (approximate)" if approximate else " (weighed)")
    return nominal, spread, origin


def read_description(reader: TomlReader, tables: Mapping[str, tuple[str, ...]] | None = None) -> dict[str, Any]:
    """The beam in a student's words: ``[beam]`` width, thickness, material or E and density;
    ``[sensor]`` mass (:mod:`beam.io.materials`).

    ``tables`` (default :data:`SIDECAR_TABLES`) are the keys ``[beam]`` and ``[sensor]`` may
    hold (a simulation config's, :data:`beam.io.config.CONFIG_GEOMETRY_TABLES`, add ``[sensor] output``).

    Returns
    -------
    dict
        ``linear_density_kg_m`` (rho b h, when width, thickness and a density are given),
        ``bending_stiffness_Nm2`` (E b h³ / 12, when width, thickness and E are given) with
        ``bending_stiffness_spread`` (log sd of its prior) and ``bending_stiffness_origin``;
        ``sensor_mass_kg`` and ``sensor_mass_approximate`` when ``[sensor] mass_kg`` is given.
        Absent keys: not derivable.

    Raises
    ------
    BeamInputError
        An unknown material, a material together with E or density, a width or thickness
        without the other, a thickness larger than the width or the length.
    """
    from beam.io.materials import (
        bending_stiffness,
        bending_stiffness_spread,
        find_material,
        linear_density,
    )

    beam = reader.table("beam", required=False) or {}
    sensor = reader.table("sensor", required=False) or {}
    tables = SIDECAR_TABLES if tables is None else tables
    reader.check_keys("beam", beam, tables["beam"])
    reader.check_keys("sensor", sensor, tables["sensor"])
    out: dict[str, Any] = {}
    width = reader.number("beam", beam, "width_m", required=False)
    thickness = reader.number("beam", beam, "thickness_m", required=False)
    modulus = reader.number("beam", beam, "youngs_modulus_Pa", required=False)
    density = reader.number("beam", beam, "density_kg_m3", required=False)
    modulus_spread = None
    material_name = reader.string("beam", beam, "material", required=False)
    if material_name is not None:
        try:
            material = find_material(material_name)
        except BeamInputError as exc:
            raise reader.fail("[beam] material", str(exc)) from None
        modulus_spread = material.youngs_modulus_spread if modulus is None else None
        modulus = material.youngs_modulus_Pa if modulus is None else modulus
        density = material.density_kg_m3 if density is None else density
        material_name = material.name
    if (width is None) != (thickness is None):
        missing = "thickness_m" if thickness is None else "width_m"
        raise reader.fail(f"[beam] {missing}", "missing key; width_m and thickness_m describe the strip together")
    if width is not None:
        length = reader.number("beam", beam, "length_m", required=False)
        if thickness > width:
            raise reader.fail("[beam] thickness_m", f"{thickness!r} m is more than width_m = {width!r} m; the strip "
                                                    "bends about its width (swap them?)")
        if length is not None and width > length:
            raise reader.fail("[beam] width_m", f"{width!r} m is more than length_m = {length!r} m")
        if density is not None:
            out["linear_density_kg_m"] = linear_density(density, width, thickness)
        if modulus is not None and length is not None:
            out["bending_stiffness_Nm2"] = bending_stiffness(modulus, width, thickness)
            out["bending_stiffness_spread"] = bending_stiffness_spread(
                modulus_spread if modulus_spread is not None else 0.0, length, width, thickness)
            source = f"{material_name}'s E" if modulus_spread is not None else "youngs_modulus_Pa"
            out["bending_stiffness_origin"] = f"E b h³ / 12 from {source}, width_m and thickness_m"
    mass = reader.number("sensor", sensor, "mass_kg", required=False)
    if mass is not None:
        approximate = sensor.get("mass_approximate", False)
        if not isinstance(approximate, bool):
            raise reader.fail("[sensor] mass_approximate", f"must be true or false, got {short_repr(approximate)}")
        out["sensor_mass_kg"] = mass
        out["sensor_mass_approximate"] = approximate
    elif "mass_approximate" in sensor:
        raise reader.fail("[sensor] mass_approximate", "given without mass_kg")
    return out


def read_title(reader: TomlReader) -> str | None:
    """The optional top-level ``title`` string."""
    return reader.string(None, reader.document, "title", required=False)


_INPUT_NEEDS = {"voltage": ("patch", "voltage_V"), "force": ("force", "force_N")}


def read_geometry(
    reader: TomlReader, tables: Mapping[str, tuple[str, ...]] = GEOMETRY_TABLES, input_kind: str | None = "voltage",
    description: Mapping[str, Any] | None = None,
) -> BeamGeometry:
    """``[beam]``, ``[patch]``, ``[force]``, ``[sensor]`` of a sidecar or config as a :class:`BeamGeometry`.

    Parameters
    ----------
    reader : TomlReader
        The parsed file.
    tables : mapping
        Tables and the keys each may hold (:data:`GEOMETRY_TABLES` for a config,
        :data:`SIDECAR_TABLES` for a sidecar); only ``position_m`` / ``start_m`` / ``end_m`` /
        ``length_m`` / ``linear_density_kg_m`` are geometry (``[sensor] range`` is read by
        :func:`load_sidecar`).
    input_kind : {"voltage", "force", None}
        Which tables are required besides ``[beam]`` and ``[sensor]``: ``[patch]`` for a
        voltage, ``[force]`` for a force.
    description : mapping, optional
        :func:`read_description` of the file: its ``linear_density_kg_m`` (rho b h) stands in
        for a missing ``[beam] linear_density_kg_m``.
    """
    required = {"beam", "sensor"}
    if input_kind in _INPUT_NEEDS:
        required.add(_INPUT_NEEDS[input_kind][0])
    values: dict[tuple[str, str], float | None] = {}
    for table_name, keys in tables.items():
        table = reader.table(table_name, required=False)
        if table is None:
            if table_name in required:
                needed_by = next((col for tab, col in _INPUT_NEEDS.values() if tab == table_name), None)
                reason = f" (a {needed_by} input needs it)" if needed_by else ""
                raise reader.fail(f"[{table_name}]", f"missing table{reason}")
            continue
        reader.check_keys(table_name, table, keys)
        for key in keys:
            if (table_name, key) in DESCRIPTION_KEYS:
                continue
            if (table_name, key) == ("beam", "linear_density_kg_m") and key not in table:
                derived = (description or {}).get("linear_density_kg_m")
                if derived is None:
                    raise reader.fail("[beam] linear_density_kg_m", "missing key; give it, or width_m, thickness_m and "
                                      "material (or density_kg_m3)" if "material" in tables.get("beam", ()) else "missing key")
                values[(table_name, key)] = derived
                continue
            values[(table_name, key)] = reader.number(table_name, table, key, positive=table_name == "beam")
    for (table_name, key), value in values.items():
        if table_name in ("patch", "sensor", "force") and value < 0:
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
            patch_start_m=values.get(("patch", "start_m")),
            patch_end_m=values.get(("patch", "end_m")),
            sensor_position_m=values[("sensor", "position_m")],
            force_position_m=values.get(("force", "position_m")),
            width_m=(reader.number("beam", reader.table("beam"), "width_m", required=False)
                     if "width_m" in tables.get("beam", ()) else None),  # for the quadratic drag
            thickness_m=(reader.number("beam", reader.table("beam"), "thickness_m", required=False)
                         if "thickness_m" in tables.get("beam", ()) else None),  # for a strain output
        )
    except BeamInputError as exc:  # the patch, force or sensor does not fit on the beam
        message = str(exc)
        table = next((f"[{name}]" for name in ("patch", "sensor", "force") if message.startswith(name)), "[beam]")
        raise reader.fail(table, message) from None


def read_nominal(reader: TomlReader) -> dict[str, float]:
    """The optional ``[nominal]`` table (prior centres), validated."""
    table = reader.table("nominal", required=False)
    return {} if table is None else check_nominal(table, f"{reader.path}: [nominal]")


def read_measurement_table(path: str | os.PathLike[str], sensor_range: float | None = None) -> MeasurementTable:
    """Read and check the columns of a measurement CSV.

    Parameters
    ----------
    path : str or path-like
        The ``NAME.csv`` file.
    sensor_range : float, optional
        The sensor's full scale (``[sensor] range``), to refuse a record more than half clipped.

    Returns
    -------
    MeasurementTable
        The header, the time stamps, the input (if any) and the output, as float arrays.

    Raises
    ------
    BeamInputError
        Missing, empty, binary, non-UTF-8 or too large (over 64 MiB) file; a header that breaks
        the rule (unknown or misspelt column, a column in another unit, two inputs or two
        outputs, no output, wrong order); a row with the wrong number of cells, a cell that is
        not a number or not finite; fewer than two rows; time stamps that do not increase or
        have a gap of more than :data:`MAX_GAP_STEPS` median steps; a sampling interval that is
        not representable; more than half of the output clipped. The message names the file
        and the 1-based line.
    """
    path = Path(path)
    text = read_text_file(path, "measurement CSV", MAX_MEASUREMENT_BYTES)
    return _table_from_lines(path, _lines(text), sensor_range)


def _table_from_lines(path: Path, lines: list[str], sensor_range: float | None) -> MeasurementTable:
    if not lines:
        raise BeamInputError(f"{path}: empty file; expected the header ({HEADER_RULE}, e.g. {','.join(CSV_COLUMNS)}) and data rows")
    columns = _check_header(path, lines[0])
    rows = lines[1:]
    if not rows:
        raise BeamInputError(f"{path}: header only, no data rows")
    try:
        table = np.loadtxt(rows, delimiter=",", comments=None, dtype=float, ndmin=2)
    except ValueError:
        table = None
    if table is None or table.shape != (len(rows), len(columns)):
        table = _parse_rows(path, rows, columns)  # the fast parser failed or skipped a blank line
    bad_rows, bad_columns = np.nonzero(~np.isfinite(table))
    if bad_rows.size:
        row, column = int(bad_rows[0]), int(bad_columns[0])
        raise BeamInputError(
            f"{path}: line {row + 2}: {columns[column]} = {rows[row].split(',')[column].strip()!r} is not finite"
        )
    if len(rows) == 1:
        raise BeamInputError(
            f"{path}: line 2: the only data row; need at least 2 samples to define the sampling interval"
        )
    time_s = np.ascontiguousarray(table[:, 0])
    problem = time_stamp_problem(time_s)
    if problem is not None:
        index, message = problem
        where = "" if index is None else f"line {index + 2}: "
        raise BeamInputError(f"{path}: {where}{message}")
    output = np.ascontiguousarray(table[:, -1])
    problem = clipping_problem(clipped_samples(output, sensor_range), columns[-1], sensor_range)
    if problem is not None:
        raise BeamInputError(f"{path}: {problem}")
    has_input = len(columns) == 3
    return MeasurementTable(
        columns=columns, time_s=time_s, input_column=columns[1] if has_input else None,
        input=np.ascontiguousarray(table[:, 1]) if has_input else None, output_column=columns[-1], output=output,
        uniform=uniform_time_problem(time_s) is None,
    )


_QUANTITIES = {"time": "time_s", "voltage": "voltage_V", "force": "force_N", "displacement": "displacement_m",
               "velocity": "velocity_m_s", "acceleration": "acceleration_m_s2", "strain": "strain"}


def _check_header(path: Path, header: str) -> tuple[str, ...]:
    """The header's column names, or one error saying what breaks :data:`HEADER_RULE`."""
    names = [name.strip() for name in header.split(",")]
    detail = _header_problem(header, names)
    if detail is None:
        return tuple(names)
    shown = header.strip()
    if len(shown) > 80:
        shown = shown[:77] + "..."
    if "\ufffd" in shown or any(ord(c) < 32 and c != "\t" for c in shown):  # never echo binary bytes
        raise BeamInputError(f"{path}: line 1: header must be exactly {HEADER_RULE}, got binary content")
    raise BeamInputError(f"{path}: line 1: header must be exactly {HEADER_RULE}, got {shown!r} ({detail})")


def _header_problem(header: str, names: list[str]) -> str | None:
    if len(names) == 1 and any(separator in header for separator in (";", "\t")):
        return "columns must be separated by commas"
    if len(names) > 1 and not names[-1] and all(names[:-1]):
        return "remove the trailing comma"
    unknown = [n for n in names if n not in ALL_COLUMNS]
    if unknown and all(_looks_numeric(n) for n in names):
        return "the first line holds numbers, the header is missing"
    for name in unknown:
        quantity = name.split("_", 1)[0].lower()
        if quantity in _QUANTITIES and name != _QUANTITIES[quantity]:
            right = _QUANTITIES[quantity]
            unit = "m/m (dimensionless)" if COLUMN_UNITS[right] == "1" else COLUMN_UNITS[right]
            return f"unexpected column {name!r}: {quantity} is read in {unit} as {right}"
    if unknown:
        listed = ", ".join(repr(e) for e in unknown)
        return f"unexpected column {listed}{did_you_mean(unknown[0], ALL_COLUMNS)}"
    repeated = sorted({n for n in names if names.count(n) > 1}, key=names.index)
    if repeated:
        return f"column {repeated[0]} is repeated"
    if "time_s" not in names:
        return "missing column time_s"
    if names[0] != "time_s":
        return "time_s must be the first column (columns are in the wrong order)"
    inputs = [n for n in names if n in INPUT_COLUMNS]
    outputs = [n for n in names if n in OUTPUT_COLUMNS]
    if len(inputs) > 1:
        return f"two input columns {' and '.join(inputs)}; a record has at most one input"
    if len(outputs) > 1:
        return f"two output columns {' and '.join(outputs)}; a record has one output"
    if not outputs:
        return f"missing column: an output, one of {', '.join(OUTPUT_COLUMNS)}"
    if names[-1] != outputs[0]:
        return f"the input column {inputs[0]} must come before the output column {outputs[0]} (wrong order)"
    return None


def _looks_numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _parse_rows(path: Path, rows: list[str], columns: tuple[str, ...]) -> np.ndarray:
    """Parse row by row with ``float`` and raise for the first bad row (the slow path).

    Used when :func:`numpy.loadtxt` refuses the rows: either a row is bad, or a cell holds a
    number that ``float`` reads and loadtxt does not (``1_000``, non-ASCII digits).
    """
    width = len(columns)
    table = np.empty((len(rows), width))
    for offset, row in enumerate(rows):
        line = offset + 2
        if not row.strip():
            raise BeamInputError(f"{path}: line {line}: empty row (blank lines are only allowed at the end)")
        cells = row.split(",")
        if len(cells) != width:
            hint = "; remove the trailing comma" if len(cells) == width + 1 and not cells[-1].strip() else ""
            expected = f"expected {width} ({','.join(columns)})"
            raise BeamInputError(f"{path}: line {line}: {len(cells)} cell(s), {expected}{hint}")
        for index, (column, cell) in enumerate(zip(columns, cells)):
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
# a record in another format
# ---------------------------------------------------------------------------------------------
# The samples come from :func:`beam.io.readers.read_record` (any supported format, SI units,
# clean stamps, one pluck); the beam from a sidecar: the ``beam=`` argument of
# :func:`read_measurement` (a TOML path, or the document as a mapping, e.g. built from
# command-line flags by :func:`beam.cli.record_arguments.beam_document`), else ``STEM.toml``
# next to the file (``Raw Data.csv`` -> ``Raw Data.toml``, ``run.npy`` -> ``run.toml``).

#: The project's input column -> the input kind the sidecar is checked for.
_INPUT_KIND = {column: kind for kind, column in INPUT_COLUMNS.items()}


def sidecar_path_for(path: str | os.PathLike[str]) -> Path:
    """``STEM.toml`` next to a record file."""
    path = Path(path)
    return path.with_name(path.stem + ".toml") if path.suffix else path.with_name(path.name + ".toml")


def measurement_from_record(record: Any, beam: Any = None) -> Measurement:
    """A :class:`Measurement` from a record read by :func:`beam.io.readers.read_record` and the
    description of its beam (module notes).

    Raises
    ------
    BeamInputError
        No description of the beam, or a bad one; one line.
    """
    path = Path(record.path)
    input_kind = _INPUT_KIND.get(record.input_column) if record.input_column else None
    if beam is None:
        candidate = sidecar_path_for(path)
        if not candidate.exists():
            raise BeamInputError(
                f"{path}: read as {record.format}, but the beam is not described: give --length, --width, --thickness "
                f"and --material (or --density and --youngs-modulus) and --sensor-at, or a sidecar {candidate.name} "
                "next to it, or --beam BEAM.toml")
        beam = candidate
    if isinstance(beam, Mapping):
        where = getattr(beam, "where", "beam description")
        sidecar = sidecar_from_document(beam, where, input_kind=input_kind, record=record)
        toml_path = None
    else:
        sidecar = load_sidecar(beam, input_kind=input_kind, record=record)
        toml_path = Path(beam)
    name = path.stem if path.suffix else path.name
    output_kind = record.output_column.split("_", 1)[0]
    nominal, origin = anchored(sidecar, record.time_s, record.output, output_kind, input_kind, record.input)
    return Measurement(
        name=name, title=sidecar.title if sidecar.title is not None else name, geometry=sidecar.geometry,
        time_s=record.time_s, nominal=nominal, csv_path=None, toml_path=toml_path,
        sensor_range=sidecar.sensor_range, nominal_spread=sidecar.nominal_spread, nominal_origin=origin,
        source=tuple(describe_record(record)),
        arbitrary_units=bool(getattr(record, "arbitrary_units", False)) or sidecar.arbitrary_units,
        **{column: values for column, values in record.arrays().items() if column != "time_s"},
    )


def describe_record(record: Any, phrasing: Any = None) -> list[str]:
    """What was read, one line each, in ``phrasing``'s words (default the command line's,
    :data:`beam.io.readers.findings.COMMAND_LINE`): the format, then every decision of the
    reader with why and the option that changes it (:attr:`beam.io.readers.Record.findings`),
    what was done to the data, the segments."""
    from beam.io.readers.findings import COMMAND_LINE

    phrasing = phrasing or COMMAND_LINE
    lines = [f"read as {record.format}"]
    lines += [phrasing.finding(finding, change=True) for finding in record.findings]
    if record.input_column:
        lines.append(f"input: {record.input_column}")
    lines += record.cleaning
    if record.segments:
        for k, segment in enumerate(record.segments, start=1):
            mark = " (used)" if record.segment_index == k - 1 else ""
            lines.append(f"segment {k}: {segment.start_s:.3f}-{segment.end_s:.3f} s, peak {segment.peak:.3g}{mark}")
    return lines


# ---------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------


def measurement_csv_text(time_s: np.ndarray, *columns: np.ndarray, names: tuple[str, ...] = CSV_COLUMNS) -> str:
    """The CSV text: header then rows with every float at full precision (shortest exact repr).

    ``measurement_csv_text(time_s, voltage_V, displacement_m)`` writes the classic header; give
    ``names`` (time first) for the other kinds, e.g. ``names=("time_s", "acceleration_m_s2")``.
    """
    if len(names) != len(columns) + 1:
        raise BeamInputError(f"measurement_csv_text: {len(columns) + 1} columns but {len(names)} names")
    lists = [np.asarray(time_s, dtype=float).tolist()] + [np.asarray(c, dtype=float).tolist() for c in columns]
    rows = (",".join(repr(value) for value in row) for row in zip(*lists))
    return ",".join(names) + "\n" + "\n".join(rows) + "\n"


def sidecar_document(
    title: str, geometry: BeamGeometry, nominal: Mapping[str, float], sensor_range: float | None = None,
    arbitrary_units: bool = False,
) -> dict[str, Any]:
    """The sidecar TOML content (title, geometry, sensor range and unit and, if any, nominal values) as a document."""
    document: dict[str, Any] = {
        "title": title,
        "beam": {"length_m": float(geometry.length_m), "linear_density_kg_m": float(geometry.linear_density_kg_m)},
    }
    if geometry.has_patch:
        document["patch"] = {"start_m": float(geometry.patch_start_m), "end_m": float(geometry.patch_end_m)}
    if geometry.force_position_m is not None:
        document["force"] = {"position_m": float(geometry.force_position_m)}
    for key in ("width_m", "thickness_m"):
        if getattr(geometry, key) is not None:
            document["beam"][key] = float(getattr(geometry, key))
    document["sensor"] = {"position_m": float(geometry.sensor_position_m)}
    if sensor_range is not None:
        document["sensor"]["range"] = float(sensor_range)
    if arbitrary_units:
        document["sensor"]["unit"] = "arbitrary"
    if nominal:
        document["nominal"] = {name: float(value) for name, value in nominal.items()}
    return document


def write_measurement(
    prefix: str | os.PathLike[str],
    data: Measurement | tuple[np.ndarray, ...] | Mapping[str, np.ndarray],
    *,
    geometry: BeamGeometry | None = None,
    title: str | None = None,
    nominal: Mapping[str, float] | None = None,
    extra_files: Mapping[str | os.PathLike[str], str] | None = None,
    sensor_range: float | None = None,
) -> Measurement:
    """Write ``PREFIX.csv`` and ``PREFIX.toml`` atomically (parent directories are created).

    Parameters
    ----------
    prefix : str or path-like
        Output path without suffix (a ``.csv`` or ``.toml`` suffix is dropped).
    data : Measurement, tuple or mapping
        A :class:`Measurement`; or the arrays ``(time_s, voltage_V, displacement_m)`` of the
        classic record as a tuple; or a mapping (a pandas DataFrame works) holding ``time_s``,
        at most one input column and one output column (see the module notes; other keys are
        ignored).
    geometry : BeamGeometry, optional
        Required with arrays; overrides the measurement's otherwise.
    title : str, optional
        Title; defaults to the measurement's, else the file stem.
    nominal : mapping, optional
        ``[nominal]`` values; default the measurement's, else none.
    extra_files : mapping, optional
        More files (path to text) written in the same all-or-nothing step, e.g. a truth file.
    sensor_range : float, optional
        ``[sensor] range``; default the measurement's, else none.

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
            sensor_range=sensor_range if sensor_range is not None else data.sensor_range,
            csv_path=csv_path, toml_path=toml_path,
        )
    else:
        if geometry is None:
            raise BeamInputError("write_measurement: geometry is required when writing arrays")
        if isinstance(data, Mapping) or hasattr(data, "columns"):
            present = [c for c in ALL_COLUMNS if c in data]
            if "time_s" not in present:
                raise BeamInputError("write_measurement: data has no column time_s")
            if not any(c in OUTPUT_COLUMNS for c in present):
                raise BeamInputError(f"write_measurement: data has no output column ({', '.join(OUTPUT_COLUMNS)})")
            arrays = {c: np.asarray(data[c], dtype=float) for c in present}
        else:
            if len(data) != len(CSV_COLUMNS):
                raise BeamInputError(
                    "write_measurement: expected arrays (time_s, voltage_V, displacement_m), or a mapping by column name"
                )
            arrays = dict(zip(CSV_COLUMNS, (np.asarray(c, dtype=float) for c in data)))
        measurement = Measurement(
            name=name, title=title if title is not None else name, geometry=geometry,
            nominal=dict(nominal or {}), csv_path=csv_path, toml_path=toml_path, sensor_range=sensor_range,
            **arrays,
        )
    columns = measurement.columns
    csv_text = measurement_csv_text(*(getattr(measurement, c) for c in columns), names=columns)
    if len(csv_text) > MAX_MEASUREMENT_BYTES:  # ASCII: characters are bytes
        raise BeamInputError(
            f"{csv_path}: {measurement.sample_count:,} samples make {len(csv_text) / 2**20:.1f} MiB of CSV, more than "
            f"the {MAX_MEASUREMENT_BYTES // 2**20} MiB read_measurement reads back; write a shorter record or "
            "decimate it (beam.calibration.records.decimate_measurement)"
        )
    contents: dict[str | os.PathLike[str], str] = {
        csv_path: csv_text,
        toml_path: dump_toml(
            sidecar_document(measurement.title, measurement.geometry, measurement.nominal, measurement.sensor_range,
                             measurement.arbitrary_units),
            header_comment="Measurement sidecar: what the lab knows about the beam (geometry, sensor, "
            "nominal values).\nThe samples are in the CSV file of the same name.",
        ),
    }
    contents.update(extra_files or {})
    atomic_write_texts(contents)
    return measurement
