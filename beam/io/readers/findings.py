"""What the reader found in a file and chose, as data; and how a front end says it.

The reader (:mod:`beam.io.readers.signal`) decides several things a file may not say: which
record of a file holding several, which block, where the time comes from and in which unit,
which column is the signal and in which unit, which pluck. Each decision is a :class:`Finding`
(what was found, what was chosen, why, and the reading option that changes it); a file that
cannot be read without a choice raises a :class:`ReadingError` holding the problem, the one
:class:`Hint` that resolves it and the findings made before it.

Neither names a front end's controls. A :class:`Phrasing` does: the command line's
(:data:`COMMAND_LINE`, its flags ``--column``, ``--unit``, ``--time-unit`` ...; the message of a
:class:`ReadingError` is in its words) or the dashboard's (its controls under *Reading
options*), each in its own sentences.

Reading options are named by their keywords of :func:`beam.io.readers.read_record`:
:data:`OPTIONS`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from beam.errors import BeamInputError
from beam.io.readers.units import display_unit

#: The reading options (keywords of :func:`beam.io.readers.read_record`).
OPTIONS = ("format", "record", "column", "axis", "unit", "rate", "time_unit", "segment")

#: What a finding is about, in the order a summary lists them, with its title.
TOPICS = {"record": "record", "block": "block", "time": "time", "signal": "signal", "unit": "unit",
          "input": "input", "pluck": "pluck"}


@dataclass(frozen=True)
class Finding:
    """One decision of the reader.

    Attributes
    ----------
    topic : str
        A key of :data:`TOPICS`.
    chosen : str
        What was used (a column's name, ``"m/s^2"``, ``"segment 2"``), as the file spells it.
    why : str
        Why, in words that name no front end ("the most vibration power", "its name"); empty
        when the choice was given (:attr:`given`).
    found : str
        What the file offered, in words ("3 columns measure acceleration: gFx, gFy, gFz"); may be
        empty.
    option : str or None
        The reading option (:data:`OPTIONS`) that changes it; None when nothing does.
    given : bool
        True when the choice is the user's (the option was given).
    """

    topic: str
    chosen: str
    why: str = ""
    found: str = ""
    option: str | None = None
    given: bool = False


@dataclass(frozen=True)
class Hint:
    """What resolves a :class:`ReadingError`: a kind (a key of a phrasing's ``hints``) and the
    values to suggest, as :func:`beam.io.readers.read_record` takes them."""

    kind: str
    values: tuple[str, ...] = ()


class ReadingError(BeamInputError):
    """A file that cannot become a record without a choice (or with the choice given).

    Parameters
    ----------
    path : path-like
        The file.
    problem : str
        What is wrong, in words that name no front end.
    hint : Hint, optional
        What resolves it.
    findings : sequence of Finding
        What the reader had found before (the time, the record, ...).
    format : str, optional
        The format recognised.
    columns : sequence of str
        The listing of the columns of the part of the file read (``"2: gFx (acceleration in g)"``).
    records : sequence of str
        The records of a file holding several (:attr:`beam.io.readers.table.Block.label`).
    option : str, optional
        The reading option whose value is wrong (a choice given that the file does not have).
    value : str, optional
        That value.

    The message (``str``) is the command line's (:data:`COMMAND_LINE`); :meth:`phrased` says
    it in another front end's words.
    """

    def __init__(self, path, problem: str, hint: Hint | None = None, *, findings: Sequence[Finding] = (),
                 format: str | None = None, columns: Sequence[str] = (), records: Sequence[str] = (),
                 option: str | None = None, value: object = None) -> None:
        self.path = None if path is None else Path(path)
        self.problem = problem
        self.hint = hint
        self.findings = tuple(findings)
        self.format = format
        self.columns = tuple(columns)
        self.records = tuple(records)
        self.option = option
        self.value = value
        super().__init__(self.phrased(COMMAND_LINE))

    def __reduce__(self):  # pickled whole (a worker process's error reaches its caller with its data)
        return (_rebuilt, (self.path, self.problem, self.hint, self.findings, self.format, self.columns, self.records,
                           self.option, self.value))

    def phrased(self, phrasing: Phrasing, path_text: str | None = None) -> str:
        """The message in ``phrasing``'s words: ``FILE: [OPTION VALUE: ]problem; hint (read as
        FORMAT: findings)``; ``path_text`` names the file instead of its path."""
        where = path_text if path_text is not None else (str(self.path) if self.path is not None else "")
        parts = []
        if self.option is not None:
            parts.append(f"{phrasing.option(self.option)} {self.value}: ")
        parts.append(self.problem)
        if self.hint is not None:
            parts.append(f"; {phrasing.hint(self.hint)}")
        context = [phrasing.finding(f) for f in self.findings]
        if self.format:
            parts.append(f" (read as {self.format}" + (f": {'; '.join(context)}" if context else "") + ")")
        elif context:
            parts.append(f" ({'; '.join(context)})")
        return (f"{where}: " if where else "") + "".join(parts)


def _rebuilt(path, problem, hint, findings, format, columns, records, option, value) -> ReadingError:
    return ReadingError(path, problem, hint, findings=findings, format=format, columns=columns, records=records,
                        option=option, value=value)


@dataclass(frozen=True)
class Phrasing:
    """How a front end names the reading options and says the reader's findings and hints.

    Attributes
    ----------
    options : mapping
        Reading option (:data:`OPTIONS`) -> how the front end names it (``"--column"``,
        ``"Signal column"``).
    hints : mapping
        :attr:`Hint.kind` -> the sentence that says it, with ``{values}`` for its values.
    given : str
        The reason of a choice given, with ``{option}``.
    change : str
        Appended to a finding that an option changes, with ``{option}``.
    separator : str
        Between the values of a hint (``"|"`` on the command line).
    units_shown : bool
        Whether units are shown as a reader sees them (``m/s²``) rather than as typed (``m/s^2``).
    """

    options: Mapping[str, str]
    hints: Mapping[str, str]
    given: str = "chosen with {option}"
    change: str = " (another: {option})"
    separator: str = "|"
    units_shown: bool = False
    titles: Mapping[str, str] = field(default_factory=lambda: dict(TOPICS))

    def option(self, name: str) -> str:
        """How the front end names the reading option ``name``."""
        return self.options.get(name, name)

    def values(self, values: Sequence[str]) -> str:
        """Suggested values joined as the front end writes them."""
        return self.separator.join(display_unit(v) if self.units_shown else v for v in values)

    def hint(self, hint: Hint) -> str:
        """The sentence of a hint (``{values}`` joined by :attr:`separator`, ``{listed}`` by commas)."""
        return self.hints[hint.kind].format(values=self.values(hint.values), listed=listing(hint.values, self))

    def why(self, finding: Finding) -> str:
        """Why a choice was made (a choice given: :attr:`given`, then what it means, if anything)."""
        if not finding.given:
            return finding.why
        given = self.given.format(option=self.option(finding.option))
        return f"{given}; {finding.why}" if finding.why else given

    def finding(self, finding: Finding, *, title: bool = True, change: bool = False) -> str:
        """``"signal: gFz: the most vibration power"`` (with the option that changes it when
        ``change``)."""
        chosen = display_unit(finding.chosen) if self.units_shown and finding.topic == "unit" else finding.chosen
        text = f"{chosen}: {self.why(finding)}" if self.why(finding) else chosen
        if finding.found:
            text += f" ({finding.found})"
        if change and finding.option is not None and not finding.given:
            text += self.change.format(option=self.option(finding.option))
        return f"{self.titles.get(finding.topic, finding.topic)}: {text}" if title else text


#: The command line's words: its flags (``beam import``, ``beam calibrate``, ``beam diagnose``).
COMMAND_LINE = Phrasing(
    options={"format": "--format", "record": "--record", "column": "--column", "axis": "--axis", "unit": "--unit",
             "rate": "--rate", "time_unit": "--time-unit", "segment": "--segment"},
    hints={
        "time_unit": "give --time-unit {values} (or --time-unit s if they are seconds)",
        "rate": "give the sampling rate with --rate HZ (or a time column named time, t or 'Time (s)')",
        "column": "choose one with --column NAME|INDEX",
        "axis": "use --column NAME|INDEX",
        "column_and_unit": "choose one with --column NAME|INDEX and its unit with --unit UNIT ({listed}; "
                           "arbitrary-acceleration, -velocity, -displacement or -strain for a signal of unknown scale)",
        "unit": "give it with --unit ({listed}; arbitrary for a signal of unknown scale: ADC counts, an uncalibrated "
                "sensor's volts)",
        "unit_and_quantity": "give it with --unit ({listed}; arbitrary-acceleration, -velocity, -displacement or -strain "
                             "for a signal of unknown scale: ADC counts, an uncalibrated sensor's volts)",
        "output_unit": "if it is the sensor's output give its unit with --unit ({listed}; arbitrary-acceleration, "
                       "-velocity, -displacement or -strain for an uncalibrated sensor's volts)",
        "quantity": "say what the sensor measures with --unit {values}",
        "record": "choose one with --record NAME|INDEX",
        "expected": "expected one of {listed}",
    },
    given="chosen with {option}",
    change="; another with {option}",
)


def listing(values: Sequence[str], phrasing: Phrasing = COMMAND_LINE) -> str:
    """Values as a message lists them (``g, m/s^2, ...``)."""
    return ", ".join(display_unit(v) if phrasing.units_shown else v for v in values)
