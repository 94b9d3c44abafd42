"""Starting points for the beam MAP that survive the multimodality of oscillation fitting.

An oscillator fitted from a frequency a few percent off on a long window converges to a wrong
local optimum (each cycle of phase error is a new basin). So:

1. **Spectral matching** — the periodogram of the window's displacement peaks at the excited
   natural frequencies. The model's modal frequencies at the prior centres, scaled by sqrt(s)
   (frequencies scale as sqrt(EI)), are matched to the peaks: s maximises the summed log power
   of the data at the scaled frequencies of the retained modes below 0.8 x Nyquist. EI starts at
   s x its centre; the two best separated maxima are both tried.
2. **Linear coupling** — the response is linear in k_p: its least-squares value given the rest.
3. **Growing window** — a MAP on the first third of the window (where a phase error has had
   little time to accumulate) is the start of the MAP on the whole window. It is found by the
   lock-step Levenberg–Marquardt of :mod:`beam.calibration.fit` from both spectral starts at
   once, to its coarse tolerance (a start needs no Newton polish).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from beam.calibration.fit import internal_starts, levenberg_marquardt
from beam.calibration.setup import BeamCalibrationSetup, build_problem, prior_centre
from beam.inference import Problem

#: Stiffness scale factors searched: a factor 5 either way of the prior centre.
SCALE_GRID = np.exp(np.linspace(np.log(0.2), np.log(5.0), 1201))
#: Fraction of the window used for the first, short MAP.
SHORT_WINDOW_FRACTION = 1.0 / 3.0


def prior_centres(setup: BeamCalibrationSetup) -> dict[str, float]:
    """Every physical parameter at its prior centre."""
    return {name: prior_centre(name, setup.measurement.nominal) for name in setup.physical_names}


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
    unit = dict(values, patch_coupling_NmV=1.0)
    response = problem.predict({k: np.atleast_1d(v) for k, v in unit.items()})[0]
    denominator = float(response @ response)
    if denominator <= 0:
        return float(values["patch_coupling_NmV"])
    return abs(float(response @ problem.data) / denominator)


def spectral_guesses(problem: Problem, setup: BeamCalibrationSetup) -> list[dict[str, float]]:
    """Spectral starting points (see the module notes; natural units, physical parameters
    only): the prior centres with EI scaled to match the periodogram and k_p by least squares."""
    centres = prior_centres(setup)
    spectral = []
    for scale in stiffness_scales(setup, centres):
        guess = dict(centres, bending_stiffness_Nm2=centres["bending_stiffness_Nm2"] * scale)
        guess["patch_coupling_NmV"] = least_squares_coupling(setup, guess, problem)
        spectral.append(_clip_to_prior(problem, guess))
    return spectral


def initial_guesses(problem: Problem, setup: BeamCalibrationSetup) -> list[dict[str, float]]:
    """Starting points for the MAP search on the whole window: the short-window MAP first,
    then the spectral starts (natural units, physical parameters only)."""
    spectral = spectral_guesses(problem, setup)
    short = _short_window_problem(setup)
    if short is None:
        return spectral
    refined = levenberg_marquardt(short, internal_starts(short, spectral))
    values = short.from_internal(refined.z[refined.best])
    start = {name: float(v[0]) for name, v in values.items() if name not in short.noise_names}
    return [start] + spectral


def _short_window_problem(setup: BeamCalibrationSetup) -> Problem | None:
    """The same problem on the first third of the window, if that still holds two periods."""
    start, end = setup.window
    short_end = start + SHORT_WINDOW_FRACTION * (end - start)
    frequencies, _ = setup.model.natural_modes(prior_centres(setup), 1)
    mask = (setup.measurement.time_s >= start) & (setup.measurement.time_s <= short_end)
    if frequencies[0] <= 0 or short_end - start < 2.0 / frequencies[0] or mask.sum() < 50:
        return None
    short_setup = BeamCalibrationSetup(
        setup.measurement, (start, short_end), setup.effects, setup.modes, setup.likelihood, setup.model, setup.forward
    )
    return build_problem(short_setup)


def _clip_to_prior(problem: Problem, guess: dict[str, float]) -> dict[str, float]:
    out = {}
    for name, value in guess.items():
        prior = problem.parameter(name).prior
        out[name] = float(np.clip(value, prior.lower * (1 + 1e-9), prior.upper * (1 - 1e-9)))
    return out
