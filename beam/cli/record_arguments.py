"""Flags that read any record file and describe its beam, shared by ``beam import``, ``beam
calibrate`` and ``beam diagnose``.

Reading (:func:`beam.io.readers.read_record`): ``--format``, ``--record NAME|INDEX`` (a file
holding several records), ``--column NAME|INDEX``, ``--axis x|y|z``, ``--rate HZ``,
``--time-unit s|ms|us``, ``--unit UNIT`` (``arbitrary`` for a signal of unknown scale),
``--segment K``.
The beam (a sidecar's keys, :mod:`beam.io.measurement`): ``--beam BEAM.toml`` and/or
``--length``, ``--width``, ``--thickness`` (m), ``--material NAME`` or ``--youngs-modulus``
(Pa) and ``--density`` (kg/m³), ``--linear-density`` (kg/m), ``--sensor-at`` (m from the
clamp), ``--sensor-mass KG`` (``~KG`` for an approximate mass), ``--sensor-range``. Flags
override the same keys of ``--beam``, or without it of the record's own sidecar (``NAME.toml``
next to it: ``--width 0.05`` adds the width a sidecar lacks); the record is then read by
:mod:`beam.io.readers` with that description.

``beam calibrate`` and ``beam diagnose`` take one record or several (a joint run):
:func:`several_records` makes the checks they start with and tells the two apart.
"""

from __future__ import annotations

import argparse
from typing import Any

from beam.cli.arguments import finite_float, positive_int

#: Geometry flags: (flag, dest, table, key, metavar, help).
BEAM_FLAGS: tuple[tuple[str, str, str, str, str, str], ...] = (
    ("--length", "beam_length", "beam", "length_m", "M", "free length of the beam, clamp to tip (m)"),
    ("--width", "beam_width", "beam", "width_m", "M", "width of the strip (m)"),
    ("--thickness", "beam_thickness", "beam", "thickness_m", "M", "thickness of the strip (m)"),
    ("--youngs-modulus", "beam_youngs_modulus", "beam", "youngs_modulus_Pa", "PA",
     "Young's modulus (Pa), instead of --material"),
    ("--density", "beam_density", "beam", "density_kg_m3", "KG_M3", "density (kg/m³), instead of --material"),
    ("--linear-density", "beam_linear_density", "beam", "linear_density_kg_m", "KG_M", "mass per length (kg/m), if known"),
    ("--sensor-at", "sensor_at", "sensor", "position_m", "M",
     "sensor position, from the clamp (m; default for beam import: the tip)"),
    ("--sensor-range", "sensor_range", "sensor", "range", "SI",
     "sensor's full scale in SI units (e.g. 156.9 for ±16 g), for clipping"),
)

#: Reading options: dest -> keyword of read_record.
RECORD_OPTIONS = {"record_format": "format", "record": "record", "column": "column", "axis": "axis", "rate": "rate",
                  "time_unit": "time_unit", "unit": "unit", "segment": "segment"}


def sensor_mass(text: str) -> tuple[float, bool]:
    """``KG`` (weighed) or ``~KG`` (approximate): (mass in kg > 0, approximate)."""
    approximate = text.strip().startswith("~")
    value = finite_float(text.strip().lstrip("~"))
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a mass > 0 in kg (~KG if approximate), got {text!r}")
    return value, approximate


def positive_float(text: str) -> float:
    """A finite number > 0."""
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return value


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the reading and beam flags (module notes) to ``parser``."""
    from beam.io.materials import MATERIALS
    from beam.io.readers import FORMATS
    from beam.io.readers.signal import UNIT_HINT_VALUES

    reading = parser.add_argument_group("reading a record in another format (phyphox, LabVIEW, MATLAB, NumPy, TDMS, any CSV)")
    reading.add_argument("--format", dest="record_format", choices=tuple(FORMATS), default=None,
                         help="force the reader (default: recognised from the file)")
    reading.add_argument("--record", default=None, metavar="NAME|INDEX",
                         help="for a file holding several records (MATLAB structs, HDF5 groups): which, by name or "
                         "position (default: the longest; the summary lists them all)")
    which = reading.add_mutually_exclusive_group()
    which.add_argument("--column", default=None, metavar="NAME|INDEX",
                       help="the signal's column, by name or position (1 = the first column)")
    which.add_argument("--axis", choices=("x", "y", "z"), default=None, help="the signal's axis")
    when = reading.add_mutually_exclusive_group()
    when.add_argument("--rate", type=positive_float, default=None, metavar="HZ",
                      help="sampling rate, for a file without time stamps (Hz)")
    when.add_argument("--time-unit", choices=("s", "ms", "us"), default=None,
                      help="unit of the time column (an Arduino's micros() is us)")
    reading.add_argument("--unit", default=None, metavar="UNIT",
                         help=f"unit of the signal column when its name has none ({', '.join(UNIT_HINT_VALUES[:-1])}); "
                         "arbitrary for a signal of unknown scale (ADC counts, an uncalibrated sensor's volts: "
                         "arbitrary-acceleration, -velocity, -displacement or -strain when the column's name does not say "
                         "what it measures); the effects that depend on the amplitude then refuse it")
    reading.add_argument("--segment", type=positive_int, default=None, metavar="K",
                         help="use pluck/tap (or file segment) K (default: the strongest)")
    beam = parser.add_argument_group("the beam, in a student's words (or --beam BEAM.toml)")
    beam.add_argument("--beam", dest="beam_file", default=None, metavar="BEAM.toml",
                      help="a sidecar describing the beam (the flags below override its keys)")
    for flag, dest, _table, _key, metavar, text in BEAM_FLAGS:
        beam.add_argument(flag, dest=dest, type=positive_float, default=None, metavar=metavar, help=text)
    beam.add_argument("--material", default=None, metavar="NAME",
                      help="material preset: " + ", ".join(MATERIALS) + " (gives E, density and their spread)")
    beam.add_argument("--sensor-mass", dest="sensor_mass_given", type=sensor_mass, default=None, metavar="KG",
                      help="sensor's mass in kg (a known point mass; ~KG when approximate, e.g. ~0.2 for a phone)")


def beam_flags_given(args: argparse.Namespace) -> bool:
    """Whether any beam flag (not --beam) was given."""
    return any(getattr(args, dest, None) is not None for _f, dest, *_ in BEAM_FLAGS) or any(
        getattr(args, name, None) is not None for name in ("material", "sensor_mass_given"))


def beam_document(args: argparse.Namespace, default_sensor_at_tip: bool = False) -> dict[str, Any] | None:
    """The sidecar document from ``--beam`` (without it, the record's own sidecar when a flag is
    given) and the flags (flags win), None when no flag and no ``--beam`` is given."""
    from beam.io.text import load_toml

    document: dict[str, Any] = {}
    if getattr(args, "beam_file", None):
        document = load_toml(args.beam_file, "beam description")
    if not document and not beam_flags_given(args):
        return None
    own = None if document else _own_sidecar(getattr(args, "data", None))
    if own is not None:
        document = load_toml(own, "beam description")
    document = {key: (dict(value) if isinstance(value, dict) else value) for key, value in document.items()}
    for _flag, dest, table, key, _metavar, _text in BEAM_FLAGS:
        value = getattr(args, dest, None)
        if value is not None:
            document.setdefault(table, {})[key] = value
    if getattr(args, "material", None) is not None:
        document.setdefault("beam", {})["material"] = args.material
    if getattr(args, "sensor_mass_given", None) is not None:
        mass, approximate = args.sensor_mass_given
        document.setdefault("sensor", {})["mass_kg"] = mass
        if approximate:
            document["sensor"]["mass_approximate"] = True
    length = document.get("beam", {}).get("length_m")
    if default_sensor_at_tip and "position_m" not in document.get("sensor", {}) and isinstance(length, (int, float)):
        document.setdefault("sensor", {})["position_m"] = float(length)
    return document


def _own_sidecar(data: Any):
    """The sidecar ``NAME.toml`` next to the record ``data`` names (a path or a bundled run), if any."""
    from pathlib import Path

    from beam.io.bundled import resolve_data_path

    if not isinstance(data, (str, Path)):
        return None
    path = Path(resolve_data_path(str(data)))
    sidecar = path.with_suffix(".toml")
    return sidecar if path.suffix.lower() != ".toml" and sidecar.is_file() else None


def record_options(args: argparse.Namespace) -> dict[str, Any]:
    """The reading flags as keywords of :func:`beam.io.readers.read_record` (only those given)."""
    return {keyword: getattr(args, dest) for dest, keyword in RECORD_OPTIONS.items() if getattr(args, dest, None) is not None}


def measurement_from_args(args: argparse.Namespace, default_sensor_at_tip: bool = False, effects=None):
    """The measurement ``args.data`` names, read with the reading flags and the beam flags;
    with ``effects`` (ids or a comma-separated string), refused when one of them needs the
    signal's true unit and the record is in arbitrary units
    (:func:`beam.io.measurement.true_unit_problem`)."""
    from beam.errors import BeamInputError
    from beam.io.measurement import read_measurement, true_unit_problem

    document = beam_document(args, default_sensor_at_tip)
    where = getattr(args, "beam_file", None) or "the beam flags"
    beam = None
    if document is not None:
        beam = _Described(document, where)
    measurement = read_measurement(args.data, beam=beam, **record_options(args))
    problem = true_unit_problem(measurement, effects) if effects is not None else None
    if problem is not None:
        raise BeamInputError(problem)
    return measurement


def check_joint_arguments(args: argparse.Namespace) -> None:
    """--shared / --per-record need several records; --save and --report one (BeamInputError)."""
    from beam.errors import BeamInputError

    several = len(args.data) > 1
    for flag, value in (("--shared", args.shared), ("--per-record", args.per_record)):
        if value is not None and not several:
            raise BeamInputError(f"{flag} needs several records (DATA DATA ...)")
    for flag in ("save", "report"):
        if several and getattr(args, flag, None) is not None:
            raise BeamInputError(f"--{flag} takes one record; a joint calibration writes its summary only (--json)")


def several_records(args: argparse.Namespace) -> bool:
    """The checks a command of one or several records (``beam calibrate``, ``beam diagnose``)
    starts with: ``--report`` names an .html file, and :func:`check_joint_arguments`.

    Returns True for several records (``args.data`` stays the list of paths); for one record,
    ``args.data`` becomes its path and False.
    """
    if getattr(args, "report", None) is not None and not str(args.report).lower().endswith((".html", ".htm")):
        from beam.errors import BeamInputError

        raise BeamInputError(f"--report must name an .html file, got {args.report!r}")
    check_joint_arguments(args)
    if len(args.data) > 1:
        return True
    args.data = args.data[0]
    return False


def measurements_from_args(args: argparse.Namespace, effects=None) -> list:
    """Every record ``args.data`` names (a list of paths), each read as :func:`measurement_from_args`
    reads one (the same reading and beam flags; a record's own sidecar otherwise)."""
    paths = list(args.data)
    out = []
    try:
        for path in paths:
            args.data = path
            out.append(measurement_from_args(args, effects=effects))
    finally:
        args.data = paths
    return out


class _Described(dict):
    """A sidecar document with the name to use in messages (``BEAM.toml`` or ``the beam flags``)."""

    def __init__(self, document: dict[str, Any], where: str):
        super().__init__(document)
        self.where = where
