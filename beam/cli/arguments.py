"""Argument types shared by the ``beam`` subcommands (argparse ``type=`` converters).

Each raises :class:`argparse.ArgumentTypeError`, which the parser turns into one ``error:``
line and exit status 2.
"""

from __future__ import annotations

import argparse
import math


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


def time_window(text: str) -> tuple[float, float]:
    """``START:END`` in seconds, START < END."""
    start_text, colon, end_text = text.partition(":")
    if not colon:
        raise argparse.ArgumentTypeError(f"expected START:END in seconds, got {text!r}")
    start, end = finite_float(start_text), finite_float(end_text)
    if not start < end:
        raise argparse.ArgumentTypeError(f"window start must be before its end, got {text!r}")
    return start, end
