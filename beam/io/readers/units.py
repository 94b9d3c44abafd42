"""Column names and units of the files labs and phones write, and their conversion to SI.

A column's *quantity* (time, acceleration, velocity, displacement, voltage, force, strain) and
its *unit* are read from its name: a unit in brackets (``"Time (s)"``, ``"acc_z [g]"``,
``"Acceleration x (m/s^2)"``), a unit as the last word or underscore part (``"accel_z_g"``,
``"disp mm"``), or a name an app is known to write without a unit (Physics Toolbox Sensor
Suite: ``gFx`` in g, ``ax`` in m/s²; Arduino loggers: ``micros``, ``millis``). The unit alone
decides the quantity when the name does not (``"ch1 (V)"`` is a voltage). ``--unit`` gives the
unit of a column whose name has none.

Every factor is exact by definition (standard gravity g_n = 9.80665 m/s², CGPM 1901; SI
prefixes).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: Standard acceleration of gravity (m/s²), exact by definition (3rd CGPM, 1901).
STANDARD_GRAVITY = 9.80665

#: Unit spelling (lower case, spaces removed) -> (quantity, factor to SI).
UNITS: dict[str, tuple[str, float]] = {}


def _add(quantity: str, factor: float, *spellings: str) -> None:
    for spelling in spellings:
        UNITS[spelling] = (quantity, factor)


_add("time", 1.0, "s", "sec", "secs", "second", "seconds")
_add("time", 1e-3, "ms", "msec", "millis", "millisecond", "milliseconds")
_add("time", 1e-6, "us", "µs", "μs", "usec", "micros", "microsecond", "microseconds")
_add("time", 1e-9, "ns", "nanos")
_add("acceleration", 1.0, "m/s^2", "m/s²", "m/s2", "ms^-2", "ms-2", "m*s^-2", "m_s2", "m_s^2", "mps2", "m/s/s")
_add("acceleration", 1e-2, "cm/s^2", "cm/s²", "cm/s2", "gal")
_add("acceleration", 1e-3, "mm/s^2", "mm/s²", "mm/s2")
_add("acceleration", STANDARD_GRAVITY, "g", "gee", "g-force", "gforce", "gn")
_add("acceleration", STANDARD_GRAVITY * 1e-3, "mg", "milli-g", "millig")
_add("velocity", 1.0, "m/s", "m_s", "mps")
_add("velocity", 1e-2, "cm/s", "cm_s")
_add("velocity", 1e-3, "mm/s", "mm_s")
_add("velocity", 1e-6, "µm/s", "μm/s", "um/s", "um_s")
_add("displacement", 1.0, "m", "meter", "metre", "meters", "metres")
_add("displacement", 1e-2, "cm")
_add("displacement", 1e-3, "mm")
_add("displacement", 1e-6, "µm", "μm", "um", "micron", "microns", "micrometre", "micrometer")
_add("displacement", 1e-9, "nm")
_add("voltage", 1.0, "v", "volt", "volts")
_add("voltage", 1e-3, "mv", "millivolt", "millivolts")
_add("force", 1.0, "n", "newton", "newtons")
_add("force", 1e-3, "mn")
_add("force", 1e3, "kn")
_add("strain", 1.0, "strain", "m/m", "ε")
_add("strain", 1e-6, "microstrain", "µε", "με", "ue", "µstrain", "ustrain", "microstrains")

#: Quantities a record's output (what the sensor measures) may be, with the project's CSV column.
OUTPUT_COLUMN_OF = {"displacement": "displacement_m", "velocity": "velocity_m_s", "acceleration": "acceleration_m_s2",
                    "strain": "strain"}
#: Quantities an input (what drives the beam) may be, with the project's CSV column.
INPUT_COLUMN_OF = {"voltage": "voltage_V", "force": "force_N"}

#: Names apps write without a unit: lower-case name -> (quantity, factor to SI, axis or None).
KNOWN_NAMES: dict[str, tuple[str, float, str | None]] = {
    # Physics Toolbox Sensor Suite: g-force meter and linear accelerometer
    "gfx": ("acceleration", STANDARD_GRAVITY, "x"),
    "gfy": ("acceleration", STANDARD_GRAVITY, "y"),
    "gfz": ("acceleration", STANDARD_GRAVITY, "z"),
    "tgf": ("acceleration", STANDARD_GRAVITY, "total"),
    "gftotal": ("acceleration", STANDARD_GRAVITY, "total"),
    "ax": ("acceleration", 1.0, "x"),
    "ay": ("acceleration", 1.0, "y"),
    "az": ("acceleration", 1.0, "z"),
    "at": ("acceleration", 1.0, "total"),
    # Arduino loggers
    "micros": ("time", 1e-6, None),
    "millis": ("time", 1e-3, None),
}

#: Words that name the time column (compared with the name's words).
TIME_WORDS = ("time", "t", "timestamp", "times", "seconds", "sec", "elapsed")
#: Words that name a quantity.
QUANTITY_WORDS = {
    "acceleration": ("acceleration", "accel", "acc", "accelerometer"),
    "velocity": ("velocity", "vel", "speed"),
    "displacement": ("displacement", "disp", "position", "deflection"),
    "voltage": ("voltage", "volt"),
    "force": ("force", "load"),
    "strain": ("strain", "eps"),
}
#: Words that mark a magnitude (|a|, never a signed vibration: chosen only when asked for).
TOTAL_WORDS = ("absolute", "total", "magnitude", "norm", "abs", "resultant")

_BRACKET = re.compile(r"[\(\[\{]([^\)\]\}]*)[\)\]\}]\s*$")


@dataclass(frozen=True)
class ColumnMeaning:
    """What a column's name says.

    Attributes
    ----------
    name : str
        The name as written.
    quantity : str or None
        ``"time"``, ``"acceleration"``, ``"velocity"``, ``"displacement"``, ``"voltage"``,
        ``"force"``, ``"strain"`` or None (not said).
    factor : float or None
        Multiply by this to get SI (s, m/s², m/s, m, V, N, dimensionless); None when the unit is
        not said.
    unit : str or None
        The unit as written (None when not said).
    axis : str or None
        ``"x"``, ``"y"``, ``"z"``, ``"total"`` (a magnitude) or None.
    """

    name: str
    quantity: str | None
    factor: float | None
    unit: str | None
    axis: str | None

    @property
    def is_total(self) -> bool:
        """A magnitude (|a| of three axes): never a signed vibration."""
        return self.axis == "total"


def normalise_unit(text: str) -> str:
    """A unit spelling as :data:`UNITS` keys it (lower case, no spaces, ``**`` as ``^``)."""
    return text.strip().replace(" ", "").replace("**", "^").replace("⁻²", "^-2").lower()


def unit_meaning(text: str) -> tuple[str, float] | None:
    """(quantity, factor to SI) of a unit spelling, None when it is not a known unit."""
    key = normalise_unit(text)
    if key in UNITS:
        return UNITS[key]
    if key.endswith("²") and key[:-1] + "^2" in UNITS:  # pragma: no cover - covered by the table
        return UNITS[key[:-1] + "^2"]
    return None


def _words(text: str) -> list[str]:
    return [w for w in re.split(r"[\s_\-\.:]+", text.strip().lower()) if w]


def _axis(words: list[str], bare: str) -> str | None:
    if any(w in TOTAL_WORDS for w in words):
        return "total"
    if words and words[-1] in ("x", "y", "z"):
        return words[-1]
    match = re.fullmatch(r"(?:acc|accel|acceleration|a|gf|g|vel|v|disp|d)([xyz])", bare)
    return match.group(1) if match else None


def column_meaning(name: str, unit: str | None = None) -> ColumnMeaning:
    """Read a column's quantity, unit and axis from its name (module notes).

    Parameters
    ----------
    name : str
        The column's name as written in the file (quotes already removed).
    unit : str, optional
        A unit given separately (a file's unit field, or ``--unit``); it wins over the name's.

    Returns
    -------
    ColumnMeaning
    """
    text = str(name).strip()
    bare = text
    found_unit: str | None = None
    match = _BRACKET.search(text)
    if match:
        found_unit = match.group(1).strip()
        bare = text[: match.start()].strip()
    words = _words(bare)
    lower = bare.lower().replace(" ", "")
    known = KNOWN_NAMES.get(lower)
    quantity: str | None = None
    factor: float | None = None
    axis = _axis(words, lower)
    if known is not None:
        quantity, factor, known_axis = known
        axis = known_axis or axis
        found_unit = found_unit or lower
    if found_unit is None and len(words) > 2 and unit_meaning("/".join(words[-2:])) is not None:
        found_unit = "/".join(words[-2:])  # "velocity_m_s" -> "m/s", "acceleration_m_s2" -> "m/s2"
        words = words[:-2]
        axis = _axis(words, "".join(words))
    if found_unit is None and len(words) > 1 and unit_meaning(words[-1]) is not None:
        found_unit = words[-1]  # "accel_z_g", "disp mm", "time_s"
        words = words[:-1]
        axis = _axis(words, "".join(words))
    if unit is not None:
        found_unit = unit
    if found_unit is not None:
        meaning = unit_meaning(found_unit)
        if meaning is not None:
            quantity, factor = meaning
    named = next((q for q, names in QUANTITY_WORDS.items() if any(w in names for w in words)), None)
    if any(w in TIME_WORDS for w in words) and (quantity in (None, "time")):
        quantity = "time"
    elif quantity is None:
        quantity = named
    elif quantity == "displacement" and named in ("acceleration", "velocity"):
        quantity = named  # "m" after "acceleration": a unit cut short; leave the factor unknown
        factor = None
    return ColumnMeaning(text, quantity, factor, found_unit, axis)
