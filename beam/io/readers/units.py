"""Column names and units of the files labs and phones write, and their conversion to SI.

A column's *quantity* (time, acceleration, velocity, displacement, voltage, force, strain) and
its *unit* are read from its name: a unit in brackets (``"Time (s)"``, ``"acc_z [g]"``,
``"Acceleration x (m/s^2)"``), a unit as the last word or underscore part (``"accel_z_g"``,
``"disp mm"``), or a name an app is known to write without a unit (Physics Toolbox Sensor
Suite: ``gFx`` in g, ``ax`` in m/s²; Arduino loggers: ``micros``, ``millis``). The unit alone
decides the quantity when the name does not (``"ch1 (V)"`` is a voltage). ``--unit`` gives the
unit of a column whose name has none. A bracket holding a bare number (``"Acc[1]"``, the first
column of a matrix ``Acc``) is an index, never a unit.

*Arbitrary units* (:data:`ARBITRARY_SPELLINGS`: ``arbitrary``, ``counts``, ``a.u.``, ...) are a
signal of unknown scale: ADC counts (an Arduino's ``analogRead``, a "Quantisation level"), the
volts of a sensor without its calibration. The values are kept as the file holds them (factor
1) and the record says that its scale is unknown; the quantity comes from the name, or from the
spelling ``arbitrary-acceleration`` (``-velocity``, ``-displacement``, ``-strain``).

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

#: Spellings of a unit of unknown scale (lower case, spaces removed): the values as the file holds them.
ARBITRARY_SPELLINGS = ("arbitrary", "arb", "a.u.", "au", "arbitraryunits", "counts", "count", "lsb", "adc", "adccounts",
                       "raw")
#: The canonical spelling of arbitrary units, and of arbitrary units of a named quantity.
ARBITRARY = "arbitrary"


def arbitrary_spelling(quantity: str) -> str:
    """``"arbitrary-acceleration"``: arbitrary units of ``quantity``."""
    return f"{ARBITRARY}-{quantity}"


#: Units a signal column may be given in (``--unit``, the page's list), in the order a message lists them.
SIGNAL_UNITS: tuple[str, ...] = ("g", "mg", "m/s^2", "mm/s", "m/s", "µm", "mm", "m", "microstrain", "strain",
                                 ARBITRARY, *(arbitrary_spelling(q) for q in
                                              ("acceleration", "velocity", "displacement", "strain")))
#: How a unit spelling is shown to a reader (superscripts, µ), where it differs.
UNIT_DISPLAY = {"m/s^2": "m/s²", "us": "µs", "microstrain": "µε (microstrain)", "strain": "strain (m/m)",
                ARBITRARY: "arbitrary units",
                **{arbitrary_spelling(q): f"arbitrary units of {q}" for q in ("acceleration", "velocity", "displacement",
                                                                               "strain")}}

#: Quantities a record's output (what the sensor measures) may be, with the project's CSV column.
OUTPUT_COLUMN_OF = {"displacement": "displacement_m", "velocity": "velocity_m_s", "acceleration": "acceleration_m_s2",
                    "strain": "strain"}
#: Quantities an input (what drives the beam) may be, with the project's CSV column.
INPUT_COLUMN_OF = {"voltage": "voltage_V", "force": "force_N"}

_TOOLBOX_G = "Physics Toolbox Sensor Suite's g-force meter writes it in g"
_TOOLBOX_LINEAR = "Physics Toolbox Sensor Suite's linear accelerometer writes it in m/s²"
#: Names apps write without a unit: lower-case name -> (unit spelling, axis or None, who writes it so).
KNOWN_NAMES: dict[str, tuple[str, str | None, str]] = {
    "gfx": ("g", "x", _TOOLBOX_G),
    "gfy": ("g", "y", _TOOLBOX_G),
    "gfz": ("g", "z", _TOOLBOX_G),
    "tgf": ("g", "total", _TOOLBOX_G),
    "gftotal": ("g", "total", _TOOLBOX_G),
    "ax": ("m/s^2", "x", _TOOLBOX_LINEAR),
    "ay": ("m/s^2", "y", _TOOLBOX_LINEAR),
    "az": ("m/s^2", "z", _TOOLBOX_LINEAR),
    "at": ("m/s^2", "total", _TOOLBOX_LINEAR),
    "micros": ("us", None, "an Arduino's micros() counts microseconds"),
    "millis": ("ms", None, "an Arduino's millis() counts milliseconds"),
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
        The unit as written, or as an app writes it for a name it knows (``"g"`` for ``gFz``);
        None when not said.
    axis : str or None
        ``"x"``, ``"y"``, ``"z"``, ``"total"`` (a magnitude) or None.
    unit_source : str or None
        Where the unit comes from, in words (``"its name"``, ``"the file's unit field"``,
        ``"given"``, or who writes the name in that unit); None without a unit.
    arbitrary : bool
        True for arbitrary units (module notes): the values as the file holds them, scale unknown.
    """

    name: str
    quantity: str | None
    factor: float | None
    unit: str | None
    axis: str | None
    unit_source: str | None = None
    arbitrary: bool = False

    @property
    def is_total(self) -> bool:
        """A magnitude (|a| of three axes): never a signed vibration."""
        return self.axis == "total"


def normalise_unit(text: str) -> str:
    """A unit spelling as :data:`UNITS` keys it (lower case, no spaces, ``**`` as ``^``)."""
    return text.strip().replace(" ", "").replace("**", "^").replace("⁻²", "^-2").lower()


def unit_meaning(text: str) -> tuple[str, float] | None:
    """(quantity, factor to SI) of a unit spelling, None when it is not a known unit (nor for
    arbitrary units: see :func:`is_arbitrary`)."""
    key = normalise_unit(text)
    if key in UNITS:
        return UNITS[key]
    if key.endswith("²") and key[:-1] + "^2" in UNITS:  # pragma: no cover - covered by the table
        return UNITS[key[:-1] + "^2"]
    return None


def is_arbitrary(text: str) -> bool:
    """Whether ``text`` spells arbitrary units (module notes), with or without a quantity."""
    return _arbitrary(text) is not False


def arbitrary_quantity(text: str) -> str | None:
    """The quantity an arbitrary-units spelling names (``"arbitrary-strain"`` -> ``"strain"``), None
    when it names none (or is not such a spelling)."""
    found = _arbitrary(text)
    return found or None


def _arbitrary(text: str) -> str | None | bool:
    """False: not arbitrary units; None: arbitrary units of no named quantity; else the quantity."""
    key = normalise_unit(text).replace("_", "-")
    if key in ARBITRARY_SPELLINGS:
        return None
    for spelling in ARBITRARY_SPELLINGS:
        for separator in ("-", ":", ""):
            for quantity in OUTPUT_COLUMN_OF:
                if key in (f"{spelling}{separator}{quantity}", f"{quantity}{separator}{spelling}"):
                    return quantity
    return False


def is_known_unit(text: str) -> bool:
    """Whether ``text`` is a unit the reader knows (an SI or common unit, or arbitrary units)."""
    return unit_meaning(text) is not None or is_arbitrary(text)


def display_unit(text: str) -> str:
    """A unit spelling as a reader sees it (``"m/s^2"`` -> ``"m/s²"``, ``"us"`` -> ``"µs"``)."""
    return UNIT_DISPLAY.get(text, text)


def _words(text: str) -> list[str]:
    return [w for w in re.split(r"[\s_\-\.:]+", text.strip().lower()) if w]


def _axis(words: list[str], bare: str) -> str | None:
    if any(w in TOTAL_WORDS for w in words):
        return "total"
    if words and words[-1] in ("x", "y", "z"):
        return words[-1]
    match = re.fullmatch(r"(?:acc|accel|acceleration|a|gf|g|vel|v|disp|d)([xyz])", bare)
    return match.group(1) if match else None


def column_meaning(name: str, unit: str | None = None, unit_source: str = "given") -> ColumnMeaning:
    """Read a column's quantity, unit and axis from its name (module notes).

    Parameters
    ----------
    name : str
        The column's name as written in the file (quotes already removed).
    unit : str, optional
        A unit given separately (a file's unit field, or ``--unit``); it wins over the name's.
    unit_source : str
        Where ``unit`` comes from, in words (:attr:`ColumnMeaning.unit_source`).

    Returns
    -------
    ColumnMeaning
    """
    text = str(name).strip()
    bare = text
    found_unit: str | None = None
    source: str | None = None
    match = _BRACKET.search(text)
    if match:
        bare = text[: match.start()].strip()
        if not re.fullmatch(r"\s*\d*\s*", match.group(1)):  # "Acc[1]": an index, not a unit
            found_unit, source = match.group(1).strip(), "its name"
    words = _words(bare)
    lower = bare.lower().replace(" ", "")
    known = KNOWN_NAMES.get(lower)
    axis = _axis(words, lower)
    if known is not None:
        known_unit, known_axis, writer = known
        axis = known_axis or axis
        if found_unit is None:
            found_unit, source = known_unit, writer
    if found_unit is None and len(words) > 2 and is_known_unit("/".join(words[-2:])):
        found_unit, source = "/".join(words[-2:]), "its name"  # "velocity_m_s" -> "m/s", "acceleration_m_s2" -> "m/s2"
        words = words[:-2]
        axis = _axis(words, "".join(words))
    if found_unit is None and len(words) > 1 and is_known_unit(words[-1]):
        found_unit, source = words[-1], "its name"  # "accel_z_g", "disp mm", "time_s", "a0 counts"
        words = words[:-1]
        axis = _axis(words, "".join(words))
    if unit is not None:
        found_unit, source = unit, unit_source
    quantity: str | None = None
    factor: float | None = None
    arbitrary = False
    if found_unit is not None:
        meaning = unit_meaning(found_unit)
        if meaning is not None:
            quantity, factor = meaning
        elif is_arbitrary(found_unit):
            quantity, factor, arbitrary = arbitrary_quantity(found_unit), 1.0, True
    named = next((q for q, names in QUANTITY_WORDS.items() if any(w in names for w in words)), None)
    timed = any(w in TIME_WORDS or re.fullmatch(r"(?:t|time)\d+", w) for w in words)  # "t", "t1": run 1's time
    if timed and (quantity in (None, "time")) and not arbitrary:
        quantity = "time"
    elif quantity is None:
        quantity = named
    elif quantity == "displacement" and named in ("acceleration", "velocity"):
        quantity = named  # "m" after "acceleration": a unit cut short; leave the factor unknown
        factor = None
    if arbitrary and quantity not in OUTPUT_COLUMN_OF:
        quantity = None  # counts of something the name does not say: the quantity must be given
    return ColumnMeaning(text, quantity, factor, found_unit, axis, source if found_unit is not None else None, arbitrary)
