"""Designs over the effect parameters: the screened Sobol design (:class:`ScreenedDesign`) and the
stratified design over EI and the mode-changing parameters, searched by a short lock-step race
(:func:`searched_design`). Fixed seeds: the same starts for the same record, window and model."""

from __future__ import annotations

import numpy as np
from scipy.stats import qmc

from beam.calibration.fit import internal_starts, levenberg_marquardt
from beam.calibration.setup import BeamCalibrationSetup, prior_centre
from beam.calibration.starts.base import (
    BARELY_ON,
    BASE_NAMES,
    StartStrategy,
    effect_names,
    log_range,
    prior_centres,
    pure_damping_parameter,
)
from beam.calibration.starts.spectral import batched_scales, coupled_response
from beam.inference import Problem
from beam.physics.effects.base import BENDING_STIFFNESS, PATCH_COUPLING


__all__ = ["DESIGN_KEPT", "DESIGN_POINTS", "DESIGN_SPREAD", "NONLINEAR_STRATA", "RACE_FRACTION", "RACE_ITERATIONS",
           "RACE_MIN_KEPT", "RIDGE_BINS", "SCREEN_ITERATIONS", "SCREEN_KEPT", "STRATA", "ScreenedDesign", "design_points",
           "screened_design", "searched_design", "stratified_design"]

#: The base parameters: EI (scaled to the spectrum) and k_p (solved for by least squares).
EI, KP = BENDING_STIFFNESS.name, PATCH_COUPLING.name


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


def design_points(problem: Problem, setup: BeamCalibrationSetup, points: int = DESIGN_POINTS,
                  seed: int = 0) -> dict[str, np.ndarray]:
    """The design of the effect parameters (natural units, ``{name: (B,)}``): a scrambled Sobol
    design over their log prior ranges, then, for each effect, the same design with that
    effect barely on (see the module notes). Empty when the model has no effect parameter."""
    from beam.physics.effects import effect_of_parameter, parameter_spec

    names = effect_names(setup)
    if not names:
        return {}
    ranges = np.array([log_range(problem, n) for n in names])
    unit = qmc.Sobol(len(names), scramble=True, seed=seed).random(points)
    blocks = [unit]
    for effect in setup.effects:
        own = [i for i, n in enumerate(names) if effect_of_parameter(n) == effect]
        if not own:
            continue
        block = unit[: max(points // 4, 8)].copy()
        for i in own:
            block[:, i] = {"low": BARELY_ON, "high": 1.0 - BARELY_ON}.get(parameter_spec(names[i]).absent_at, 0.5)
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
    spectral_ei = centres[EI] * batched_scales(setup, batch)
    batch = {name: np.concatenate([v, v]) for name, v in batch.items()}
    design = {name: np.concatenate([v, v]) for name, v in design.items()}
    batch[EI][:size] = spectral_ei
    size *= 2
    batch = {name: np.clip(v, problem.parameter(name).prior.lower * (1 + 1e-9),
                           problem.parameter(name).prior.upper * (1 - 1e-9)) for name, v in batch.items()}
    nonlinear = setup.model.is_nonlinear
    if not nonlinear:
        batch[KP] = np.ones(size)
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
        prior = problem.parameter(KP).prior
        coupling = np.clip(coupling, prior.lower * (1 + 1e-9), prior.upper * (1 - 1e-9))
        batch[KP] = coupling
        fitted = response * coupling[:, None]
    rms = np.sqrt(np.mean((data - fitted) ** 2, axis=1))
    rms[~np.isfinite(rms)] = np.inf
    # the best points, each at least DESIGN_SPREAD apart (max-norm, in log-range units) from
    # those already kept: near-duplicates would end in one basin
    names = list(design)
    cube = np.column_stack([(np.log(design[n]) - log_range(problem, n)[0])
                            / np.ptp(log_range(problem, n)) for n in names])
    kept: list[int] = []
    for i in np.argsort(rms, kind="stable"):
        if not np.isfinite(rms[i]) or len(kept) == keep:
            break
        if all(np.max(np.abs(cube[i] - cube[j])) >= DESIGN_SPREAD or
               abs(np.log(batch[EI][i] / batch[EI][j])) > 0.05 for j in kept):
            kept.append(int(i))
    return [{name: float(v[i]) for name, v in batch.items()} for i in kept]


def stratified_design(problem: Problem, setup: BeamCalibrationSetup, seed: int = 0) -> list[dict[str, float]]:
    """Design points over EI and the parameters of the effects that change the modes, the best
    (by residual RMS, k_p by least squares) in each cell of STRATA x STRATA bins of the log
    ranges of EI and of each such parameter (see the module notes).

    Each point is also taken with EI from the spectral match of its own modes
    (:func:`batched_scales`): on the ridge of equal frequencies through the record's peaks,
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
    names = [n for n in effect_names(setup) if not pure_damping_parameter(n)]
    if not names:
        return []
    all_names = effect_names(setup)
    dims = [EI] + all_names
    ranges = np.array([log_range(problem, n) for n in dims])
    strata = STRATA if not setup.model.is_nonlinear else NONLINEAR_STRATA
    ridge_bins = RIDGE_BINS if not setup.model.is_nonlinear else strata
    points = 2 ** int(round(np.log2(8 * strata * strata)))  # ~8 per cell, a power of two (Sobol balance)
    cube = qmc.Sobol(len(dims), scramble=True, seed=seed + 1).random(points)
    logs = ranges[:, 0] + cube * (ranges[:, 1] - ranges[:, 0])
    batch = {n: np.exp(logs[:, i]) for i, n in enumerate(dims)}
    # each point twice: as drawn, and with EI from the spectral match of its own modes (on the
    # ridge of equal frequencies through the record's peaks, where a long window's narrow basins lie)
    centre_kp = prior_centre(KP, setup.measurement.nominal)
    scales = batched_scales(setup, dict(batch, **{KP: np.full(points, centre_kp)}))
    batch = {n: np.concatenate([v, v * scales if n == EI else v]) for n, v in batch.items()}
    cube = np.vstack([cube, cube])
    cube[points:, 0] = (np.log(batch[EI][points:]) - ranges[0, 0]) / (ranges[0, 1] - ranges[0, 0])
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


class ScreenedDesign(StartStrategy):
    """The :data:`DESIGN_KEPT` best points of the screened design (:func:`screened_design`)."""

    name = "screened design"

    def __call__(self, problem, setup, engine):
        return screened_design(problem, setup)
