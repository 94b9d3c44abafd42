"""Argument types shared by the ``beam`` subcommands (argparse ``type=`` converters).

Each raises :class:`argparse.ArgumentTypeError`, which the parser turns into one ``error:``
line and exit status 2.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

#: Where the bundled lab runs live when the package is used from the repository checkout.
BUNDLED_MEASUREMENTS = Path(__file__).resolve().parents[2] / "assets" / "measurements"


def finite_float(text: str) -> float:
    """A finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def non_negative_float(text: str) -> float:
    """A finite number >= 0."""
    value = finite_float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def _integer(text: str, minimum: int, description: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {description}, got {text!r}") from None
    if value < minimum:
        raise argparse.ArgumentTypeError(f"expected {description}, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """An integer >= 1."""
    return _integer(text, 1, "a positive integer")


def non_negative_int(text: str) -> int:
    """An integer >= 0."""
    return _integer(text, 0, "an integer >= 0")


def modes_choice(text: str) -> int | str:
    """A positive integer, or ``auto`` (chosen from the record's excited band)."""
    from beam.calibration.defaults import AUTO_MODES

    if text.strip().lower() == AUTO_MODES:
        return AUTO_MODES
    return _integer(text, 1, "a positive integer or 'auto'")


def time_window(text: str) -> tuple[float, float]:
    """``START:END`` in seconds, START < END."""
    start_text, colon, end_text = text.partition(":")
    if not colon:
        raise argparse.ArgumentTypeError(f"expected START:END in seconds, got {text!r}")
    start, end = finite_float(start_text), finite_float(end_text)
    if not start < end:
        raise argparse.ArgumentTypeError(f"window start must be before its end, got {text!r}")
    return start, end


def effect_list(text: str) -> str:
    """Effect ids ``A,B,...`` as given, or ``+A,B``: the default model's effects
    (:data:`beam.calibration.defaults.DEFAULT_EFFECTS`, its damping) and ``A``, ``B`` added to them
    (the ids are checked where the model is made)."""
    text = text.strip()
    if not text.startswith("+"):
        return text
    from beam.calibration.defaults import DEFAULT_EFFECTS

    added = [e.strip() for e in text[1:].split(",") if e.strip()]
    if not added:
        raise argparse.ArgumentTypeError(f"expected +A,B (effects added to the default {','.join(DEFAULT_EFFECTS)}), "
                                         f"got {text!r}")
    return ",".join([*DEFAULT_EFFECTS, *(a for a in added if a not in DEFAULT_EFFECTS)])


class HelpFormatter(argparse.HelpFormatter):
    """Wraps one-paragraph texts (descriptions) as usual; keeps texts with line breaks (tables) as written."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text.strip("\n"):
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)


def measurement_path(text: str) -> str:
    """A record as given (``NAME.csv``, ``NAME.toml``, ``NAME`` or a file in another format), or a
    bundled record by name (:func:`beam.io.bundled.resolve_data_path`: ``lab_run_1``,
    ``adxl_50cm_114655``)."""
    from beam.io.bundled import resolve_data_path

    return resolve_data_path(text)


def bundled_names() -> list[str]:
    """Names of the bundled records (empty when the package is installed without its assets)."""
    from beam.io.bundled import bundled_record_names

    return bundled_record_names()


def effects_epilog(option: str = "--effects") -> str:
    """The effect ids with their titles, for the ``--help`` of the commands that take effect ids
    (``option``: the option that takes them, ``--effects`` or ``--base``)."""
    from beam.physics.effects import EFFECTS

    width = max(len(name) for name in EFFECTS)
    lines = [f"effects (ids for {option}):"] + [f"  {name:<{width}}  {effect.title}" for name, effect in EFFECTS.items()]
    names = bundled_names()
    if names:
        lines += ["", "bundled measurements (DATA by name): " + ", ".join(names)]
    return "\n".join(lines)
