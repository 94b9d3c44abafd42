"""Spectral starts: EI scaled so the model's modes sit on the window's spectral peaks, k_p by least
squares (:class:`SpectralStarts`), and the short-window refinement of the other starts
(:class:`ShortWindowStart`). Frequencies scale as sqrt(EI)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from beam.calibration.fit import internal_starts, levenberg_marquardt
from beam.calibration.setup import BeamCalibrationSetup, build_problem, prior_centre
from beam.calibration.starts.base import SCALE_GRID, StartStrategy, clip_inside_prior, prior_centres
from beam.inference import Problem
from beam.physics.effects import EFFECTS
from beam.physics.effects.base import BENDING_STIFFNESS, PATCH_COUPLING

__all__ = ["SHORT_WINDOW_FRACTION", "ShortWindowStart", "SpectralStarts", "batched_scales", "coupled_response",
           "equivalent_linear_omega2", "least_squares_coupling", "short_window_problem", "spectral_guesses",
           "stiffness_scales", "window_spectrum"]

#: The base parameters: EI (scaled to the spectrum) and k_p (solved for by least squares).
EI, KP = BENDING_STIFFNESS.name, PATCH_COUPLING.name


#: Fraction of the window used for the first, short MAP.
SHORT_WINDOW_FRACTION = 1.0 / 3.0


def window_spectrum(setup: BeamCalibrationSetup) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and Hann-windowed periodogram of the window's displacement (zero-padded x8)."""
    data = setup.measurement.displacement_m[setup.window_mask]
    data = data - data.mean()
    taper = np.hanning(data.size)
    n_fft = 8 * int(2 ** np.ceil(np.log2(data.size)))
    power = np.abs(np.fft.rfft(data * taper, n_fft)) ** 2
    return np.fft.rfftfreq(n_fft, setup.measurement.sample_interval_s), power


def stiffness_scales(setup: BeamCalibrationSetup, centres: Mapping[str, float], count: int = 2) -> list[float]:
    """The ``count`` best separated scale factors s of EI (see the module notes)."""
    model_frequencies, _ = setup.model.natural_modes(centres, setup.modes)
    frequencies, power = window_spectrum(setup)
    nyquist = frequencies[-1]
    usable = model_frequencies[(model_frequencies > 0) & (model_frequencies < 0.8 * nyquist)]
    if usable.size == 0:
        return [1.0]
    floor = power.max() * 1e-12 + 1e-300
    scaled = np.sqrt(SCALE_GRID)[:, None] * usable[None, :]
    inside = scaled < 0.95 * nyquist
    log_power = np.log(np.interp(scaled, frequencies, power) + floor)
    score = np.where(inside, log_power, np.log(floor)).sum(axis=1)
    peaks = [i for i in range(1, SCALE_GRID.size - 1) if score[i] >= score[i - 1] and score[i] >= score[i + 1]]
    peaks.sort(key=lambda i: -score[i])
    chosen: list[float] = []
    for i in peaks:
        if all(abs(np.log(SCALE_GRID[i] / s)) > 0.05 for s in chosen):
            chosen.append(float(SCALE_GRID[i]))
        if len(chosen) == count:
            break
    return chosen or [1.0]


def least_squares_coupling(setup: BeamCalibrationSetup, values: Mapping[str, float], problem: Problem) -> float:
    """k_p minimising the window's squared error with the other parameters fixed."""
    unit = dict(values, **{KP: 1.0})
    response = problem.predict({k: np.atleast_1d(v) for k, v in unit.items()})[0]
    denominator = float(response @ response)
    if denominator <= 0:
        return float(values[KP])
    return abs(float(response @ problem.data) / denominator)


def spectral_guesses(problem: Problem, setup: BeamCalibrationSetup) -> list[dict[str, float]]:
    """Spectral starting points (see the module notes; natural units, physical parameters
    only): the prior centres with EI scaled to match the periodogram and k_p by least squares."""
    centres = prior_centres(setup)
    spectral = []
    for scale in stiffness_scales(setup, centres):
        guess = dict(centres, **{EI: centres[EI] * scale})
        guess[KP] = least_squares_coupling(setup, guess, problem)
        spectral.append(clip_inside_prior(problem, guess))
    return spectral


def short_window_problem(setup: BeamCalibrationSetup) -> Problem | None:
    """The same problem on the first third of the window, if that still holds two periods."""
    start, end = setup.window
    short_end = start + SHORT_WINDOW_FRACTION * (end - start)
    frequencies, _ = setup.model.natural_modes(prior_centres(setup), 1)
    mask = (setup.measurement.time_s >= start) & (setup.measurement.time_s <= short_end)
    if frequencies[0] <= 0 or short_end - start < 2.0 / frequencies[0] or mask.sum() < 50:
        return None
    return build_problem(replace(setup, spec=replace(setup.spec, window=(start, short_end))))


def equivalent_linear_omega2(setup: BeamCalibrationSetup, reduced: Mapping[str, np.ndarray],
                             values: Mapping[str, np.ndarray]) -> np.ndarray:
    """Squared natural frequencies (B, m) (rad²/s²) the record's spectral peaks show: the
    retained modes' (``reduced`` of :meth:`BeamModel.reduced_system`) as each effect with a
    spectral hint (:attr:`~beam.physics.effects.effect.StartHints.spectral`, the hardening tip
    spring's linearised at the amplitude) moves them at the window's displacement amplitude
    (sqrt(2) x its RMS), for the design ``values`` ((B,) arrays by name)."""
    omega2 = reduced["omega2"]
    hints = [EFFECTS[e].hints.spectral for e in setup.effects if EFFECTS[e].hints.spectral is not None
             and all(name in values for name in EFFECTS[e].required_parameter_names)]
    if hints:
        data = setup.measurement.displacement_m[setup.window_mask]
        amplitude = np.sqrt(2.0) * float(np.std(data))
        for hint in hints:
            omega2 = hint(dict(reduced, omega2=omega2), amplitude, values)
    return omega2


def batched_scales(setup: BeamCalibrationSetup, batch: Mapping[str, np.ndarray]) -> np.ndarray:
    """The best spectral scale factor of EI (see :func:`stiffness_scales`) of every design point,
    from the undamped frequencies of its retained modes (one batched modal solve).

    The scaled frequency sqrt(s) f is a shift of log f by ½ log s, and :data:`SCALE_GRID` is
    uniform in log s: the log power is interpolated once on a log-frequency grid of half that
    step, and each point's score over the scale grid is a sum of shifted slices of it (a gather,
    not an interpolation per point, scale and mode: 0.15 s per design of 512 points before)."""
    reduced, _, _ = setup.model.reduced_system({k: np.asarray(v) for k, v in batch.items()}, setup.modes)
    omega2 = equivalent_linear_omega2(setup, reduced, {k: np.asarray(v) for k, v in batch.items()})
    model_frequencies = np.sqrt(np.maximum(omega2, 0.0)) / (2 * np.pi)  # (B, m)
    frequencies, power = window_spectrum(setup)
    nyquist = frequencies[-1]
    floor = power.max() * 1e-12 + 1e-300
    usable = (model_frequencies > 0) & (model_frequencies < 0.8 * nyquist)
    if not usable.any():
        return np.ones(model_frequencies.shape[0])
    step = 0.5 * np.log(SCALE_GRID[1] / SCALE_GRID[0])  # of log f per grid step of log s
    half_span = 0.5 * np.log(SCALE_GRID[-1])  # log sqrt(5): the grid is symmetric about s = 1
    log_f = np.log(np.where(usable, model_frequencies, 1.0))
    lowest = log_f[usable].min() - half_span
    size = int(np.ceil((log_f[usable].max() + half_span - lowest) / step)) + 2
    grid = np.exp(lowest + step * np.arange(size))
    log_power = np.where(grid < 0.95 * nyquist, np.log(np.interp(grid, frequencies, power) + floor), np.log(floor))
    first = np.rint((log_f - half_span - lowest) / step).astype(int)  # (B, m): grid index at s = SCALE_GRID[0]
    first = np.clip(first, 0, size - SCALE_GRID.size)
    # each mode's slice is a row of the sliding windows of the log power (a row gather, not an
    # index array of B x S x m: 80 -> 33 ms for 1,024 points of 8 modes); an unusable mode reads
    # a block of floor values appended to it; the (B, S, m) array summed is the same as before
    padded = np.concatenate([log_power, np.full(SCALE_GRID.size, np.log(floor))])
    windows = np.lib.stride_tricks.sliding_window_view(padded, SCALE_GRID.size)  # (size + 1, S)
    shifted = windows[np.where(usable, first, size)]  # (B, m, S)
    score = np.ascontiguousarray(np.swapaxes(shifted, 1, 2)).sum(axis=2)  # (B, S)
    return SCALE_GRID[np.argmax(score, axis=1)]


def coupled_response(problem: Problem, setup: BeamCalibrationSetup, batch: dict[str, np.ndarray]) -> np.ndarray | None:
    """The response (B, n) of the design ``batch`` at its least-squares k_p (a nonlinear model:
    the k_p that gives the record's RMS), which is written into ``batch`` (``patch_coupling_NmV``)
    (clipped to its prior); None when the batch cannot be simulated.

    Exact for a linear model (the response is linear in k_p: one batched call at k_p = 1). For
    a nonlinear one the response at the prior centre's k_p is scaled, then simulated again at
    that k_p and scaled again: the hardening depends on the amplitude, hence on k_p, and at the
    prior centre's k_p (5x the amplitude of the lab records) a point's frequencies are not those
    it has at the data's amplitude (measured on lab_run_1, 30 % window, clamp + spring: the
    searched design missed the best basin by 266 nats with the one scaling). A nonlinear
    point's scaling matches its response's RMS to the record's, not its least-squares factor
    (module notes, step 6)."""
    nonlinear = setup.model.is_nonlinear
    size = next(iter(batch.values())).size
    batch[KP] = np.full(size, prior_centre(KP, setup.measurement.nominal)
                                          if nonlinear else 1.0)
    prior = problem.parameter(KP).prior
    fitted = None
    for _ in range(2 if nonlinear else 1):
        with np.errstate(all="ignore"):
            try:
                response = problem.predict(batch)
            except Exception:  # noqa: BLE001 - a design point outside any physical range: keep what we have
                break
            denominator = np.einsum("ij,ij->i", response, response)
            if nonlinear:  # the data's amplitude, which sets the hardening
                ratio = np.sqrt(float(problem.data @ problem.data) / np.where(denominator > 0, denominator, np.inf))
            else:
                ratio = np.abs(response @ problem.data) / np.where(denominator > 0, denominator, np.inf)
        batch[KP] = np.clip(batch[KP] * ratio,
                                              prior.lower * (1 + 1e-9), prior.upper * (1 - 1e-9))
        fitted = response * ratio[:, None]
    return fitted


class SpectralStarts(StartStrategy):
    """The spectral starts (:func:`spectral_guesses`)."""

    name = "spectral"

    def __call__(self, problem, setup, engine):
        return spectral_guesses(problem, setup)


class ShortWindowStart:
    """The MAP on the first :data:`SHORT_WINDOW_FRACTION` of the window from the other starts (where a
    phase error has had little time to accumulate), to the lock-step search's coarse tolerance: the
    first start of the whole window's search; none when that part holds fewer than two periods."""

    name = "short window"

    def __call__(self, setup: BeamCalibrationSetup, starts: list[dict[str, float]]) -> list[dict[str, float]]:
        short = short_window_problem(setup)
        if short is None:
            return []
        refined = levenberg_marquardt(short, internal_starts(short, starts), continuation=False)
        values = short.from_internal(refined.z[refined.best])
        return [{name: float(v[0]) for name, v in values.items() if name not in short.noise_names}]
