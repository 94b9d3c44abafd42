"""Calibration windows of a study: explicit lists, growing and sliding families, the default family.

Grammar of a window specification (times in seconds):

``START:END,START:END,...``
    An explicit list, e.g. ``0:0.5,0:1,1:2``.
``grow:START:STEP:END``
    Windows that all begin at START and end at START + STEP, START + 2 STEP, ... up to END
    (``grow:0:0.25:4`` = 0-0.25, 0-0.5, ..., 0-4 s).
``slide:LENGTH:START:STEP:END``
    Windows of LENGTH seconds beginning at START, START + STEP, ... whose end stays at or
    before END (``slide:1:0:0.5:4`` = 0-1, 0.5-1.5, ..., 3-4 s).

Window bounds are rounded to :data:`DIGITS` decimals (so that ``grow:0:0.1:1`` gives 0.3, not
0.30000000000000004, and the same window from two specifications is the same cell).
"""

from __future__ import annotations

import math

from beam.errors import BeamInputError

__all__ = ["DEFAULT_FRACTIONS", "DIGITS", "MAX_WINDOWS", "default_windows", "parse_windows"]

#: Ends of the default growing family, as fractions of the record's duration (from its start):
#: every window leaves at least 40 % of the record held out for the prediction.
DEFAULT_FRACTIONS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6)
#: Decimals (s) window bounds are rounded to (0.1 µs: far below any sampling step).
DIGITS = 7
#: Windows a family may generate at most (a typo such as ``grow:0:0.0001:4`` is an error, not 40,000 cells).
MAX_WINDOWS = 1000


def _number(text: str, spec: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise BeamInputError(f"not a number {text!r} in window specification {spec!r}") from None
    if not math.isfinite(value):
        raise BeamInputError(f"expected a finite number, got {text!r} in window specification {spec!r}")
    return value


def _window(start: float, end: float, spec: str) -> tuple[float, float]:
    start, end = round(start, DIGITS), round(end, DIGITS)
    if start < 0:
        raise BeamInputError(f"window start must be >= 0 s, got {start:g} in {spec!r}")
    if not start < end:
        raise BeamInputError(f"window start must be before its end, got {start:g}:{end:g} in {spec!r}")
    return start, end


def _steps(first: float, step: float, last: float, spec: str) -> int:
    """How many steps of ``step`` from ``first`` stay at or before ``last`` (a rounding error's tolerance)."""
    if not step > 0:
        raise BeamInputError(f"the step must be > 0 s, got {step:g} in {spec!r}")
    count = math.floor((last - first) / step + 1e-9)
    if count > MAX_WINDOWS:
        raise BeamInputError(f"{spec!r} gives {count} windows, more than {MAX_WINDOWS}")
    return count


def parse_windows(spec: str) -> tuple[tuple[float, float], ...]:
    """The windows ``(start_s, end_s)`` of a specification (module notes), in the order given, without repeats.

    Raises
    ------
    BeamInputError
        A malformed specification, a window that does not begin before it ends or begins before
        0 s, a family with no window or more than :data:`MAX_WINDOWS`.
    """
    text = spec.strip()
    kind, _, rest = text.partition(":")
    kind = kind.strip().lower()
    if kind in ("grow", "slide"):
        fields = [_number(f, spec) for f in rest.split(":")]
        if kind == "grow":
            if len(fields) != 3:
                raise BeamInputError(f"expected grow:START:STEP:END, got {spec!r}")
            start, step, end = fields
            n = _steps(start, step, end, spec)
            windows = [_window(start, start + k * step, spec) for k in range(1, n + 1)]
        else:
            if len(fields) != 4:
                raise BeamInputError(f"expected slide:LENGTH:START:STEP:END, got {spec!r}")
            length, start, step, end = fields
            if not length > 0:
                raise BeamInputError(f"the window length must be > 0 s, got {length:g} in {spec!r}")
            n = _steps(start + length, step, end, spec)
            windows = [_window(start + k * step, start + k * step + length, spec) for k in range(0, n + 1)]
    else:
        windows = []
        for item in text.split(","):
            first, colon, second = item.strip().partition(":")
            if not colon or ":" in second:
                raise BeamInputError(f"expected START:END (s) in {spec!r}, got {item.strip()!r}")
            windows.append(_window(_number(first, spec), _number(second, spec), spec))
    if not windows:
        raise BeamInputError(f"no window in {spec!r} (the first window ends after END)")
    return tuple(dict.fromkeys(windows))


def default_windows(start_s: float, end_s: float) -> tuple[tuple[float, float], ...]:
    """The default growing family of a record spanning ``[start_s, end_s]`` (s): windows from its
    start ending at :data:`DEFAULT_FRACTIONS` of its duration."""
    duration = end_s - start_s
    return tuple(_window(start_s, start_s + f * duration, "default") for f in DEFAULT_FRACTIONS)
