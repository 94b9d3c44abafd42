"""How far the model's mode 1 falls out of phase with the record after the calibration window.

A frequency error too small to see in a window (0.1 % of f1) accumulates in phase over a long
held-out span: at 6 Hz it is 40° after 15 s, and a model whose amplitudes are right then misses
by most of the signal. :func:`phase_drift` measures that lag block by block (the record's and
the prediction's mode 1, band-passed alike, their Hilbert phases differenced) and how much of the
held-out error the lag alone explains: the prediction shifted in time by each block's mean lag
(``lag / (2 pi f1)``) against the record.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

from beam.errors import BeamInputError
from beam.residuals.common import jsonable

__all__ = ["PhaseDrift", "phase_drift"]

#: Cycles of mode 1 per block: enough for a mean phase that the noise does not move, few enough
#: for a lag that grows along the record to be followed.
CYCLES_PER_BLOCK = 12
#: Half-width of the band-pass around f1, relative to it (the mode's own band; the next mode of a
#: cantilever is 6 f1 away).
RELATIVE_BAND = 0.3


@dataclass(frozen=True)
class PhaseDrift:
    """The phase of the record's mode 1 against the model's after the calibration window.

    Attributes
    ----------
    frequency_Hz : float
        The model's f1, around which both signals are band-passed.
    block_start_s, block_stop_s : ndarray
        The blocks (s).
    lag_deg : ndarray
        Mean phase of the record minus the model's in each block (degrees; positive: the record
        runs ahead, its frequency is higher).
    rmse, rmse_aligned : ndarray
        RMSE of record minus prediction in each block, as predicted and with the prediction
        shifted in time by the block's lag (output unit).
    slope_deg_per_s : float
        Least-squares slope of the lag against the block centres (deg/s).
    frequency_offset_pct : float
        The frequency offset that slope means, 100 slope / (360 f1) (%; positive: the record's
        f1 is above the model's over the blocks).
    rmse_total, rmse_aligned_total : float
        Over all blocks.
    """

    frequency_Hz: float
    block_start_s: np.ndarray
    block_stop_s: np.ndarray
    lag_deg: np.ndarray
    rmse: np.ndarray
    rmse_aligned: np.ndarray
    slope_deg_per_s: float
    frequency_offset_pct: float
    rmse_total: float
    rmse_aligned_total: float

    @property
    def lag_share(self) -> float:
        """Share of the blocks' residual power the lag explains, 1 − (aligned / as predicted)²."""
        if not self.rmse_total > 0:
            return float("nan")
        return float(1.0 - (self.rmse_aligned_total / self.rmse_total) ** 2)

    def to_dict(self) -> dict:
        return jsonable({
            "frequency_Hz": self.frequency_Hz, "block_start_s": self.block_start_s,
            "block_stop_s": self.block_stop_s, "lag_deg": self.lag_deg, "rmse": self.rmse,
            "rmse_aligned": self.rmse_aligned, "slope_deg_per_s": self.slope_deg_per_s,
            "frequency_offset_pct": self.frequency_offset_pct, "rmse_total": self.rmse_total,
            "rmse_aligned_total": self.rmse_aligned_total, "lag_share": self.lag_share,
        })


def phase_drift(
    time_s: np.ndarray,
    data: np.ndarray,
    prediction: np.ndarray,
    frequency_Hz: float,
    start_s: float,
    *,
    cycles_per_block: int = CYCLES_PER_BLOCK,
    filter_from_s: float | None = None,
) -> PhaseDrift:
    """The phase lag of the record's mode 1 behind (or ahead of) the model's, block by block.

    Parameters
    ----------
    time_s : ndarray, shape (n,)
        Uniform stamps (s).
    data, prediction : ndarray, shape (n,)
        The record and the model's prediction on those stamps (same unit).
    frequency_Hz : float
        The model's mode-1 frequency (Hz).
    start_s : float
        Where the blocks begin (s): the end of the calibration window.
    cycles_per_block : int
        Cycles of mode 1 per block (default :data:`CYCLES_PER_BLOCK`).
    filter_from_s : float, optional
        Where the band-pass starts (s, at most ``start_s``; default ``start_s``): an earlier
        start keeps the filter's edge out of the first block. The record and the prediction
        must be finite from there on.

    Returns
    -------
    PhaseDrift

    Raises
    ------
    BeamInputError
        When fewer than three whole blocks fit after ``start_s``, the sampling cannot carry f1,
        or a sample to filter is not finite.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(data, dtype=float)
    m = np.asarray(prediction, dtype=float)
    if not (t.shape == y.shape == m.shape) or t.ndim != 1:
        raise BeamInputError("time, data and prediction must be 1-D arrays of one length")
    f1 = float(frequency_Hz)
    dt = float(np.median(np.diff(t)))
    if not (f1 > 0 and (1.0 + RELATIVE_BAND) * f1 < 0.5 / dt):
        raise BeamInputError(f"mode 1 at {f1:g} Hz cannot be followed at {1.0 / dt:g} samples per second")
    block = cycles_per_block / f1
    starts = np.arange(float(start_s), t[-1] - block + 1e-12, block)
    if starts.size < 3:
        raise BeamInputError(f"fewer than 3 blocks of {cycles_per_block} cycles fit after {start_s:g} s")
    sos = scipy.signal.butter(4, [(1.0 - RELATIVE_BAND) * f1, (1.0 + RELATIVE_BAND) * f1], btype="band",
                              fs=1.0 / dt, output="sos")
    lead = float(start_s) if filter_from_s is None else min(float(filter_from_s), float(start_s))
    used = t >= lead  # filtered from here on (before it the prediction may not exist: a release)
    if not (np.isfinite(y[used]).all() and np.isfinite(m[used]).all()):
        raise BeamInputError("the record or the prediction has non-finite samples after the window")
    record, model = (scipy.signal.hilbert(scipy.signal.sosfiltfilt(sos, v[used])) for v in (y, m))
    phase = np.full(t.shape, np.nan)
    after = t[used] >= float(start_s)  # the difference of phases, followed from the window's end
    phase[np.flatnonzero(used)[after]] = np.unwrap(np.angle(record[after] * np.conj(model[after])))
    lags, rmse, aligned, squares, aligned_squares, count = [], [], [], 0.0, 0.0, 0
    for a in starts:
        inside = (t >= a) & (t < a + block)
        lag = float(np.mean(phase[inside]))
        shifted = np.interp(t[inside] + lag / (2.0 * np.pi * f1), t, m)  # the model moved by the lag
        r, ra = y[inside] - m[inside], y[inside] - shifted
        lags.append(np.degrees(lag))
        rmse.append(float(np.sqrt(np.mean(r**2))))
        aligned.append(float(np.sqrt(np.mean(ra**2))))
        squares, aligned_squares, count = squares + float(r @ r), aligned_squares + float(ra @ ra), count + r.size
    lag_deg = np.asarray(lags)
    centres = starts + 0.5 * block
    slope = float(np.polyfit(centres, lag_deg, 1)[0])
    return PhaseDrift(
        frequency_Hz=f1, block_start_s=starts, block_stop_s=starts + block, lag_deg=lag_deg,
        rmse=np.asarray(rmse), rmse_aligned=np.asarray(aligned), slope_deg_per_s=slope,
        frequency_offset_pct=100.0 * slope / (360.0 * f1),
        rmse_total=float(np.sqrt(squares / count)), rmse_aligned_total=float(np.sqrt(aligned_squares / count)),
    )
