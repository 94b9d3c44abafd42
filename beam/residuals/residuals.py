"""Residuals over time against the prediction band, and scores per window.

:func:`band_residuals` gives the residual data − mean, which samples leave the (95 %) prediction
band, the *intervals* where the data leave it (runs merged across short gaps) and the coverage.
:func:`window_scores` splits the record into the calibration window and the rest (the
prediction window) and scores each: RMSE, bias and coverage.

All displacements are in metres, times in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from beam.errors import BeamInputError
from beam.residuals.common import check_signals, integer, jsonable

__all__ = ["BandResiduals", "ExceedanceInterval", "WindowScore", "WindowScores", "band_residuals", "window_scores"]

#: Runs of out-of-band samples separated by fewer than this many in-band samples are merged.
DEFAULT_MERGE_GAP = 3


@dataclass(frozen=True)
class ExceedanceInterval:
    """One interval where the data leave the prediction band.

    Parameters
    ----------
    start_s, end_s : float
        Times of the first and last out-of-band samples (s).
    n_samples : int
        Samples spanned, first to last inclusive (merged gaps included).
    n_outside : int
        Samples of the interval that are outside the band.
    max_excess_m : float
        Largest distance of the data beyond the band (m), > 0.
    side : str
        ``"above"``, ``"below"`` or ``"both"``: where the data leave the band.
    """

    start_s: float
    end_s: float
    n_samples: int
    n_outside: int
    max_excess_m: float
    side: str


@dataclass(frozen=True, eq=False)
class BandResiduals:
    """Residuals of the data against the predictive mean and band.

    Parameters
    ----------
    time_s : ndarray
        Sample times (s).
    residual_m : ndarray
        data − predictive mean (m).
    outside : ndarray of bool
        True where the data lie outside [lower, upper].
    excess_m : ndarray
        Distance of the data beyond the band (m): data − upper above it, lower − data below it,
        0 inside.
    intervals : tuple of ExceedanceInterval
        Merged runs of out-of-band samples, in time order.
    coverage : float
        Fraction of samples inside the band (compare with ``level``).
    level : float
        Nominal probability of the band (for labels), e.g. 0.95.
    rmse_m : float
        Root mean square residual (m).
    """

    time_s: np.ndarray = field(repr=False)
    residual_m: np.ndarray = field(repr=False)
    outside: np.ndarray = field(repr=False)
    excess_m: np.ndarray = field(repr=False)
    intervals: tuple[ExceedanceInterval, ...]
    coverage: float
    level: float
    rmse_m: float

    def to_dict(self, arrays: bool = False) -> dict[str, Any]:
        """JSON-ready dict; arrays only when asked."""
        return jsonable(self, arrays)


@dataclass(frozen=True)
class WindowScore:
    """Scores of the residuals in one window.

    Parameters
    ----------
    name : str
        ``"calibration"`` or ``"prediction"``.
    n_samples : int
        Samples in the window (0 leaves the scores NaN).
    rmse_m : float
        Root mean square residual (m).
    bias_m : float
        Mean residual (m).
    max_abs_residual_m : float
        Largest |residual| (m).
    coverage : float
        Fraction of samples inside the band (NaN without a band).
    """

    name: str
    n_samples: int
    rmse_m: float
    bias_m: float
    max_abs_residual_m: float
    coverage: float


@dataclass(frozen=True)
class WindowScores:
    """Calibration window [start_s, end_s] against the rest of the record.

    ``rmse_ratio`` is prediction RMSE / calibration RMSE: near 1 when the model extrapolates
    as well as it fits, large when it only fits where it was calibrated.
    """

    start_s: float
    end_s: float
    calibration: WindowScore
    prediction: WindowScore
    rmse_ratio: float

    def to_dict(self) -> dict[str, Any]:
        return jsonable(self)


def _check_band(data: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
    crossed = np.flatnonzero(lower > upper)
    if crossed.size:
        raise BeamInputError(
            f"the prediction band is inverted (lower > upper) at {crossed.size} samples, first at index {crossed[0]}"
        )


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and last indices of the runs of True in ``mask``."""
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.diff(padded)
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1


def band_residuals(
    time_s: np.ndarray,
    data_m: np.ndarray,
    mean_m: np.ndarray,
    lower_m: np.ndarray,
    upper_m: np.ndarray,
    *,
    merge_gap: int = DEFAULT_MERGE_GAP,
    level: float = 0.95,
) -> BandResiduals:
    """Residuals, out-of-band samples and the intervals where the data leave the band.

    Parameters
    ----------
    time_s : array (n,)
        Uniform sample times (s).
    data_m : array (n,)
        Measured displacement (m).
    mean_m : array (n,)
        Predictive mean (m).
    lower_m, upper_m : array (n,)
        Lower and upper edges of the prediction band (m); samples on an edge count as inside.
    merge_gap : int
        Runs of out-of-band samples separated by fewer than ``merge_gap`` in-band samples form
        one interval (default 3; 0 or 1 merges nothing).
    level : float
        Nominal probability of the band, kept for labels (default 0.95).

    Returns
    -------
    BandResiduals

    Raises
    ------
    BeamInputError
        Arrays of different lengths, NaN, non-uniform time, an inverted band.
    """
    time, _, (data, mean, lower, upper) = check_signals(
        time_s, data_m=data_m, mean_m=mean_m, lower_m=lower_m, upper_m=upper_m
    )
    merge_gap = integer(merge_gap, "merge_gap", 0)
    _check_band(data, lower, upper)
    residual = data - mean
    above = np.maximum(data - upper, 0.0)
    below = np.maximum(lower - data, 0.0)
    excess = above + below
    outside = excess > 0
    starts, ends = _runs(outside)
    if starts.size > 1:  # merge runs separated by short in-band gaps
        gaps = starts[1:] - ends[:-1] - 1
        keep = np.concatenate([[True], gaps >= merge_gap])
        starts, ends = starts[keep], np.concatenate([ends[:-1][keep[1:]], ends[-1:]])
    intervals = []
    for first, last in zip(starts, ends):
        span = slice(first, last + 1)
        high, low = bool(above[span].any()), bool(below[span].any())
        intervals.append(
            ExceedanceInterval(
                start_s=float(time[first]), end_s=float(time[last]), n_samples=int(last - first + 1),
                n_outside=int(outside[span].sum()), max_excess_m=float(excess[span].max()),
                side="both" if high and low else ("above" if high else "below"),
            )
        )
    return BandResiduals(
        time_s=time, residual_m=residual, outside=outside, excess_m=excess, intervals=tuple(intervals),
        coverage=float(1.0 - outside.mean()), level=float(level), rmse_m=float(np.sqrt(np.mean(residual**2))),
    )


def _score(name: str, residual: np.ndarray, inside: np.ndarray | None) -> WindowScore:
    if residual.size == 0:
        nan = float("nan")
        return WindowScore(name, 0, nan, nan, nan, nan)
    return WindowScore(
        name=name, n_samples=int(residual.size), rmse_m=float(np.sqrt(np.mean(residual**2))),
        bias_m=float(residual.mean()), max_abs_residual_m=float(np.abs(residual).max()),
        coverage=float(inside.mean()) if inside is not None else float("nan"),
    )


def window_scores(
    time_s: np.ndarray,
    data_m: np.ndarray,
    mean_m: np.ndarray,
    calibration_window_s: tuple[float, float],
    lower_m: np.ndarray | None = None,
    upper_m: np.ndarray | None = None,
) -> WindowScores:
    """RMSE, bias and coverage in the calibration window and in the rest of the record.

    Parameters
    ----------
    time_s, data_m, mean_m : array (n,)
        Sample times (s), data and predictive mean (m).
    calibration_window_s : (float, float)
        Start and end (s) of the calibration window, inclusive; the prediction window is every
        other sample (before and after it).
    lower_m, upper_m : array (n,), optional
        Prediction band (m); without it coverage is NaN.

    Returns
    -------
    WindowScores

    Raises
    ------
    BeamInputError
        Bad arrays, a window with start >= end or holding fewer than two samples.
    """
    time, _, (data, mean) = check_signals(time_s, data_m=data_m, mean_m=mean_m)
    try:
        start, end = (float(v) for v in calibration_window_s)
    except (TypeError, ValueError):
        raise BeamInputError(f"calibration_window_s must be (start_s, end_s), got {calibration_window_s!r}") from None
    if not (np.isfinite(start) and np.isfinite(end) and start < end):
        raise BeamInputError(f"calibration window must have finite start_s < end_s, got ({start}, {end})")
    inside = None
    if (lower_m is None) != (upper_m is None):
        raise BeamInputError("give both lower_m and upper_m, or neither")
    if lower_m is not None:
        _, _, (lower, upper) = check_signals(time, lower_m=lower_m, upper_m=upper_m)
        _check_band(data, lower, upper)
        inside = (data >= lower) & (data <= upper)
    in_window = (time >= start) & (time <= end)
    if in_window.sum() < 2:
        raise BeamInputError(
            f"calibration window [{start:g}, {end:g}] s holds {int(in_window.sum())} samples of the record "
            f"[{time[0]:g}, {time[-1]:g}] s; at least 2 needed"
        )
    residual = data - mean
    calibration = _score("calibration", residual[in_window], None if inside is None else inside[in_window])
    prediction = _score("prediction", residual[~in_window], None if inside is None else inside[~in_window])
    ratio = prediction.rmse_m / calibration.rmse_m if calibration.rmse_m > 0 else float("nan")
    return WindowScores(start, end, calibration, prediction, float(ratio))
