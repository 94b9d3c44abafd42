"""The prediction after the window that a candidate of a free decay is judged on.

A free decay has no input: after the window, a model predicts the rest of the record by carrying
its initial state forward. Two linear models (viscous or modal damping, a mass, a clamp) then
both extrapolate each mode's exponential decay from the window; on a real strip whose damping
changes with the swing, both miss the later amplitudes by far more than anything the candidate
changes (the shared 50 cm runs: 0.59-0.60 m/s² after 0-6 s for the base and for every linear
candidate alike, the record's noise 0.012 m/s²), and a better model of the frequencies can come out
0.2-1.5 % "worse". So the held-out part of a free decay is judged on the **amplitude-aware
prediction**:

- **both models linear**: block by block from the record's own amplitudes (:func:`reanchored_rmse`):
  the held-out samples are cut into blocks of :data:`BLOCK_PERIODS` periods of the model's mode 1
  (the phase-drift blocks' length, :func:`beam.residuals.phase_drift`); in each block the modal amplitudes, phases and the
  sensor's offset are fitted to the record by least squares, the model's poles at its MAP (its
  frequencies and decay rates, from the calibration window) kept. What is judged is then what
  the models differ in — frequencies, decay rates, how the modes mix at the sensor — at the
  amplitudes the record has after the window;
- **either model with an amplitude-dependent force** (drag, a slipping clamp, a spring: a nonlinear
  channel): the forward prediction from the window (:attr:`~beam.calibration.CalibrationResult.rmse_prediction_map`),
  which follows the model's own amplitude law: that law is what such an effect claims.

:func:`held_out_error` applies the rule to a pair; the re-anchored error is memoised on the result
(in its ``__dict__``, so that it travels with a result computed in a worker process; the
dashboard's server never runs the model): :func:`remember_held_out` computes it where the fit ran.
"""

from __future__ import annotations

import math

import numpy as np

from beam.calibration import CalibrationResult
from beam.calibration.free import free_rows_at

__all__ = ["BLOCK_PERIODS", "held_out_error", "reanchored_rmse", "remember_held_out", "uses_forward"]

#: Fewest periods of mode 1 in a block of the re-anchored prediction (the phase-drift blocks' 12).
BLOCK_PERIODS = 12.0
#: Where :func:`remember_held_out` keeps the value on a result.
_MEMO = "held_out_reanchored_rmse"


def uses_forward(*results: CalibrationResult) -> bool:
    """Whether a comparison of ``results`` judges the forward prediction from the window (a driven
    record, or any of them with an amplitude-dependent force) rather than the re-anchored one."""
    return any(not r.setup.is_free or r.setup.model.is_nonlinear for r in results)


def held_out_error(result: CalibrationResult, *others: CalibrationResult) -> float:
    """The held-out error (output's unit) of ``result`` compared with ``others``: the re-anchored
    one when every model of the comparison is a linear free decay, else the forward prediction's
    (module notes). NaN when the record has no held-out part."""
    if uses_forward(result, *others):
        return float(result.rmse_prediction_map)
    return reanchored_rmse(result)


def remember_held_out(result: CalibrationResult) -> None:
    """Compute the re-anchored held-out error of a linear free decay here (where the model is) and
    keep it on the result; nothing for any other result."""
    if result.setup.is_free and not result.setup.model.is_nonlinear:
        reanchored_rmse(result)


def _blocks(time_s: np.ndarray, block_s: float) -> list[slice]:
    """Consecutive slices of ``time_s`` (sorted) about ``block_s`` long; a last block shorter than
    half of it joins the one before."""
    edges = [0]
    start = float(time_s[0])
    for i in range(1, time_s.size):
        if time_s[i] - start >= block_s:
            edges.append(i)
            start = float(time_s[i])
    if len(edges) > 1 and time_s[-1] - time_s[edges[-1]] < 0.5 * block_s:
        edges.pop()
    edges.append(time_s.size)
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def reanchored_rmse(result: CalibrationResult) -> float:
    """RMSE (output's unit) after the window of a linear free decay's MAP model re-anchored block
    by block on the record (module notes): per block, least squares of the model's free-response
    basis at its MAP poles (and the offset's column for a velocity, an acceleration or a strain
    record) against the record's samples; NaN without samples after the window. Memoised on the result."""
    memo = vars(result).get(_MEMO)
    if memo is not None:
        return memo
    setup = result.setup
    m = setup.measurement
    mask = setup.held_out_mask & (m.time_s > setup.window[1])
    if not mask.any():
        value = math.nan
    else:
        model = result.problem.model
        values = {name: np.atleast_1d(float(v)) for name, v in result.laplace.map.values.items()}
        poles = model.poles(values)
        periods = [2.0 * math.pi / abs(p.imag) for p in poles[0] if p.imag > 0]
        block = BLOCK_PERIODS * max(periods) if periods else float(setup.window[1] - setup.window[0])
        t, y = m.time_s[mask], m.output[mask]
        squares = 0.0
        for part in _blocks(t, block):
            tb, yb = t[part], y[part]
            rows = free_rows_at(poles, tb, float(tb[0]), 1 if model.offset else 0)[0].T  # (n, k)
            coefficients, *_ = np.linalg.lstsq(rows, yb, rcond=None)
            squares += float(np.sum((yb - rows @ coefficients) ** 2))
        value = float(math.sqrt(squares / t.size))
    vars(result)[_MEMO] = value
    return value
