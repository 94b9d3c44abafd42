"""Input checks and JSON conversion shared by the diagnostics (private).

Every public diagnostic takes plain arrays; these helpers turn bad input into one-line
:class:`beam.errors.BeamInputError` messages and turn results into JSON-ready values.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from beam.errors import BeamInputError

#: Largest allowed deviation of a time step from the median step, as a fraction of the step
#: (the tolerance of the measurement files, :data:`beam.io.measurement.UNIFORM_TIME_TOLERANCE`).
UNIFORM_TIME_TOLERANCE = 1e-2


def as_signal(values: Any, name: str, *, min_samples: int = 2) -> np.ndarray:
    """``values`` as a finite 1-d float array of at least ``min_samples`` samples."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise BeamInputError(f"{name} must be an array of numbers") from None
    if array.ndim != 1:
        raise BeamInputError(f"{name} must be 1-d, got shape {array.shape}")
    if array.size < min_samples:
        raise BeamInputError(f"{name} is too short: {array.size} samples, at least {min_samples} needed")
    bad = np.flatnonzero(~np.isfinite(array))
    if bad.size:
        raise BeamInputError(f"{name} holds NaN or infinite values ({bad.size} samples, first at index {bad[0]})")
    return array


def check_time(time_s: Any, *, min_samples: int = 2) -> tuple[np.ndarray, float]:
    """Uniformly sampled increasing time (s) and its sample interval (s)."""
    time = as_signal(time_s, "time_s", min_samples=min_samples)
    steps = np.diff(time)
    step = float(np.median(steps))
    if not step > 0:
        raise BeamInputError("time_s must increase")
    irregular = np.flatnonzero(np.abs(steps - step) > UNIFORM_TIME_TOLERANCE * step)
    if irregular.size:
        k = int(irregular[0])
        raise BeamInputError(
            f"time_s must be uniformly sampled: step {k} ({time[k]:g} s to {time[k + 1]:g} s) "
            f"differs from the median step {step:g} s"
        )
    return time, step


def check_signals(time_s: Any, min_samples: int = 2, **signals: Any) -> tuple[np.ndarray, float, list[np.ndarray]]:
    """Time (checked), its step and the named signals, all finite and of the same length."""
    time, step = check_time(time_s, min_samples=min_samples)
    arrays = []
    for name, values in signals.items():
        array = as_signal(values, name, min_samples=min_samples)
        if array.size != time.size:
            raise BeamInputError(f"{name} has {array.size} samples but time_s has {time.size}")
        arrays.append(array)
    return time, step, arrays


def positive(value: Any, name: str) -> float:
    """A finite positive float."""
    if isinstance(value, bool):
        raise BeamInputError(f"{name} must be a positive number, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise BeamInputError(f"{name} must be a positive number, got {value!r}") from None
    if not (math.isfinite(number) and number > 0):
        raise BeamInputError(f"{name} must be a positive number, got {value!r}")
    return number


def integer(value: Any, name: str, minimum: int, maximum: int | None = None) -> int:
    """An integer in [minimum, maximum]."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum or (
        maximum is not None and value > maximum
    ):
        upper = "" if maximum is None else f" and <= {maximum}"
        raise BeamInputError(f"{name} must be an integer >= {minimum}{upper}, got {value!r}")
    return int(value)


def jsonable(value: Any, arrays: bool = True) -> Any:
    """Plain Python values for :func:`json.dumps`: arrays to lists, NaN and inf to None.

    Dataclasses become dicts of their fields; with ``arrays=False`` array fields (of more than
    one element) are left out, which keeps the summaries a CLI prints short.
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out = {}
        for f in dataclasses.fields(value):
            item = getattr(value, f.name)
            if not arrays and isinstance(item, np.ndarray) and item.ndim > 0:
                continue
            out[f.name] = jsonable(item, arrays)
        return out
    if isinstance(value, dict):
        return {str(k): jsonable(v, arrays) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v, arrays) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist(), arrays)
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        number = float(value)
        return number if math.isfinite(number) else None
    return value
