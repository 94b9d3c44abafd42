"""Record checks before a calibration, and decimation of over-long records.

Decimation (:func:`decimate_measurement`)
-----------------------------------------
A record of n > ``max_samples`` samples is decimated by q = ceil(n / max_samples), keeping the
samples t_0, t_q, t_2q, ... (the time stamps as given):

* **displacement** (a point sample at t_k): zero-phase anti-alias FIR filter, then every q-th
  sample (:func:`scipy.signal.resample_poly`, ``padtype="antireflect"`` so that a sensor offset
  or a record ending mid-oscillation makes no edge transient). White sensor noise comes
  out with its sd scaled by about sqrt(0.9 / q) (the filter keeps 0.9 of the new band), which
  the calibration then estimates;
* **voltage** (held over each interval, zero-order hold): the same filter, then the **mean over
  each block** of q samples, held over the coarse interval [t_jq, t_(j+1)q). A held value that
  equals the block's mean keeps the impulse (integral of V over the interval) of the block, so
  the model driven by it matches the response to the fine voltage to second order in the
  coarse step. Picking every q-th voltage sample instead holds V(t_jq) for the whole block, a
  delay of (q - 1) dt / 2 that the model cannot undo.

The measured errors of both choices (and of scipy's ``decimate``) are on the design decisions
page (``docs/decisions.md``, records and files); ``tests/test_reliability_limits.py`` checks
the chirp and pulse cases.

The same holds for every kind of record: the output (displacement, velocity or acceleration,
all point samples) is treated as the displacement above, the input (voltage or point force, both
held) as the voltage; a free response has no input. An **irregular** record (time stamps not on a
uniform grid, :attr:`beam.io.measurement.Measurement.uniform`) cannot be filtered (a digital filter
assumes a uniform grid): its output is subsampled without a filter (the models evaluate it exactly
at the kept stamps; white noise keeps its sd) and its input becomes the time-weighted mean over
each coarse interval [t_jq, t_(j+1)q), which keeps the impulse integral of u over the interval
(the last sample is held for one median step).

The anti-alias filter has 40 q + 1 taps (Hamming window) and its cutoff at 0.9 of the new
Nyquist frequency: content up to 0.82 of the new Nyquist frequency is kept to within 1 %, and
everything above the new Nyquist frequency is attenuated by at least 53 dB
(``tests/test_reliability_limits.py``). For the tip cubic spring (nonlinear)
filtering the voltage and the displacement alike is an approximation in itself: a filter
commutes only with a linear model.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from beam.errors import BeamInputError
from beam.io.limits import (
    FILTER_CUTOFF,
    FILTER_TAPS_PER_FACTOR,
    MAX_ABS_VOLTAGE_V,
    MAX_CALIBRATION_SAMPLES,
    MIN_DISPLACEMENT_VARIATION_M,
)
from beam.io.measurement import Measurement


def decimation_factor(sample_count: int, max_samples: int = MAX_CALIBRATION_SAMPLES) -> int:
    """Smallest integer q with ceil(n / q) <= ``max_samples`` (1 when the record fits).

    Parameters
    ----------
    sample_count : int
        Samples n in the record.
    max_samples : int
        Cap on the samples kept (>= 2).

    Returns
    -------
    int
        The factor q >= 1.
    """
    if isinstance(max_samples, bool) or not isinstance(max_samples, (int, np.integer)) or max_samples < 2:
        raise BeamInputError(f"max_samples must be an integer >= 2, got {max_samples!r}")
    return max(1, -(-int(sample_count) // int(max_samples)))


def anti_alias_taps(factor: int) -> np.ndarray:
    """Linear-phase FIR low-pass for decimation by ``factor`` (see the module notes)."""
    import scipy.signal  # slow import, only when decimating

    return scipy.signal.firwin(FILTER_TAPS_PER_FACTOR * factor + 1, FILTER_CUTOFF / factor, window="hamming")


def decimate_displacement(displacement_m: np.ndarray, factor: int) -> np.ndarray:
    """Anti-aliased point samples at every ``factor``-th time: ceil(n / q) values (m)."""
    import scipy.signal

    values = np.asarray(displacement_m, dtype=float)
    if factor == 1:
        return values.copy()
    taps = anti_alias_taps(factor)
    return scipy.signal.resample_poly(values, 1, factor, window=taps, padtype="antireflect")


def decimate_voltage(voltage_V: np.ndarray, factor: int) -> np.ndarray:
    """Held voltage over each coarse interval: block means of the anti-aliased voltage (V).

    The filter's edges are padded with the first and last values (a held voltage continues);
    the last block may be shorter than ``factor`` samples and is averaged over what it holds.
    """
    import scipy.signal

    values = np.asarray(voltage_V, dtype=float)
    if factor == 1:
        return values.copy()
    taps = anti_alias_taps(factor)
    half = taps.size // 2
    filtered = scipy.signal.oaconvolve(np.pad(values, half, mode="edge"), taps, mode="valid")
    starts = np.arange(0, values.size, factor)
    counts = np.diff(np.append(starts, values.size))
    return np.add.reduceat(filtered, starts) / counts


def held_block_mean(values: np.ndarray, time_s: np.ndarray, factor: int) -> np.ndarray:
    """Time-weighted mean of a held input over each block of ``factor`` irregular intervals.

    Sample k is held over [t_k, t_k+1) (the last one for the median step); block j covers
    samples jq .. (j+1)q - 1, i.e. the coarse interval [t_jq, t_(j+1)q).
    """
    u = np.asarray(values, dtype=float)
    t = np.asarray(time_s, dtype=float)
    steps = np.diff(t)
    durations = np.append(steps, np.median(steps))
    starts = np.arange(0, u.size, factor)
    return np.add.reduceat(u * durations, starts) / np.add.reduceat(durations, starts)


def decimate_measurement(
    measurement: Measurement, max_samples: int = MAX_CALIBRATION_SAMPLES
) -> tuple[Measurement, int]:
    """The record with at most ``max_samples`` samples, and the decimation factor used.

    Parameters
    ----------
    measurement : Measurement
        The record.
    max_samples : int
        Cap on the number of samples (default :data:`MAX_CALIBRATION_SAMPLES`).

    Returns
    -------
    measurement : Measurement
        The same object when it already fits (factor 1); otherwise a new measurement with the
        time stamps ``time_s[::q]``, the anti-aliased output at those times and the
        block-mean input (see the module notes; an irregular record: the output subsampled,
        the time-weighted block-mean input), with the same name, title, geometry, nominal
        values, sensor range and file paths (which name where the samples came from).
    factor : int
        The decimation factor q (1 when nothing was done).

    Raises
    ------
    BeamInputError
        ``max_samples`` is not an integer >= 2.
    """
    factor = decimation_factor(measurement.sample_count, max_samples)
    if factor == 1:
        return measurement, 1
    changes: dict[str, np.ndarray] = {}
    if measurement.uniform:
        changes[measurement.output_column] = decimate_displacement(measurement.output, factor)
        if measurement.input_column is not None:
            changes[measurement.input_column] = decimate_voltage(measurement.input, factor)
    else:
        changes[measurement.output_column] = measurement.output[::factor].copy()
        if measurement.input_column is not None:
            changes[measurement.input_column] = held_block_mean(measurement.input, measurement.time_s, factor)
    decimated = replace(measurement, time_s=measurement.time_s[::factor].copy(), **changes)
    return decimated, factor


def check_calibration_record(measurement: Measurement, window: tuple[float, float] | None = None) -> None:
    """Refuse a record the calibration cannot learn from, with one line saying why.

    Parameters
    ----------
    measurement : Measurement
        The record.
    window : (float, float), optional
        Calibration window (s); default the whole record.

    Raises
    ------
    BeamInputError
        The voltage exceeds :data:`MAX_ABS_VOLTAGE_V`; the input (voltage or force) is zero up
        to the window's end (the beam is never driven, the model predicts zero); the
        displacement in the window exceeds the beam's length or varies by less than
        :data:`MIN_DISPLACEMENT_VARIATION_M` (all zero, constant, or at the floating-point noise
        floor); a velocity or acceleration that is constant in the window. A free response
        has no input to check.
    """
    t = measurement.time_s
    start, end = (float(t[0]), float(t[-1])) if window is None else (float(window[0]), float(window[1]))
    where = f"measurement {measurement.name}"
    column = measurement.input_column
    if column is not None:
        values = measurement.input
        driven = values[t <= end + 1e-12]
        if column == "voltage_V":
            peak_voltage = float(np.max(np.abs(values)))
            if peak_voltage > MAX_ABS_VOLTAGE_V:
                raise BeamInputError(
                    f"{where}: |voltage_V| reaches {peak_voltage:.3g} V, above the {MAX_ABS_VOLTAGE_V:g} V a piezo "
                    "patch takes; is the column in volts?"
                )
        if not np.any(driven):
            raise BeamInputError(
                f"{where}: {column} is zero up to the end of the window ({end:g} s): the beam is never driven, "
                "so the model (at rest at the first sample) predicts no motion to calibrate against"
            )
    inside_mask = (t >= start - 1e-12) & (t <= end + 1e-12)
    if measurement.output_column != "displacement_m":
        inside = measurement.output[inside_mask]
        if inside.size == 0 or not float(np.std(inside)) > 0:
            raise BeamInputError(
                f"{where}: {measurement.output_column} is constant in the window {start:g}:{end:g} s: no motion was "
                "recorded"
            )
        return
    inside = measurement.displacement_m[inside_mask]
    length = measurement.geometry.length_m
    peak = float(np.max(np.abs(inside))) if inside.size else 0.0
    if peak > length:
        raise BeamInputError(
            f"{where}: |displacement_m| reaches {peak:.3g} m in the window, more than the beam's length "
            f"{length:g} m; is the column in metres?"
        )
    variation = float(np.std(inside)) if inside.size else 0.0
    if not variation > MIN_DISPLACEMENT_VARIATION_M:
        raise BeamInputError(
            f"{where}: displacement_m varies by {variation:.3g} m (standard deviation) in the window "
            f"{start:g}:{end:g} s, below the {MIN_DISPLACEMENT_VARIATION_M:g} m a sensor resolves: "
            "no motion was recorded"
        )
