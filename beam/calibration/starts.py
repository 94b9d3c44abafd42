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
4. **Screened design over the effects** (:func:`screened_design`) — an effect's parameters can
   have a narrow basin neither the prior centre nor the spectral start reaches (a hardening
   spring, a heavy patch): a scrambled Sobol design (:class:`scipy.stats.qmc.Sobol`, fixed seed)
   over every effect parameter's log prior range, plus each effect "barely on" (2 % of its log
   range from the end where it vanishes: the nested model's fit, whatever the other effects)
   while the others range over the design. Each design point gets its own EI from the spectral
   match of its own modal frequencies (one batched modal solve) and its k_p by least squares
   (the response is linear in k_p; one batched model call for the whole design); the
   :data:`DESIGN_KEPT` best, by residual RMS, are started.
5. **Nested starts** (:func:`nested_starts`) — for each effect of the model that changes its mass,
   stiffness or linearity (a pure damping effect only if the model without it still has such an
   effect: a model of damping effects alone has no new basin to offer, and the default model's
   preview stays one fit), the MAP of the model without it (found by this same strategy and the
   same two stages as every calibration, recursively; remembered per record, window, modes,
   likelihood and effect set, and shared with the previews and calibrations of that model, see
   :func:`submodel_map`) with that effect barely on. The model with the effect nests the model without it, so its MAP is then at least
   as good as every smaller model's, whatever the effects: under a gross misfit (a tip mass
   standing in for a missing patch) the residual RMS of a design point says little about where
   its search ends (measured on lab_run_1, 20 % window: the basin 18 nats above the engine's
   optimum was reached from design points ranked 37th-124th of 125 by RMS), and a superset of
   the true model (tip mass + patch) started from the design alone ended 877 nats below the
   patch-only optimum.

6. **Stratified design, searched** (:func:`stratified_design`, :func:`searched_design`) — for
   the effects that change the modes, a second scrambled Sobol design over EI *and* the effect
   parameters (full log prior ranges, k_p by least squares), of which the best point (residual
   RMS) in each cell of :data:`STRATA` x :data:`STRATA` bins of (log EI, log parameter), for
   each such parameter, is kept (up to 64 per parameter); all of them run
   :data:`SCREEN_ITERATIONS` lock-step Levenberg–Marquardt iterations together (one batched
   model call per iteration) and the :data:`SCREEN_KEPT` best ends are started. Ranking by RMS
   alone fails under a gross misfit (the MAP basin's points ranked 37th-124th), and the
   spectral EI of a design point is no guide there either (lab_run_1, 20 % window, tip mass
   without the patch: spectral EI 0.27-0.49 N m², the best basin at 0.56 with a 0.11 kg tip
   mass); one best point per (EI, parameter) cell keeps every region alive until a few
   iterations of search tell them apart; each point is also taken with EI from its own spectral
   match (on the ridge of equal frequencies, see :func:`stratified_design`). Measured on
   lab_run_1 at the 20 % window: the seven
   models with tip_mass or clamp_compliance but no patch that ended 15-34 nats below a 256-start
   reference now reach it. The cost, with the nested starts' sub-model fits (each with its own
   searched design), is seconds per preview with a mode-changing effect on a cold cache
   (lab_run_1, 0-1.05 s: + tip_mass 2-6 s, + patch_stiffening 5-16 s on a shared machine, from
   0.15-0.25 s); none for the default model, whose effects only damp. For the nonlinear spring
   the design is :data:`NONLINEAR_STRATA` x :data:`NONLINEAR_STRATA` cells (256 points, two
   forward simulations each) and k_p is scaled twice: the least-squares factor of the response
   at the prior centre's k_p, then again of the response at that scaled k_p. The hardening
   depends on the amplitude: at the prior centre's k_p (5x the amplitude of the lab records)
   a point's frequencies are not those it has at the data's amplitude, and the best basin,
   narrow along the effective frequency, was never kept (lab_run_1, 30 % window: clamp +
   spring ended 266 nats below it with 4 x 4 cells and one scaling, and so did 8 x 8 cells
   with one scaling even when all their points were searched to convergence; with the second
   scaling 5 x 5, 6 x 6 and 8 x 8 cells reach it, 4 x 4 do not; preview of + spring on
   lab_run_1, 0-1.05 s, 7 modes: 5.5 s before, 5.0 s after, on the loaded machine). Each
   scaling matches the response's RMS to the record's (the amplitude that sets the hardening),
   not the least-squares factor, which for a point off the record's frequencies is near zero and
   drove k_p to the prior's bottom, where the spring does nothing; and the spectral match of a
   spring point uses the frequencies the spring gives at the record's amplitude
   (:func:`equivalent_linear_omega2`), not the linear ones, which put a hardened first mode
   15-20 % low. On the 65 spring cases of the two global-mode samples (seeds 1 and 2): four
   MAPs 78-225 nats higher (lab_run_4 at 45 %, tip mass + spring: 225, to a 256-start search's
   optimum; two others now above their 256-start references), one 0.14 lower, CPU +5 %.

7. **Walk along the ridge** (:func:`ridge_walk`, in :func:`searched_map`, the second stage of
   every MAP) — along the ridge of equal frequencies a long window's optima can lie side by side
   a few percent of a parameter apart, each a few nats above the last (a washboard: the random
   clamp record of the global-mode sample, 45 % window, air damping + sensor mass: optima at 105,
   101, 97, 93 and 88 g, 10762.7 -> 10770.5 nats, 3.3 above a 256-start Sobol search). No design
   resolves them; a walk does: from the MAP, each mode-changing parameter is stepped by
   :data:`WALK_STEPS` of its log range each way, EI moved along the ridge (:func:`ridge_neighbours`),
   a lock-step search of :data:`WALK_ITERATIONS` iterations from the MAP and its neighbours,
   repeated from each better end (at most :data:`WALK_MAX_STEPS`), one Newton polish at the end.
   On the 98 cases of the global-mode sample (seed 1): 7 MAPs higher (by 0.3-7.8 nats), none
   lower by more than 0.01; three of the five misses now reach the benchmark's reference
   (random1 45 % air + sensor mass, 4.5 nats short before; lab_run_4 30 % air + patch, 1.4 ->
   0.7; lab_run_3 20 % clamp + spring + sensor mass, 2.5 short -> 0.1 above, though a seed-1
   Sobol search finds 11.5 nats more there); engine CPU 278.6 -> 290.4 s (+4 %); lab_run_1's
   nine diagnosis fits +3 % (six alternated runs, 14.2 -> 14.6 s mean; the same MAPs). Steps of
   0.5 % alone lost the spring's case; four steps (0.5-4 %) with 40 iterations and trust-region
   continuations cost ~1 s per walk and +11 % in that diagnosis; two steps and 10 iterations
   cost 0.1-0.2 s per walk that finds nothing.
   The two misses left are other basins, not neighbours: lab_run_4 20 % air + tip mass + clamp
   (the reference doubles EI with a softer clamp, 10 against 19 N m/rad) and random1 20 % tip
   mass + patch + modal damping (modes 3-4 damped away under a 12 g tip mass and a stiff patch:
   damped-away copies of the design reach it when searched to convergence, 7 of 284, but not
   through the race or the residual RMS; not kept).

8. **Upper modes damped away** (:func:`damped_away_starts`, with the searched design of a
   driven model with modal damping) — modal damping can damp a mode away (its ratio at the
   prior's top), so the model nests the model of its other effects on fewer modes, whose optimum
   need not follow the upper modes: for each count of kept modes, that smaller model's MAP (its
   own searched design) with the upper modes damped away is a start. On the random clamp record,
   20 % window, tip mass + patch + modal damping: 91 nats gained, to a 256-start search's
   optimum. On the 98 cases of the global-mode sample no MAP is lower; the 31 with modal damping
   cost 104 -> 156 s of CPU (the other 67: 186 -> 162 s, the machine's drift); lab_run_1,
   0-1.05 s, 8 modes, + patch stiffening + modal damping: 5.5 -> 10.1 s of CPU for both stages.

:func:`starting_points` is the one start strategy of every calibration (CLI, dashboard,
diagnosis candidates, ladder rungs): its starts depend only on the record, window, modes,
effects and likelihood.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from scipy.stats import qmc

from beam.calibration.fit import fast_map, internal_starts, levenberg_marquardt, newton_polish
from beam.calibration.setup import (
    BeamCalibrationSetup,
    DEFAULT_EFFECTS,
    BeamForwardModel,
    build_problem,
    prior_centre,
)
from beam.inference import MapResult, Problem
from beam.physics.model import BeamModel

#: Stiffness scale factors searched: a factor 5 either way of the prior centre.
SCALE_GRID = np.exp(np.linspace(np.log(0.2), np.log(5.0), 1201))
#: Fraction of the window used for the first, short MAP.
SHORT_WINDOW_FRACTION = 1.0 / 3.0
#: Points of the Sobol design over the effect parameters (a power of two), and how many of the
#: best are started.
DESIGN_POINTS = 128
DESIGN_KEPT = 3
#: Bins of each log range in the stratified screening (see :func:`screened_design`).
STRATA = 8
NONLINEAR_STRATA = 6
#: Bins of each mode-changing parameter's log range for the design points on the ridge of equal
#: frequencies of a linear model (see :func:`stratified_design`; a nonlinear model's: its strata).
RIDGE_BINS = 32
#: Lock-step iterations of the screening search over the stratified design, and how many of its
#: best distinct ends are kept as starts.
SCREEN_ITERATIONS = 8
SCREEN_KEPT = 4
#: The screening search is a race (successive halving): after RACE_ITERATIONS iterations only the
#: best RACE_FRACTION of the points (at least RACE_MIN_KEPT) go on (see :func:`searched_design`).
RACE_ITERATIONS = 2
RACE_FRACTION = 0.25
RACE_MIN_KEPT = 16
#: Smallest distance between two kept design points (max-norm, fraction of the log ranges).
DESIGN_SPREAD = 0.2
#: Where a "barely on" effect parameter sits: this fraction of its log prior range from the end
#: where the effect vanishes.
BARELY_ON = 0.02
#: The parameters of the base model (EI from the spectrum, k_p by least squares in the design).
BASE_NAMES = ("bending_stiffness_Nm2", "patch_coupling_NmV")


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


def _effect_names(setup: BeamCalibrationSetup) -> list[str]:
    return [name for name in setup.physical_names if name not in BASE_NAMES]


def _log_range(problem: Problem, name: str) -> tuple[float, float]:
    prior = problem.parameter(name).prior
    return float(np.log(prior.lower)), float(np.log(prior.upper))


def design_points(problem: Problem, setup: BeamCalibrationSetup, points: int = DESIGN_POINTS,
                  seed: int = 0) -> dict[str, np.ndarray]:
    """The design of the effect parameters (natural units, ``{name: (B,)}``): a scrambled Sobol
    design over their log prior ranges, then, for each effect, the same design with that
    effect barely on (see the module notes). Empty when the model has no effect parameter."""
    from beam.physics.effects import effect_of_parameter, parameter_spec

    names = _effect_names(setup)
    if not names:
        return {}
    ranges = np.array([_log_range(problem, n) for n in names])
    unit = qmc.Sobol(len(names), scramble=True, seed=seed).random(points)
    blocks = [unit]
    for effect in setup.effects:
        own = [i for i, n in enumerate(names) if effect_of_parameter(n) == effect]
        if not own:
            continue
        block = unit[: max(points // 4, 8)].copy()
        for i in own:
            block[:, i] = BARELY_ON if parameter_spec(names[i]).absent_at == "low" else 1.0 - BARELY_ON
        blocks.append(block)
    cube = np.vstack(blocks)
    logs = ranges[:, 0] + cube * (ranges[:, 1] - ranges[:, 0])
    return {n: np.exp(logs[:, i]) for i, n in enumerate(names)}


def screened_design(problem: Problem, setup: BeamCalibrationSetup, keep: int = DESIGN_KEPT,
                    points: int = DESIGN_POINTS, seed: int = 0) -> list[dict[str, float]]:
    """The ``keep`` best design points (natural units, physical parameters; see the module
    notes), each with its spectral EI and least-squares k_p, by residual RMS on the window."""
    design = design_points(problem, setup, points, seed)
    if not design:
        return []
    centres = prior_centres(setup)
    size = next(iter(design.values())).size
    batch = {name: np.full(size, centres[name]) for name in BASE_NAMES}
    batch.update(design)
    # each point twice: EI from its own spectral match, and EI at its prior centre (under a gross
    # misfit the spectral match can prefer a wrong family of peaks)
    spectral_ei = centres["bending_stiffness_Nm2"] * _batched_scales(setup, batch)
    batch = {name: np.concatenate([v, v]) for name, v in batch.items()}
    design = {name: np.concatenate([v, v]) for name, v in design.items()}
    batch["bending_stiffness_Nm2"][:size] = spectral_ei
    size *= 2
    batch = {name: np.clip(v, problem.parameter(name).prior.lower * (1 + 1e-9),
                           problem.parameter(name).prior.upper * (1 - 1e-9)) for name, v in batch.items()}
    nonlinear = setup.model.is_nonlinear
    if not nonlinear:
        batch["patch_coupling_NmV"] = np.ones(size)
    with np.errstate(all="ignore"):
        try:
            response = problem.predict(batch)
        except Exception:  # noqa: BLE001 - a design point outside any physical range: no design
            return []
    data = problem.data
    if nonlinear:
        fitted = response
    else:
        denominator = np.einsum("ij,ij->i", response, response)
        coupling = np.abs(response @ data) / np.where(denominator > 0, denominator, np.inf)
        prior = problem.parameter("patch_coupling_NmV").prior
        coupling = np.clip(coupling, prior.lower * (1 + 1e-9), prior.upper * (1 - 1e-9))
        batch["patch_coupling_NmV"] = coupling
        fitted = response * coupling[:, None]
    rms = np.sqrt(np.mean((data - fitted) ** 2, axis=1))
    rms[~np.isfinite(rms)] = np.inf
    # the best points, each at least DESIGN_SPREAD apart (max-norm, in log-range units) from
    # those already kept: near-duplicates would end in one basin
    names = list(design)
    cube = np.column_stack([(np.log(design[n]) - _log_range(problem, n)[0])
                            / np.ptp(_log_range(problem, n)) for n in names])
    kept: list[int] = []
    for i in np.argsort(rms, kind="stable"):
        if not np.isfinite(rms[i]) or len(kept) == keep:
            break
        if all(np.max(np.abs(cube[i] - cube[j])) >= DESIGN_SPREAD or
               abs(np.log(batch["bending_stiffness_Nm2"][i] / batch["bending_stiffness_Nm2"][j])) > 0.05 for j in kept):
            kept.append(int(i))
    return [{name: float(v[i]) for name, v in batch.items()} for i in kept]


def stratified_design(problem: Problem, setup: BeamCalibrationSetup, seed: int = 0) -> list[dict[str, float]]:
    """Design points over EI and the parameters of the effects that change the modes, the best
    (by residual RMS, k_p by least squares) in each cell of STRATA x STRATA bins of the log
    ranges of EI and of each such parameter (see the module notes).

    Each point is also taken with EI from the spectral match of its own modes
    (:func:`_batched_scales`): on the ridge of equal frequencies through the record's peaks,
    along which a long window's narrow basins lie and where a point's residual RMS tells basins
    apart; on the ridge EI follows the other parameters, so those copies are binned by each
    parameter alone (the best per bin; :data:`RIDGE_BINS` bins for a linear model: along the
    ridge a long window's basins lie side by side, each a few tenths of the parameter's log range
    wide — a random record with a hidden soft clamp, 45 % window, air damping + sensor mass: optima
    at a 49 g and a 98 g sensor mass 115 nats apart, in one of eight bins; with 32 bins the engine
    gained 110 nats there and 66 on tip mass + sensor mass, none of the 98 cases lower, for ~6 % more
    CPU in the diagnosis of lab_run_1; the spring's fits, whose design points cost two simulations
    each, keep their six). Measured on the 98 cases of the global-mode sample
    (seed 1) against the engine of the session before: 13 MAPs better (by up to 392 nats;
    lab_run_2, 45 % window, air + clamp: 2.8 nats, to within 0.3 of a 256-start reference),
    5 lower by at most 0.03 nats;
    engine CPU 330 -> 271 s (with the race; 248 s with the race alone). Half as many design
    points with their copies (the same 512 simulations as now without them: 231 s) did as well
    on the sample but left lab_run_1's gross misfits at the 20 % window (a tip mass for the
    missing patch) 18 nats short of a 256-start search (tests/test_calibration_starts.py)."""
    names = [n for n in _effect_names(setup) if not _pure_damping_parameter(n)]
    if not names:
        return []
    all_names = _effect_names(setup)
    dims = ["bending_stiffness_Nm2"] + all_names
    ranges = np.array([_log_range(problem, n) for n in dims])
    strata = STRATA if not setup.model.is_nonlinear else NONLINEAR_STRATA
    ridge_bins = RIDGE_BINS if not setup.model.is_nonlinear else strata
    points = 2 ** int(round(np.log2(8 * strata * strata)))  # ~8 per cell, a power of two (Sobol balance)
    cube = qmc.Sobol(len(dims), scramble=True, seed=seed + 1).random(points)
    logs = ranges[:, 0] + cube * (ranges[:, 1] - ranges[:, 0])
    batch = {n: np.exp(logs[:, i]) for i, n in enumerate(dims)}
    # each point twice: as drawn, and with EI from the spectral match of its own modes (on the
    # ridge of equal frequencies through the record's peaks, where a long window's narrow basins lie)
    centre_kp = prior_centre("patch_coupling_NmV", setup.measurement.nominal)
    scales = _batched_scales(setup, dict(batch, patch_coupling_NmV=np.full(points, centre_kp)))
    batch = {n: np.concatenate([v, v * scales if n == "bending_stiffness_Nm2" else v]) for n, v in batch.items()}
    cube = np.vstack([cube, cube])
    cube[points:, 0] = (np.log(batch["bending_stiffness_Nm2"][points:]) - ranges[0, 0]) / (ranges[0, 1] - ranges[0, 0])
    cube[:, 0] = np.clip(cube[:, 0], 0.0, 1.0 - 1e-12)
    batch = {name: np.clip(v, problem.parameter(name).prior.lower * (1 + 1e-9),
                           problem.parameter(name).prior.upper * (1 - 1e-9)) for name, v in batch.items()}
    fitted = coupled_response(problem, setup, batch)
    if fitted is None:
        return []
    data = problem.data
    rms = np.sqrt(np.mean((data - fitted) ** 2, axis=1))
    rms[~np.isfinite(rms)] = np.inf
    kept: list[int] = []
    stiffness_bin = np.minimum((cube[:, 0] * strata).astype(int), strata - 1)
    ridge = np.arange(rms.size) >= points  # the spectral copies
    for name in names:
        j = dims.index(name)
        cell = stiffness_bin * strata + np.minimum((cube[:, j] * strata).astype(int), strata - 1)
        # on the ridge EI follows the parameter: one cell per bin of the parameter alone
        cell = np.where(ridge, strata * strata + np.minimum((cube[:, j] * ridge_bins).astype(int), ridge_bins - 1), cell)
        for c in np.unique(cell):
            members = np.flatnonzero((cell == c) & np.isfinite(rms))
            if members.size:
                best = int(members[np.argmin(rms[members])])
                if best not in kept:
                    kept.append(best)
    return [{name: float(v[i]) for name, v in batch.items()} for i in kept]


def coupled_response(problem: Problem, setup: BeamCalibrationSetup, batch: dict[str, np.ndarray]) -> np.ndarray | None:
    """The response (B, n) of the design ``batch`` at its least-squares k_p (a nonlinear model:
    the k_p that gives the record's RMS), which is written into ``batch["patch_coupling_NmV"]``
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
    batch["patch_coupling_NmV"] = np.full(size, prior_centre("patch_coupling_NmV", setup.measurement.nominal)
                                          if nonlinear else 1.0)
    prior = problem.parameter("patch_coupling_NmV").prior
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
        batch["patch_coupling_NmV"] = np.clip(batch["patch_coupling_NmV"] * ratio,
                                              prior.lower * (1 + 1e-9), prior.upper * (1 - 1e-9))
        fitted = response * ratio[:, None]
    return fitted


def _damping_only(effect: str) -> bool:
    """Whether the effect only adds damping (it keeps the modes: no new basin)."""
    from beam.physics.effects import EFFECTS

    return all(term.target == "damping" for term in EFFECTS[effect].terms)


def _pure_damping_parameter(name: str) -> bool:
    """Whether the parameter's effect only adds damping (:func:`_damping_only`)."""
    from beam.physics.effects import effect_of_parameter

    return _damping_only(effect_of_parameter(name))


def equivalent_linear_omega2(setup: BeamCalibrationSetup, reduced: Mapping[str, np.ndarray],
                             cubic_N_m3: np.ndarray) -> np.ndarray:
    """Squared natural frequencies (B, m) (rad²/s²) of a model with the hardening tip spring,
    linearised at the window's amplitude (harmonic balance, the first mode dominant): the tip's
    amplitude A is sqrt(2) x the window's RMS displacement carried from the sensor to the tip by
    the first mode's shape; the cubic force k3 w³ then adds (3/4) k3 A² phi_1(L)² to the first
    mode and (3/2) k3 A² phi_j(L)² to each other mode (linearised about the first mode's
    oscillation; mass-normalised shapes, ``reduced`` of :meth:`BeamModel.reduced_system`).

    The record's peaks are where the spring puts the modes at that amplitude, not the linear
    frequencies: lab_run_4 (simulated with a 15,000 N/m³ spring), 45 % window, tip mass + spring,
    a 256-start search's optimum has linear frequencies 5.9, 38.7, 111, 222 Hz and these 7.17,
    38.9, 111, 222 Hz, against the record's peaks at 7.2, 38.9, 108 Hz."""
    data = setup.measurement.displacement_m[setup.window_mask]
    amplitude = np.sqrt(2.0) * float(np.std(data))
    tip, sensor = reduced["tip"], reduced["sensor"]
    with np.errstate(divide="ignore", invalid="ignore"):
        tip_amplitude = amplitude * np.abs(tip[:, 0] / sensor[:, 0])
    tip_amplitude = np.where(np.isfinite(tip_amplitude), tip_amplitude, 0.0)
    factor = np.full(tip.shape[1], 1.5)
    factor[0] = 0.75
    k3 = np.broadcast_to(np.asarray(cubic_N_m3, dtype=float), tip_amplitude.shape)
    return reduced["omega2"] + factor[None, :] * (k3 * tip_amplitude ** 2)[:, None] * tip ** 2


def _batched_scales(setup: BeamCalibrationSetup, batch: Mapping[str, np.ndarray]) -> np.ndarray:
    """The best spectral scale factor of EI (see :func:`stiffness_scales`) of every design point,
    from the undamped frequencies of its retained modes (one batched modal solve).

    The scaled frequency sqrt(s) f is a shift of log f by ½ log s, and :data:`SCALE_GRID` is
    uniform in log s: the log power is interpolated once on a log-frequency grid of half that
    step, and each point's score over the scale grid is a sum of shifted slices of it (a gather,
    not an interpolation per point, scale and mode: 0.15 s per design of 512 points before)."""
    reduced, _, _ = setup.model.reduced_system({k: np.asarray(v) for k, v in batch.items()}, setup.modes)
    omega2 = reduced["omega2"]
    if "tip_cubic_stiffness_N_m3" in batch:
        omega2 = equivalent_linear_omega2(setup, reduced, np.asarray(batch["tip_cubic_stiffness_N_m3"]))
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


#: Model optima kept by :func:`submodel_map` / :func:`remember_map` (least recently used dropped first).
SUBMODEL_CACHE_SIZE = 256
_SUBMODEL_CACHE: OrderedDict[tuple, MapResult] = OrderedDict()
_SUBMODEL_LOCK = threading.Lock()  # the diagnosis fits candidates in threads

#: Log-posterior gain (nats) by which the searched design's MAP must beat the quick stage's to
#: replace it: far below the 1 nat that tells optima apart, far above the search's tolerance,
#: so that the same basin keeps the quick stage's MAP exactly (the CLI's, the dashboard's preview's
#: and final's, the diagnosis's candidates' MAPs are then one; tests/dashboard/test_one_engine.py).
SEARCH_GAIN_NATS = 1e-3


def _record_key(setup: BeamCalibrationSetup) -> tuple:
    """What a sub-model's optimum depends on besides its effects."""
    m = setup.measurement
    digest = hashlib.blake2b(np.ascontiguousarray(m.displacement_m).tobytes(), digest_size=16)
    digest.update(np.ascontiguousarray(m.voltage_V).tobytes())
    digest.update(repr((m.geometry, sorted(m.nominal.items()), sorted(m.nominal_spread.items()), m.sample_interval_s,
                        float(m.time_s[0]))).encode())
    return digest.hexdigest(), tuple(setup.window), setup.modes, setup.likelihood


def _model_key(setup: BeamCalibrationSetup, effects: tuple[str, ...]) -> tuple:
    from beam.physics.effects import EFFECTS

    chosen = set(effects)
    return _record_key(setup) + (tuple(e for e in EFFECTS if e in chosen),)


def searched_map(problem: Problem, setup: BeamCalibrationSetup, quick: MapResult) -> MapResult | None:
    """The second stage of every beam MAP: the search from the searched stratified design
    (:func:`searched_starts`) together with the quick stage's MAP ``quick``, then the walk along
    the ridge of equal frequencies from the better of the two (:func:`ridge_walk`); the MAP
    reached when it beats ``quick`` by :data:`SEARCH_GAIN_NATS`, else None (``quick`` stands, to
    the last digit).

    None at once for a model that adds a pure damping effect (not the default damping) to one
    that changes the modes: the quick stage started it from that sub-model's MAP
    (:func:`nested_starts`), whose own searched design stratified the same mode-changing
    parameters; the damping moves no basin. Measured: lab_run_1's revealed model (patch
    stiffening + patch damping) 3.8 s cold, of which the redundant searched design took ~0.8 s.
    """
    if _adds_damping_to_a_searched_submodel(setup):
        return None
    best = quick
    extra = searched_starts(problem, setup)
    if extra:
        current = {name: float(v) for name, v in quick.values.items() if name in setup.physical_names}
        found = fast_map(problem, [current] + extra)
        if found.log_posterior > quick.log_posterior + SEARCH_GAIN_NATS:
            best = found
    best = ridge_walk(problem, setup, best) or best
    return best if best is not quick else None


#: Steps of the walk along the ridge of equal frequencies (fractions of a parameter's log prior
#: range, each way) and its most steps (see :func:`ridge_walk`).
WALK_STEPS = (0.005, 0.02)
WALK_MAX_STEPS = 8
#: Gain (nats) by which a step of the walk must beat the current optimum to go on: the
#: lock-step search's tolerance (:data:`beam.calibration.fit.LM_TOLERANCE`).
WALK_GAIN_NATS = 0.1
#: Lock-step iterations of each step of the walk (no trust-region continuation).
WALK_ITERATIONS = 10


def ridge_neighbours(problem: Problem, setup: BeamCalibrationSetup, best: Mapping[str, float]) -> list[dict[str, float]]:
    """Neighbours of ``best`` along the ridge of equal frequencies (natural units, physical
    parameters): each parameter of an effect that changes the modes moved by :data:`WALK_STEPS`
    of its log prior range each way, the others kept, EI moved by the ratio of the spectral
    scales (:func:`_batched_scales`) of the neighbour and of ``best`` (so the modes stay where
    ``best`` put them against the record's peaks), k_p by least squares."""
    names = [n for n in _effect_names(setup) if not _pure_damping_parameter(n)]
    rows = []
    for name in names:
        low, high = _log_range(problem, name)
        here = np.log(best[name])
        for step in WALK_STEPS:
            for sign in (1.0, -1.0):
                value = here + sign * step * (high - low)
                if low < value < high:
                    rows.append(dict(best, **{name: float(np.exp(value))}))
    if not rows:
        return []
    batch = {n: np.array([best[n]] + [r[n] for r in rows]) for n in setup.physical_names}
    scales = _batched_scales(setup, batch)
    batch["bending_stiffness_Nm2"] = batch["bending_stiffness_Nm2"] * scales / scales[0]
    batch = {name: np.clip(v, problem.parameter(name).prior.lower * (1 + 1e-9),
                           problem.parameter(name).prior.upper * (1 - 1e-9)) for name, v in batch.items()}
    if coupled_response(problem, setup, batch) is None:
        return []
    return [{n: float(v[i]) for n, v in batch.items()} for i in range(1, len(rows) + 1)]


def ridge_walk(problem: Problem, setup: BeamCalibrationSetup, found: MapResult) -> MapResult | None:
    """The MAP reached by walking from ``found`` along the ridge of equal frequencies: a lock-step
    search from the current optimum and its :func:`ridge_neighbours`, repeated from each end
    better by more than :data:`WALK_GAIN_NATS` (at most :data:`WALK_MAX_STEPS` times), then the
    Newton polish of the last; None when it ends no better than ``found`` by
    :data:`SEARCH_GAIN_NATS` (see the module notes)."""
    current = {name: float(found.values[name]) for name in setup.physical_names}
    level = found.log_posterior
    end = None
    for _ in range(WALK_MAX_STEPS):
        neighbours = ridge_neighbours(problem, setup, current)
        if not neighbours:
            break
        lm = levenberg_marquardt(problem, internal_starts(problem, [current] + neighbours), continuation=False,
                                 max_iterations=WALK_ITERATIONS)
        if not lm.log_posterior[lm.best] > level + WALK_GAIN_NATS:
            break
        end = (lm.z[lm.best], lm.fd_steps[lm.best])
        level = float(lm.log_posterior[lm.best])
        values = problem.from_internal(lm.z[lm.best])
        current = {name: float(values[name][0]) for name in setup.physical_names}
    if end is None:
        return None
    polished = newton_polish(problem, *end)
    polished = replace(polished, n_starts=found.n_starts, start_log_posteriors=found.start_log_posteriors)
    return polished if polished.log_posterior > found.log_posterior + SEARCH_GAIN_NATS else None


def has_second_stage(setup: BeamCalibrationSetup) -> bool:
    """Whether :func:`searched_map` can move the quick stage's MAP of this model: a driven model
    (a free response's starts are projected, see :mod:`beam.calibration.free_starts`) with an effect
    that changes the modes, not one that only adds damping to such a sub-model."""
    if "patch_coupling_NmV" not in setup.physical_names or _adds_damping_to_a_searched_submodel(setup):
        return False
    return any(not _pure_damping_parameter(name) for name in _effect_names(setup))


def _adds_damping_to_a_searched_submodel(setup: BeamCalibrationSetup) -> bool:
    """Whether the model has a pure damping effect besides the default damping and an effect that
    changes the modes (then :func:`nested_starts` starts it from the two-stage MAP of the model
    without that damping effect)."""
    extra_damping = any(_damping_only(e) and e not in DEFAULT_EFFECTS for e in setup.effects)
    return extra_damping and not all(_damping_only(e) for e in setup.effects)


def remember_map(setup: BeamCalibrationSetup, found: MapResult) -> None:
    """Keep the MAP ``found`` of the setup's model, found by the two stages of
    :func:`submodel_map` from the cold starts (a caller's warm start or extra guesses may end
    elsewhere: never remember those), for the nested starts of every larger model (the
    diagnosis's candidates, base + each effect, are the sub-models of the climb's fits) and for
    a later calibration of the same model (:func:`recall_map`)."""
    _keep(_SUBMODEL_CACHE, _model_key(setup, setup.effects), found)


def _keep(cache: OrderedDict, key: tuple, found: MapResult) -> None:
    """Put ``found`` in one of the MAP caches, the least recently used dropped past
    :data:`SUBMODEL_CACHE_SIZE`."""
    with _SUBMODEL_LOCK:
        cache[key] = found
        cache.move_to_end(key)
        while len(cache) > SUBMODEL_CACHE_SIZE:
            cache.popitem(last=False)


def forget_maps() -> None:
    """Drop every remembered MAP (benchmarks that time a cold calibration; tests)."""
    with _SUBMODEL_LOCK:
        _SUBMODEL_CACHE.clear()
        _FIRST_STAGE_CACHE.clear()


#: First-stage MAPs (:func:`remember_first_stage`), least recently used dropped first.
_FIRST_STAGE_CACHE: OrderedDict[tuple, MapResult] = OrderedDict()


def remember_first_stage(setup: BeamCalibrationSetup, found: MapResult) -> None:
    """Keep the MAP of the first stage of a cold calibration of the setup's model (the quick search
    from :func:`starting_points` without the search; a screening fit's MAP): the second stage of a
    later calibration of the model starts from it instead of repeating the first (the same starts,
    the same MAP: they depend only on the record, window, modes, likelihood, effects and the
    sub-models' MAPs). Not the model's MAP (:func:`recall_map`)."""
    _keep(_FIRST_STAGE_CACHE, _model_key(setup, setup.effects), found)


def recall_first_stage(setup: BeamCalibrationSetup) -> MapResult | None:
    """The remembered first-stage MAP of the setup's model (:func:`remember_first_stage`), or None."""
    with _SUBMODEL_LOCK:
        return _FIRST_STAGE_CACHE.get(_model_key(setup, setup.effects))


def recall_map(setup: BeamCalibrationSetup) -> MapResult | None:
    """The remembered MAP of the setup's own model (:func:`remember_map`), or None."""
    key = _model_key(setup, setup.effects)
    with _SUBMODEL_LOCK:
        cached = _SUBMODEL_CACHE.get(key)
        if cached is not None:
            _SUBMODEL_CACHE.move_to_end(key)
        return cached


def submodel_map(setup: BeamCalibrationSetup, effects: tuple[str, ...]) -> dict[str, float]:
    """Physical parameters (natural units) of the MAP of the model with ``effects`` on the
    setup's record and window: the same two stages as every calibration (the quick stage from
    :func:`starting_points` without the search, recursively nested, then :func:`searched_map`),
    so the value is the MAP :func:`beam.calibration.run.calibration_preview` finds for that
    model. Cached (see :data:`SUBMODEL_CACHE_SIZE`) and shared with the previews and
    calibrations (:func:`remember_map`): the dashboard, the diagnosis and the ladder reuse it.

    Measured on lab_run_1 (7 modes, 0-1.05 s): a climb fit (base + patch stiffening + clamp
    compliance) spent 2.6 s of its 5.6 s refitting the two sub-models the diagnosis's ranking
    had just fitted (when the sub-models were found to the coarse tolerance by a search of
    their own, not shared with the previews)."""
    key = _model_key(setup, effects)
    with _SUBMODEL_LOCK:
        cached = _SUBMODEL_CACHE.get(key)
        if cached is not None:
            _SUBMODEL_CACHE.move_to_end(key)
            return {name: float(v) for name, v in cached.values.items()}  # extra (noise) names: ignored by callers
    sub = _model_setup(setup, effects, setup.modes)
    problem = build_problem(sub)
    quick = fast_map(problem, starting_points(problem, sub, search=False))
    best = searched_map(problem, sub, quick) or quick
    remember_map(sub, best)
    return {name: float(best.values[name]) for name in sub.physical_names}


def barely_on(problem: Problem, name: str) -> float:
    """A parameter's value :data:`BARELY_ON` of its log prior range from the end where its
    effect vanishes (natural units)."""
    from beam.physics.effects import parameter_spec

    low, high = _log_range(problem, name)
    fraction = BARELY_ON if parameter_spec(name).absent_at == "low" else 1.0 - BARELY_ON
    return float(np.exp(low + fraction * (high - low)))


def nested_starts(problem: Problem, setup: BeamCalibrationSetup) -> list[dict[str, float]]:
    """For each effect of the model, the optimum of the model without it (:func:`submodel_map`)
    with that effect barely on (see the module notes); a pure damping effect only when the
    model without it still has an effect that changes the modes (whose optimum may lie in a
    basin no design point of the model with it reaches: lab_run_1, 30 % window, clamp
    compliance + patch damping ended 9 nats below the clamp-only optimum), and never the default
    damping (air, Kelvin-Voigt), which every model has: dropping it only made each preview fit
    its sub-models recursively (lab_run_1, 7 modes, + patch stiffening: 6.2 s, 4.5 s of it in
    sub-model fits)."""
    out = []
    for effect in setup.effects:
        if _damping_only(effect) and (effect in DEFAULT_EFFECTS
                                      or all(_damping_only(e) for e in setup.effects if e != effect)):
            continue  # the default damping is in every model: dropping it finds no new basin
        values = submodel_map(setup, tuple(e for e in setup.effects if e != effect))
        guess = {name: values.get(name, barely_on(problem, name)) for name in setup.physical_names}
        out.append(_clip_to_prior(problem, guess))
    return out


def searched_design(problem: Problem, guesses: list[dict[str, float]], keep: int = SCREEN_KEPT,
                    iterations: int = SCREEN_ITERATIONS) -> list[dict[str, float]]:
    """The ends of a short lock-step search (:data:`SCREEN_ITERATIONS` iterations, no
    continuation) from ``guesses``: the ``keep`` best distinct ends (natural units, physical
    parameters).

    A race: after :data:`RACE_ITERATIONS` iterations only the best :data:`RACE_FRACTION` of the
    points (at least :data:`RACE_MIN_KEPT`) go on. Two iterations already tell the basins apart
    far better than the design's residual RMS: on lab_run_1 (0-1.05 s, 7 modes; patch
    stiffening, tip mass, and each of tip mass and clamp compliance on top of patch stiffening;
    64-112 points) the four best ends of the full eight iterations ranked 0th-12th after two.
    The search costs 2 + 6/4 = 3.5 point-iterations per point instead of 8."""
    starts = internal_starts(problem, guesses)
    kept = max(RACE_MIN_KEPT, int(np.ceil(RACE_FRACTION * starts.shape[0])))
    result = levenberg_marquardt(problem, starts, max_iterations=iterations, continuation=False,
                                 race=(RACE_ITERATIONS, kept))
    order = [int(i) for i in np.argsort(-result.log_posterior, kind="stable")
             if np.isfinite(result.log_posterior[i]) and not result.dropped[i]]
    out = []
    for i in order[:keep]:
        values = problem.from_internal(result.z[i])
        out.append({name: float(v[0]) for name, v in values.items() if name not in problem.noise_names})
    return out


def searched_starts(problem: Problem, setup: BeamCalibrationSetup) -> list[dict[str, float]]:
    """The ends of the searched stratified design (step 6 of the module notes; empty for a model
    whose effects only damp), then, with modal damping, the damped-away starts
    (:func:`damped_away_starts`, step 8)."""
    strata = stratified_design(problem, setup)
    return (searched_design(problem, strata) if strata else []) + damped_away_starts(problem, setup)


#: Where a damped-away mode's damping ratio starts: this fraction of its log prior range from the
#: top (as :data:`BARELY_ON` from the other end).
DAMPED_AWAY = 0.02


def _model_setup(setup: BeamCalibrationSetup, effects: tuple[str, ...], modes: int) -> BeamCalibrationSetup:
    """The setup of the model with ``effects`` and ``modes`` retained modes on the same record,
    window and likelihood."""
    model = BeamModel(setup.measurement.geometry, effects, setup.model.intervals)
    return BeamCalibrationSetup(setup.measurement, setup.window, model.effects, modes, setup.likelihood, model,
                                BeamForwardModel(model, setup.measurement, modes))


def damped_away_starts(problem: Problem, setup: BeamCalibrationSetup) -> list[dict[str, float]]:
    """Starts of a driven model with modal damping that damp its upper modes away (step 8 of the
    module notes): for each count ``k`` of kept modes below the retained ``M``, the MAP of the
    model without modal damping on its first ``k`` modes only (its searched stratified design
    and spectral starts, one lock-step search), with the damping ratios of modes ``k+1..M``
    :data:`DAMPED_AWAY` of their log range from the top and those of modes ``1..k`` barely on.

    With modal damping the model nests the model of its other effects with fewer modes (a mode
    damped at the prior's top adds almost nothing), and a fit that need not follow the upper
    modes can put the lower ones elsewhere: the random clamp record of the global-mode sample,
    20 % window, tip mass + patch stiffening + modal damping (4 modes), whose best optimum damps
    modes 3-4 away under a 12 g tip mass and a stiff patch, 91 nats above the engine's MAP
    without these starts, which followed all four modes with a 1.3 g tip mass and no patch; the
    2-mode fit reaches it, the 1- and 3-mode fits do not, and the upper modes' frequencies do
    not say which ``k`` (the engine's MAP put modes 3-4 within 1 % of the record's peaks), so
    every ``k`` is tried. Damped-away copies of the design points of the full model reach it
    only when searched to convergence (7 of 284 points), not through the race. Cost: one
    searched design of a smaller model per ``k`` (0.7-0.9 s each on that record, 4 modes)."""
    if "modal_damping" not in setup.effects or "patch_coupling_NmV" not in setup.physical_names or setup.modes < 2:
        return []
    others = tuple(e for e in setup.effects if e != "modal_damping")
    ratios = [n for n in setup.physical_names if n.startswith("damping_ratio_mode_")]
    out = []
    for kept in range(1, setup.modes):
        sub = _model_setup(setup, others, kept)
        sub_problem = build_problem(sub)
        found = fast_map(sub_problem, spectral_guesses(sub_problem, sub) + searched_starts(sub_problem, sub))
        guess = {name: float(found.values[name]) for name in sub.physical_names}
        for name in ratios:
            low, high = _log_range(problem, name)
            away = int(name.rsplit("_", 1)[1]) > kept
            guess[name] = float(np.exp(high - DAMPED_AWAY * (high - low))) if away else barely_on(problem, name)
        out.append(_clip_to_prior(problem, guess))
    return out


def starting_points(problem: Problem, setup: BeamCalibrationSetup,
                    warm: Mapping[str, float] | None = None, search: bool = True) -> list[dict[str, float]]:
    """The start strategy of every beam calibration (natural units, physical parameters): the
    short-window MAP (or a caller's ``warm`` start in its place), the spectral starts, the
    nested starts, the screened design over the effects and, with ``search``, the searched
    stratified design (see the module notes). Without ``search`` (the first, quick stage of
    :func:`beam.calibration.run.calibration_stream`) the caller adds :func:`searched_starts`
    later."""
    spectral = spectral_guesses(problem, setup)
    nested = nested_starts(problem, setup)
    design = screened_design(problem, setup)
    if search and not _adds_damping_to_a_searched_submodel(setup):  # see searched_map
        design = design + searched_starts(problem, setup)
    if warm is not None:
        return [dict(warm)] + nested + spectral + design
    short = _short_window_problem(setup)
    if short is None:
        return nested + spectral + design
    refined = levenberg_marquardt(short, internal_starts(short, spectral + design), continuation=False)
    values = short.from_internal(refined.z[refined.best])
    start = {name: float(v[0]) for name, v in values.items() if name not in short.noise_names}
    return [start] + nested + spectral + design
