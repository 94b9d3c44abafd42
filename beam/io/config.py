"""Simulation configs: a measurement sidecar plus the true parameters, excitation and sampling.

A config is TOML with

* optional ``title``; ``[beam]``, ``[patch]``, ``[sensor]`` and optional ``[nominal]`` as in a
  measurement sidecar (:mod:`beam.io.measurement`), the beam's description included
  (``[beam] width_m``, ``thickness_m``, ``material`` or ``youngs_modulus_Pa`` and
  ``density_kg_m3``; ``[sensor] mass_kg``, ``mass_approximate``), derived by the same code
  (:func:`beam.io.measurement.read_description`): the linear density rho b h where
  ``linear_density_kg_m`` is not given, the nominal E b h³ / 12 where ``[nominal]`` has no
  bending stiffness. In a simulation the description is also the truth where
  ``[parameters]`` is silent: ``bending_stiffness_Nm2`` defaults to E b h³ / 12 and
  ``[sensor] mass_kg`` is the sensor's point mass (``sensor_mass_kg``, switching on the
  ``sensor_mass`` effect) — a simulated beam carries its sensor. ``[sensor] output``
  (``"displacement"``, the default, ``"velocity"``, ``"acceleration"`` or ``"strain"``, which
  needs ``thickness_m``) is what the simulated sensor measures;
* ``[parameters]``: values keyed by parameter name (:data:`beam.physics.effects.PARAMETER_SPECS`), all
  positive finite. ``bending_stiffness_Nm2`` and ``patch_coupling_NmV`` are required; a
  parameter of an effect switches that effect on, and then all the effect's required
  parameters must be given;
* ``[excitation]``: ``kind`` and the keys of that kind (:mod:`beam.physics.excitation`); for
  ``kind = "file"``, ``file`` is a measurement CSV (relative to the config's folder) whose
  voltage column is replayed;
* ``[sampling]``: ``rate_Hz``, ``duration_s`` (n = round(rate_Hz duration_s) samples at
  t_k = k / rate_Hz), optional ``noise_m`` (standard deviation of Gaussian sensor noise in the
  output's unit: m for a displacement, dimensionless for a strain; default 0) and ``seed`` (integer >= 0, default 0);
* optional ``[model]``: ``intervals`` (B-spline elements, default
  :data:`beam.physics.basis.DEFAULT_INTERVALS`) and ``knots`` (``"patch"``, the default: double knots at
  the patch ends; or ``"uniform"``: Smith's uniform mesh, see :mod:`beam.physics.basis`).

``[excitation]`` and ``[sampling]`` may be left out when only the parameters matter
(``beam modes``); :meth:`SimulationConfig.require_simulation` asks for them. Unknown tables and
keys are errors, so a typo is never silently ignored.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from beam.errors import BeamInputError
from beam.io.measurement import (
    GEOMETRY_TABLES,
    OUTPUT_COLUMNS,
    SIDECAR_TABLES,
    check_nominal,
    described_nominal,
    read_description,
    read_geometry,
    read_measurement_table,
    read_nominal,
    read_title,
    time_grid_problem,
)
from beam.io.text import (
    TomlReader,
    as_finite_float,
    did_you_mean,
    load_toml,
    short_repr,
)
from beam.physics.basis import (
    DEFAULT_INTERVALS,
    DEFAULT_KNOTS,
    INTERVALS_RANGE,
    KNOT_LAYOUTS,
    patch_breaks,
)
from beam.physics.effects import BASE_PARAMETERS, EFFECTS, effects_switched_on
from beam.physics.excitation import ALL_EXCITATION_KEYS, EXCITATION_KEYS, Excitation
from beam.physics.geometry import BeamGeometry

#: Geometry tables of a config and their keys: a sidecar's (no ``[force]``: the patch drives a
#: simulation; no ``[sensor] range``) plus ``[sensor] output``.
CONFIG_GEOMETRY_TABLES: dict[str, tuple[str, ...]] = {
    "beam": SIDECAR_TABLES["beam"],
    "patch": GEOMETRY_TABLES["patch"],
    "sensor": ("position_m", "mass_kg", "mass_approximate", "output"),
}
#: Top-level tables a config may hold.
CONFIG_TABLES: tuple[str, ...] = (*CONFIG_GEOMETRY_TABLES, "nominal", "parameters", "excitation", "sampling", "model")
#: What a simulated sensor may measure (``[sensor] output``).
OUTPUT_KINDS: tuple[str, ...] = tuple(OUTPUT_COLUMNS.values())


#: Largest number of samples a simulation may ask for.
MAX_SAMPLES = 1_000_000


@dataclass(frozen=True)
class Sampling:
    """How a simulated record is sampled.

    Parameters
    ----------
    rate_Hz : float
        Sampling rate (Hz); t_k = k / rate_Hz.
    duration_s : float
        Record length (s); n = round(rate_Hz duration_s) samples.
    noise_m : float
        Standard deviation of the Gaussian sensor noise added to the displacement (m).
    seed : int
        Seed of :func:`numpy.random.default_rng` for the noise.
    """

    rate_Hz: float
    duration_s: float
    noise_m: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        for key in ("rate_Hz", "duration_s"):
            value = getattr(self, key)
            number = as_finite_float(value)
            if number is None or number <= 0:
                raise BeamInputError(f"sampling {key}: must be a positive finite number, got {short_repr(value)}")
        noise = as_finite_float(self.noise_m)
        if noise is None or noise < 0:
            raise BeamInputError(f"sampling noise_m: must be a finite number >= 0, got {short_repr(self.noise_m)}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise BeamInputError(f"sampling seed: must be an integer >= 0, got {short_repr(self.seed)}")
        count = float(self.rate_Hz) * float(self.duration_s)
        if not math.isfinite(count):
            raise BeamInputError(
                f"sampling: rate_Hz x duration_s = {count:g} samples; the limit is {MAX_SAMPLES:,}"
            )
        if round(count) < 2:
            raise BeamInputError(
                f"sampling: rate_Hz x duration_s = {count:g} samples; need at least 2"
            )
        if count > MAX_SAMPLES:
            raise BeamInputError(f"sampling: rate_Hz x duration_s = {count:.3g} samples; the limit is {MAX_SAMPLES:,}")

    @property
    def sample_count(self) -> int:
        """Number of samples n = round(rate_Hz duration_s)."""
        return int(round(self.rate_Hz * self.duration_s))

    @property
    def sample_interval_s(self) -> float:
        """Sampling interval 1 / rate_Hz (s)."""
        return 1.0 / self.rate_Hz

    def time_s(self) -> np.ndarray:
        """Sample times t_k = k / rate_Hz (s), k = 0 .. n - 1."""
        return np.arange(self.sample_count) / self.rate_Hz


@dataclass(frozen=True)
class SimulationConfig:
    """A parsed simulation config (see the module docstring for the file format).

    Parameters
    ----------
    title : str
        Human title (the file stem when the file has none).
    geometry : BeamGeometry
        Beam, patch and sensor.
    parameters : dict
        True parameter values keyed by public name; they decide the effects switched on.
    excitation : Excitation or None
        Voltage signal; None when the file has no ``[excitation]``.
    sampling : Sampling or None
        Sampling and noise; None when the file has no ``[sampling]``.
    intervals : int
        B-spline elements of the Galerkin model.
    knots : {"patch", "uniform"}
        Knot layout of the Galerkin model (:mod:`beam.physics.basis`).
    nominal : dict
        ``[nominal]`` prior centres (with the description's bending stiffness and sensor mass),
        copied to a simulated measurement's sidecar.
    path : Path or None
        The config file.
    output : {"displacement", "velocity", "acceleration", "strain"}
        What the simulated sensor measures (``[sensor] output``).
    nominal_spread : dict
        Log standard deviations of the priors the description sets (as a sidecar's).
    """

    title: str
    geometry: BeamGeometry
    parameters: dict[str, float]
    excitation: Excitation | None = None
    sampling: Sampling | None = None
    intervals: int = DEFAULT_INTERVALS
    knots: str = DEFAULT_KNOTS
    nominal: dict[str, float] = field(default_factory=dict)
    path: Path | None = None
    output: str = "displacement"
    nominal_spread: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "parameters", check_parameters(self.parameters, "parameters"))
        if self.output not in OUTPUT_KINDS:
            raise BeamInputError(f"output must be one of {', '.join(OUTPUT_KINDS)}, got {short_repr(self.output)}")
        if self.output == "strain" and self.geometry.thickness_m is None:
            raise BeamInputError("a strain output needs the strip's thickness: [beam] thickness_m (with width_m)")

    @property
    def effects(self) -> tuple[str, ...]:
        """Effect ids switched on by the parameters present, in catalogue order."""
        return effects_switched_on(self.parameters)

    def require_simulation(self) -> tuple[Excitation, Sampling]:
        """The excitation and sampling, or a BeamInputError naming the missing table."""
        where = f"{self.path}: " if self.path else ""
        if self.excitation is None:
            raise BeamInputError(f"{where}[excitation]: missing table (needed to simulate)")
        if self.sampling is None:
            raise BeamInputError(f"{where}[sampling]: missing table (needed to simulate)")
        return self.excitation, self.sampling


def check_parameters(parameters: Mapping[str, Any], where: str) -> dict[str, float]:
    """Validate true parameter values and the completeness of the effects they switch on.

    Parameters
    ----------
    parameters : mapping
        Parameter name to value.
    where : str
        Prefix for messages, e.g. ``"sim.toml: [parameters]"``.

    Returns
    -------
    dict
        Names to floats, in the given order.

    Raises
    ------
    BeamInputError
        Unknown name, a value that is not a positive finite number, a missing base parameter
        or an effect missing one of its required parameters.
    """
    checked = check_nominal(parameters, where)  # known names, positive finite numbers
    for spec in BASE_PARAMETERS:
        if spec.name not in checked:
            required = ", ".join(p.name for p in BASE_PARAMETERS)
            raise BeamInputError(f"{where} {spec.name}: missing (required: {required})")
    for effect_id in effects_switched_on(checked):
        effect = EFFECTS[effect_id]
        missing = [name for name in effect.required_parameter_names if name not in checked]
        if missing:
            given = [name for name in effect.parameter_names if name in checked]
            raise BeamInputError(
                f"{where} {missing[0]}: missing; {', '.join(given)} switches on effect {effect_id}, "
                f"which also needs {', '.join(missing)}"
            )
    return checked


def load_config(path: str | os.PathLike[str]) -> SimulationConfig:
    """Read and validate a simulation config.

    Parameters
    ----------
    path : str or path-like
        The TOML file.

    Returns
    -------
    SimulationConfig

    Raises
    ------
    BeamInputError
        Missing file, TOML syntax error, unknown table or key, a missing or ill-typed value;
        one line naming the file and the table and key.
    """
    path = Path(path)
    reader = TomlReader(load_toml(path, "config"), path)
    reader.check_top_level(tables=CONFIG_TABLES, keys=("title",))
    title = read_title(reader)
    description = read_description(reader, CONFIG_GEOMETRY_TABLES)
    geometry = read_geometry(reader, tables=CONFIG_GEOMETRY_TABLES, description=description)
    nominal, spread, _ = described_nominal(read_nominal(reader), description)
    output = reader.string("sensor", reader.table("sensor"), "output", required=False) or "displacement"
    if output not in OUTPUT_KINDS:
        raise reader.fail("[sensor] output", f"unknown output {output!r}; expected one of {', '.join(OUTPUT_KINDS)}")
    if output == "strain" and geometry.thickness_m is None:
        raise reader.fail("[beam] thickness_m", "missing key; a strain output needs the strip's thickness (with width_m)")
    parameters_table = dict(reader.table("parameters"))
    # the description is the simulated beam's truth where [parameters] is silent (module notes)
    for name, key in (("bending_stiffness_Nm2", "bending_stiffness_Nm2"), ("sensor_mass_kg", "sensor_mass_kg")):
        if name not in parameters_table and key in description:
            parameters_table[name] = description[key]
    parameters = check_parameters(parameters_table, f"{path}: [parameters]")
    excitation = _read_excitation(reader)
    sampling = _read_sampling(reader)
    model_table = reader.table("model", required=False) or {}
    reader.check_keys("model", model_table, ("intervals", "knots"))
    intervals = reader.integer(
        "model", model_table, "intervals", required=False, default=DEFAULT_INTERVALS,
        minimum=INTERVALS_RANGE[0], maximum=INTERVALS_RANGE[1],
    )
    knots = read_knots(reader, model_table, "model")
    if knots == "patch":
        segments = patch_breaks(geometry, intervals).size - 1
        if intervals < segments:
            raise reader.fail("[model] intervals", f"must be >= {segments} with knots = \"patch\" (one element per segment "
                                                   "between the root, the patch ends and the tip)")
    return SimulationConfig(
        title=title if title is not None else path.stem, geometry=geometry, parameters=parameters,
        excitation=excitation, sampling=sampling, intervals=intervals, knots=knots, nominal=nominal, path=path,
        output=output, nominal_spread=spread,
    )


def read_knots(reader: TomlReader, table: Mapping[str, Any], name: str | None, default: str = DEFAULT_KNOTS) -> str:
    """``knots`` of a table (``default`` when absent), one of :data:`KNOT_LAYOUTS`."""
    if "knots" not in table:
        return default
    knots = reader.string(name, table, "knots")
    if knots not in KNOT_LAYOUTS:
        where = f"[{name}] knots" if name else "knots"
        raise reader.fail(where, f"unknown knot layout {knots!r}; expected one of {', '.join(KNOT_LAYOUTS)}")
    return knots


def _read_excitation(reader: TomlReader) -> Excitation | None:
    table = reader.table("excitation", required=False)
    if table is None:
        return None
    kind = reader.string("excitation", table, "kind")
    if kind not in EXCITATION_KEYS:
        raise reader.fail("[excitation] kind", f"unknown kind {kind!r}; expected one of {', '.join(EXCITATION_KEYS)}")
    needed = EXCITATION_KEYS[kind]
    for key in table:
        if key == "kind":
            continue
        if key not in ALL_EXCITATION_KEYS:
            raise reader.fail(
                f"[excitation] {key}",
                f"unknown key{did_you_mean(key, needed)}; a {kind!r} excitation takes {', '.join(needed)}",
            )
        if key not in needed:
            raise reader.fail(
                f"[excitation] {key}", f"not used by a {kind!r} excitation (it takes {', '.join(needed)})"
            )
    if kind == "file":
        file_name = reader.string("excitation", table, "file")
        recording = (reader.path.parent / file_name) if not Path(file_name).is_absolute() else Path(file_name)
        try:
            table = read_measurement_table(recording)
        except BeamInputError as exc:  # name the config too: the recording is its reference
            raise reader.fail("[excitation] file", str(exc)) from None
        if table.input_column != "voltage_V":
            raise reader.fail("[excitation] file", f"{recording}: has no voltage_V column to replay")
        problem = time_grid_problem(table.time_s)
        if problem is not None:
            where = "" if problem[0] is None else f"line {problem[0] + 2}: "
            raise reader.fail("[excitation] file", f"{recording}: {where}{problem[1]} (a replayed voltage needs them)")
        time_s = table.time_s
        step = float((time_s[-1] - time_s[0]) / (time_s.size - 1))
        return Excitation.from_recording(table.input, step, file=str(recording))
    values = {key: reader.number("excitation", table, key) for key in needed}
    try:
        return Excitation(kind, **values)
    except BeamInputError as exc:  # pragma: no cover - the checks above cover Excitation's
        raise reader.fail("[excitation]", str(exc)) from None


def _read_sampling(reader: TomlReader) -> Sampling | None:
    table = reader.table("sampling", required=False)
    if table is None:
        return None
    reader.check_keys("sampling", table, ("rate_Hz", "duration_s", "noise_m", "seed"))
    rate = reader.number("sampling", table, "rate_Hz")
    duration = reader.number("sampling", table, "duration_s")
    noise = reader.number("sampling", table, "noise_m", required=False, default=0.0, allow_zero=True)
    seed = reader.integer("sampling", table, "seed", required=False, default=0, minimum=0)
    try:
        return Sampling(rate_Hz=rate, duration_s=duration, noise_m=noise, seed=seed)
    except BeamInputError as exc:
        raise reader.fail("[sampling]", str(exc).removeprefix("sampling: ")) from None
