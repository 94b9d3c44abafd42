"""Errors that are the user's to fix (bad files, bad options), as opposed to bugs.

The command line prints a :class:`BeamInputError` as one ``error: ...`` line and exits with
status 2; the dashboard shows its message and keeps the previous result. The two helpers below
check a value before such a message names it (every layer uses them: the physics reads its
tables with them, :mod:`beam.io.text` re-exports them).
"""

from __future__ import annotations

import math
import numbers
from typing import Any

__all__ = ["BeamInputError", "as_finite_float", "short_repr"]


class BeamInputError(ValueError):
    """Invalid user input: a malformed file, an unknown effect, a window outside the record.

    The message is one line that names the file, row or key and says what is wrong.
    """


def as_finite_float(value: Any) -> float | None:
    """``float(value)`` for a finite real number (not a boolean), else None.

    Unlike ``math.isfinite``, never raises: an integer too large for a float (TOML integers
    have no size limit in :mod:`tomllib`) and anything that is not a number give None.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    try:
        number = float(value)
    except (OverflowError, ValueError, TypeError):
        return None
    return number if math.isfinite(number) else None


def short_repr(value: Any, limit: int = 40) -> str:
    """``repr(value)`` cut to ``limit`` characters (a 400-digit integer would flood a message)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
