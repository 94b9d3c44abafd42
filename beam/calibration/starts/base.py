"""Shared pieces of the start strategies: prior ranges, "barely on" values, the strategy interface.

A start strategy (:class:`StartStrategy`) proposes starting points for the MAP search of a beam
calibration: physical parameters in natural units, each inside its prior's support.
"""

from __future__ import annotations

import numpy as np

from beam.calibration.setup import BeamCalibrationSetup, BeamForwardModel, prior_centre
from beam.inference import Problem
from beam.physics.effects.base import BENDING_STIFFNESS, PATCH_COUPLING
from beam.physics.model import BeamModel

__all__ = ["BARELY_ON", "BASE_NAMES", "DAMPED_AWAY", "SCALE_GRID", "SEARCH_GAIN_NATS", "StartStrategy", "barely_on",
           "clip_inside_prior", "damping_only", "effect_names", "log_range", "model_setup", "prior_centres", "pure_damping_parameter"]

#: Log-posterior gain (nats) by which the searched design's MAP must beat the quick stage's to
#: replace it: far below the 1 nat that tells optima apart, far above the search's tolerance,
#: so that the same basin keeps the quick stage's MAP exactly (the CLI's, the dashboard's preview's
#: and final's, the diagnosis's candidates' MAPs are then one; tests/dashboard/test_one_engine.py).
SEARCH_GAIN_NATS = 1e-3


class StartStrategy:
    """One source of starting points (the interface every strategy implements).

    Attributes
    ----------
    name : str
        Short id, for reports.
    stage : {"quick", "search"}
        ``"quick"``: a start of the first stage of every MAP; ``"search"``: of the second stage
        only (the searched design, :func:`beam.calibration.starts.search.searched_map`).
    nested : bool
        Whether its starts are optima of sub-models (not refined on the short window).
    """

    name = "strategy"
    stage = "quick"
    nested = False

    def __call__(self, problem: Problem, setup: BeamCalibrationSetup, engine) -> list[dict[str, float]]:
        """Starting points (natural units, physical parameters) for ``problem`` of ``setup``;
        ``engine`` (:class:`beam.calibration.engine.Engine`) holds the optima found so far."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


#: Stiffness scale factors searched: a factor 5 either way of the prior centre.
SCALE_GRID = np.exp(np.linspace(np.log(0.2), np.log(5.0), 1201))


#: Where a "barely on" effect parameter sits: this fraction of its log prior range from the end
#: where the effect vanishes.
BARELY_ON = 0.02


#: The parameters of the base model (EI from the spectrum, k_p by least squares in the design).
BASE_NAMES = (BENDING_STIFFNESS.name, PATCH_COUPLING.name)


#: Where a damped-away mode's damping ratio starts: this fraction of its log prior range from the
#: top (as :data:`BARELY_ON` from the other end).
DAMPED_AWAY = 0.02


def prior_centres(setup: BeamCalibrationSetup) -> dict[str, float]:
    """Every physical parameter at its prior centre."""
    return {name: prior_centre(name, setup.measurement.prior_nominal) for name in setup.physical_names}


def clip_inside_prior(problem: Problem, guess: dict[str, float]) -> dict[str, float]:
    out = {}
    for name, value in guess.items():
        prior = problem.parameter(name).prior
        out[name] = float(np.clip(value, prior.lower * (1 + 1e-9), prior.upper * (1 - 1e-9)))
    return out


def effect_names(setup: BeamCalibrationSetup) -> list[str]:
    return [name for name in setup.physical_names if name not in BASE_NAMES]


def log_range(problem: Problem, name: str) -> tuple[float, float]:
    prior = problem.parameter(name).prior
    return float(np.log(prior.lower)), float(np.log(prior.upper))


def barely_on(problem: Problem, name: str) -> float:
    """A parameter's value :data:`BARELY_ON` of its log prior range from the end where its
    effect vanishes (natural units)."""
    from beam.physics.effects import parameter_spec

    low, high = log_range(problem, name)
    fraction = {"low": BARELY_ON, "high": 1.0 - BARELY_ON}.get(parameter_spec(name).absent_at)
    if fraction is None:  # vanishes at the prior's centre (the effective length at the stated one)
        return float(problem.parameter(name).prior.from_internal(problem.parameter(name).prior.internal_centre()))
    return float(np.exp(low + fraction * (high - low)))


def damping_only(effect: str) -> bool:
    """Whether the effect only adds linear damping (it keeps the modes: no new basin)."""
    from beam.physics.effects import EFFECTS

    return EFFECTS[effect].channel is None and all(term.target == "damping" for term in EFFECTS[effect].terms)


def pure_damping_parameter(name: str) -> bool:
    """Whether the parameter's effect only adds damping (:func:`damping_only`)."""
    from beam.physics.effects import effect_of_parameter

    return damping_only(effect_of_parameter(name))


def model_setup(setup: BeamCalibrationSetup, effects: tuple[str, ...], modes: int) -> BeamCalibrationSetup:
    """The setup of the model with ``effects`` and ``modes`` retained modes on the same record,
    window and likelihood."""
    model = BeamModel(setup.measurement.geometry, effects, setup.model.intervals)
    return BeamCalibrationSetup(setup.measurement, setup.window, model.effects, modes, setup.likelihood, model,
                                BeamForwardModel(model, setup.measurement, modes))
