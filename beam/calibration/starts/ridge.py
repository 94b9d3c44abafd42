"""The walk along the ridge of equal frequencies (:func:`ridge_walk`): the last move of the second
stage of every driven MAP, from the optimum found to its neighbours along the ridge."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from beam.calibration.fit import internal_starts, levenberg_marquardt, newton_polish
from beam.calibration.setup import BeamCalibrationSetup
from beam.calibration.starts.base import SEARCH_GAIN_NATS, effect_names, log_range, pure_damping_parameter
from beam.calibration.starts.spectral import batched_scales, coupled_response
from beam.inference import MapResult, Problem
from beam.physics.effects.base import BENDING_STIFFNESS

EI = BENDING_STIFFNESS.name

__all__ = ["WALK_GAIN_NATS", "WALK_ITERATIONS", "WALK_MAX_STEPS", "WALK_STEPS", "ridge_neighbours", "ridge_walk"]


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
    scales (:func:`batched_scales`) of the neighbour and of ``best`` (so the modes stay where
    ``best`` put them against the record's peaks), k_p by least squares."""
    names = [n for n in effect_names(setup) if not pure_damping_parameter(n)]
    rows = []
    for name in names:
        low, high = log_range(problem, name)
        here = np.log(best[name])
        for step in WALK_STEPS:
            for sign in (1.0, -1.0):
                value = here + sign * step * (high - low)
                if low < value < high:
                    rows.append(dict(best, **{name: float(np.exp(value))}))
    if not rows:
        return []
    batch = {n: np.array([best[n]] + [r[n] for r in rows]) for n in setup.physical_names}
    scales = batched_scales(setup, batch)
    batch[EI] = batch[EI] * scales / scales[0]
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
